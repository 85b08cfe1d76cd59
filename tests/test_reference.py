"""The dense reference (tests/reference/dense.py) on small cases worked out by hand.

Each test builds a tiny network whose weights make the expected spikes easy to derive from
docs/model.md, and checks one rule. These tests need no engine: they are what makes the
reference trustworthy as the engine's yardstick.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from reference import dense

T0 = 1_000


def make_config(**layers: dict) -> dict:
    """A small network (12 x 10 sensor, static threshold 1) with ``layers`` merged in."""
    config = {
        "version": 1,
        "width": 12,
        "height": 10,
        "padding": "same",
        "conv1": {
            "kernel": 3,
            "maps": 1,
            "threshold": 1.0,
            "lateral_inhibition": True,
            "wta_k": 4,
            "wta_radius": 1,
        },
        "pool1": {"kernel": 2, "stride": 2},
        "conv2": {
            "kernel": 1,
            "maps": 1,
            "threshold": 1.0,
            "lateral_inhibition": True,
            "wta_k": 4,
            "wta_radius": 1,
        },
        "pool2": {"kernel": 1, "stride": 1},
        "conv3": {
            "kernel": 1,
            "maps": 1,
            "threshold": 1.0,
            "lateral_inhibition": True,
            "wta_k": 4,
            "wta_radius": 1,
        },
        "pent": {"mode": "static", "beta": 8.0, "theta_min": 1.0, "estimate": "window"},
        "stdp": {"a_plus": 0.004, "a_minus": -0.003, "a_plus_max": 0.15, "lr_every": 500},
        "detection": {"min_detections": 1},
        "init": {"mean": 0.8, "std": 0.08},
        "gabor": {"sigma": 1.5, "wavelength": 4.0, "gamma": 0.5},
    }
    for name, fields in layers.items():
        if isinstance(fields, dict):
            config[name] = {**config[name], **fields}
        else:
            config[name] = fields
    return config


def pass_through_weights(config: dict, conv1: np.ndarray) -> dict:
    """conv1 as given; conv2 and conv3 1x1 kernels of weight 1 that relay every spike."""
    weights = {"conv1": np.asarray(conv1, dtype=np.float32)}
    previous = conv1.shape[0]
    for name in ("conv2", "conv3"):
        k = config[name]["kernel"]
        maps = config[name]["maps"]
        weights[name] = np.ones((maps, previous, k, k), dtype=np.float32)
        previous = maps
    return weights


def spikes_at(spikes: np.ndarray) -> set[tuple[int, int, int, int]]:
    """``{(t, map, row, col)}`` of a spike array."""
    return {(int(s["t"]), int(s["map"]), int(s["row"]), int(s["col"])) for s in spikes}


def window(*spikes: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Input arrays ``(t, x, y)`` from ``(t, x, y)`` triples, sorted by time."""
    ordered = sorted(spikes, key=lambda s: s[0])
    t = np.array([s[0] for s in ordered], dtype=np.uint64)
    x = np.array([s[1] for s in ordered], dtype=np.uint16)
    y = np.array([s[2] for s in ordered], dtype=np.uint16)
    return t, x, y


def single_tap(k: int, dy: int, dx: int, maps: int = 1) -> np.ndarray:
    """conv1 kernels ``(maps, 1, k, k)`` with one weight of 1 at ``(dy, dx)``."""
    w = np.zeros((maps, 1, k, k), dtype=np.float32)
    w[:, 0, dy, dx] = 1.0
    return w


# ------------------------------------------------------------------------------------------------
# Input and geometry


def test_each_pixel_fires_once_at_its_first_spike() -> None:
    t, x, y = window((T0 + 5, 3, 4), (T0 + 9, 3, 4), (T0 + 7, 1, 2))
    frame = dense.time_embedded_frame(t, x, y, T0, 12, 10)
    assert frame.shape == (1, 10, 12)
    assert frame[0, 4, 3] == 5
    assert frame[0, 2, 1] == 7
    assert np.isinf(frame).sum() == 12 * 10 - 2


@pytest.mark.parametrize("padding", ["same", "valid"])
@pytest.mark.parametrize("k", [3, 4])
def test_conv_is_cross_correlation_with_the_padding_offset(padding: str, k: int) -> None:
    # One weight at (dy, dx) = (0, k - 1): input (iy, ix) reaches output (iy - dy + p_lo,
    # ix - dx + p_lo), per §2, with p_lo = (k - 1) // 2 for same (1 for k = 3 and k = 4) and 0
    # for valid.
    config = make_config(padding=padding, conv1={"kernel": k}, pool1={"kernel": 1, "stride": 1})
    weights = pass_through_weights(config, single_tap(k, 0, k - 1))
    t, x, y = window((T0 + 3, 5, 4))
    out = dense.run_window(config, weights, t, x, y, T0)
    p_lo = 1 if padding == "same" else 0
    assert spikes_at(out["conv1"]) == {(T0 + 3, 0, 4 + p_lo, 5 - (k - 1) + p_lo)}


@pytest.mark.parametrize(("padding", "expected"), [("same", (10, 12)), ("valid", (8, 10))])
def test_conv_output_size_follows_padding(padding: str, expected: tuple[int, int]) -> None:
    config = make_config(padding=padding, pool1={"kernel": 1, "stride": 1})
    weights = pass_through_weights(config, np.ones((1, 1, 3, 3), np.float32))
    # Weight 1 everywhere, threshold 1: every output position that reads a spike fires, so
    # a spike at every pixel lights up the whole output grid.
    cols, rows = np.meshgrid(np.arange(12), np.arange(10))
    t = np.full(120, T0, np.uint64)
    out = dense.run_window(config, weights, t, cols.ravel(), rows.ravel(), T0)
    assert len(out["conv1"]) == expected[0] * expected[1]
    assert out["conv1"]["row"].max() + 1 == expected[0]
    assert out["conv1"]["col"].max() + 1 == expected[1]


def test_same_padding_reaches_the_sensor_edge_and_valid_does_not() -> None:
    # A corner pixel with the kernel's centre tap: in same padding it drives output (0, 0); in
    # valid padding the centre tap of output o reads o + 1, so the corner reaches nothing.
    t, x, y = window((T0, 0, 0))
    for padding, fires in (("same", True), ("valid", False)):
        config = make_config(padding=padding, pool1={"kernel": 1, "stride": 1})
        weights = pass_through_weights(config, single_tap(3, 1, 1))
        out = dense.run_window(config, weights, t, x, y, T0)
        assert (len(out["conv1"]) == 1) is fires


def test_valid_layer_that_does_not_fit_is_an_error() -> None:
    config = make_config(padding="valid", conv1={"kernel": 11})
    weights = pass_through_weights(config, np.ones((1, 1, 11, 11), np.float32))
    t, x, y = window((T0, 0, 0))
    with pytest.raises(ValueError, match="does not fit"):
        dense.run_window(config, weights, t, x, y, T0)


# ------------------------------------------------------------------------------------------------
# Neurons: crossing, same-time spikes, latching


def test_neuron_crosses_when_the_sum_reaches_threshold_and_latches() -> None:
    config = make_config(conv1={"threshold": 1.0}, pool1={"kernel": 1, "stride": 1})
    conv1 = np.zeros((1, 1, 3, 3), np.float32)
    conv1[0, 0, 1, 0] = conv1[0, 0, 1, 1] = conv1[0, 0, 1, 2] = 0.5
    weights = pass_through_weights(config, conv1)
    # Three pixels in a row at (4, 4), (5, 4), (6, 4), times 10, 20, 30: the neuron at (4, 5)
    # reads all three with weight 0.5; it reaches 1.0 at t = 20 and fires once, with V = 1.0.
    t, x, y = window((T0 + 10, 4, 4), (T0 + 20, 5, 4), (T0 + 30, 6, 4))
    out = dense.run_window(config, weights, t, x, y, T0)
    at_centre = out["conv1"][(out["conv1"]["row"] == 4) & (out["conv1"]["col"] == 5)]
    assert len(at_centre) == 1
    assert at_centre["t"][0] == T0 + 20
    assert at_centre["v"][0] == np.float32(1.0)


def test_potential_at_crossing_counts_every_spike_of_that_time() -> None:
    config = make_config(conv1={"threshold": 0.5}, pool1={"kernel": 1, "stride": 1})
    conv1 = np.zeros((1, 1, 3, 3), np.float32)
    conv1[0, 0, 1, :] = [0.25, 0.5, 0.125]
    weights = pass_through_weights(config, conv1)
    # Neuron (4, 5): the spike at (5, 4) alone reaches 0.5, but (4, 4) and (6, 4) arrive at the
    # same time, so V at the crossing is 0.25 + 0.5 + 0.125.
    t, x, y = window((T0 + 7, 4, 4), (T0 + 7, 5, 4), (T0 + 7, 6, 4))
    out = dense.run_window(config, weights, t, x, y, T0)
    spike = out["conv1"][(out["conv1"]["row"] == 4) & (out["conv1"]["col"] == 5)]
    assert spike["v"][0] == np.float32(0.875)
    assert spike["t"][0] == T0 + 7


def test_potentials_are_exact_float64_sums() -> None:
    # 0.5 + (0.5 - 2**-25) = 1 - 2**-25 exactly, below θ = 1. (A float32 sum would round it to
    # 1.0, ties to even, and fire.) §3: decisions use the exact float64 sum.
    config = make_config(conv1={"threshold": 1.0}, pool1={"kernel": 1, "stride": 1})
    conv1 = np.zeros((1, 1, 3, 3), np.float32)
    conv1[0, 0, 1, 1] = 0.5
    conv1[0, 0, 1, 2] = np.float32(0.5 - 2**-25)
    assert np.float32(conv1[0, 0, 1, 1] + conv1[0, 0, 1, 2]) == 1.0  # the float32 trap
    weights = pass_through_weights(config, conv1)
    t, x, y = window((T0 + 1, 5, 4), (T0 + 1, 6, 4))
    out = dense.run_window(config, weights, t, x, y, T0)
    assert conv1_at(out, 4, 5) == set()


def test_below_threshold_never_fires() -> None:
    config = make_config(conv1={"threshold": 2.0})
    weights = pass_through_weights(config, np.ones((1, 1, 3, 3), np.float32))
    t, x, y = window((T0, 3, 3))
    out = dense.run_window(config, weights, t, x, y, T0)
    assert all(len(out[layer]) == 0 for layer in dense.LAYERS)


# ------------------------------------------------------------------------------------------------
# Lateral inhibition


def two_map_conv1(centre0: float, right0: float, centre1: float, right1: float) -> np.ndarray:
    w = np.zeros((2, 1, 3, 3), np.float32)
    w[0, 0, 1, 1], w[0, 0, 1, 2] = centre0, right0
    w[1, 0, 1, 1], w[1, 0, 1, 2] = centre1, right1
    return w


def conv1_at(out: dict, row: int, col: int) -> set[tuple[int, int]]:
    s = out["conv1"]
    sel = s[(s["row"] == row) & (s["col"] == col)]
    return {(int(a["t"]), int(a["map"])) for a in sel}


@pytest.mark.parametrize(
    ("kernels", "winner"),
    [
        # same time, map 1 has the higher potential (1.0 > 0.875): map 1 fires
        ((0.875, 0.0, 0.5, 0.5), 1),
        # same time, map 0 higher
        ((0.5, 0.5, 0.875, 0.0), 0),
        # same time, equal potentials: the lowest map index
        ((0.5, 0.5, 1.0, 0.0), 0),
    ],
)
def test_lateral_inhibition_ties_go_to_potential_then_map(
    kernels: tuple[float, float, float, float], winner: int
) -> None:
    config = make_config(conv1={"maps": 2, "threshold": 0.75}, pool1={"kernel": 1, "stride": 1})
    weights = pass_through_weights(config, two_map_conv1(*kernels))
    # Pixels (5, 4) and (6, 4) at the same time reach neuron (4, 5) through the centre and right
    # taps.
    t, x, y = window((T0 + 4, 5, 4), (T0 + 4, 6, 4))
    out = dense.run_window(config, weights, t, x, y, T0)
    assert conv1_at(out, 4, 5) == {(T0 + 4, winner)}


def test_lateral_inhibition_earliest_crossing_wins_over_higher_potential() -> None:
    config = make_config(conv1={"maps": 2, "threshold": 0.75}, pool1={"kernel": 1, "stride": 1})
    # Map 1 crosses at t = 4 on the centre pixel alone (0.75); map 0 needs both (1.0) and so
    # crosses only at t = 9: map 1 fires, map 0 is inhibited for the rest of the window.
    weights = pass_through_weights(config, two_map_conv1(0.5, 0.5, 0.75, 0.25))
    t, x, y = window((T0 + 4, 5, 4), (T0 + 9, 6, 4))
    out = dense.run_window(config, weights, t, x, y, T0)
    assert conv1_at(out, 4, 5) == {(T0 + 4, 1)}
    # Without lateral inhibition both fire, each at its own crossing.
    config["conv1"]["lateral_inhibition"] = False
    out = dense.run_window(config, weights, t, x, y, T0)
    assert conv1_at(out, 4, 5) == {(T0 + 4, 1), (T0 + 9, 0)}


def test_lateral_inhibition_compares_float64_potentials() -> None:
    # Map 1 reaches 0.5 + (0.5 + 2**-24) = 1 + 2**-24, map 0 reaches 1.0: equal in float32, but
    # map 1 is higher in float64 and fires; its reported v is the float32 rounding, 1.0.
    config = make_config(conv1={"maps": 2, "threshold": 1.0}, pool1={"kernel": 1, "stride": 1})
    conv1 = two_map_conv1(1.0, 0.0, 0.5, float(np.float32(0.5 + 2**-24)))
    assert conv1[1, 0, 1, 2] == 0.5 + 2**-24
    weights = pass_through_weights(config, conv1)
    t, x, y = window((T0 + 4, 5, 4), (T0 + 4, 6, 4))
    out = dense.run_window(config, weights, t, x, y, T0)
    assert conv1_at(out, 4, 5) == {(T0 + 4, 1)}
    s = out["conv1"]
    assert s["v"][(s["row"] == 4) & (s["col"] == 5)].tolist() == [1.0]
    # The same comparison orders the winners in training.
    config["conv1"].update(wta_k=1, wta_radius=5)
    winners, _ = dense.stdp_step(config, weights, "conv1", t, x, y, T0)
    assert [(int(w["map"]), int(w["row"]), int(w["col"])) for w in winners] == [(1, 4, 5)]


def test_lateral_inhibition_is_per_position() -> None:
    config = make_config(conv1={"maps": 2, "threshold": 1.0}, pool1={"kernel": 1, "stride": 1})
    w = np.zeros((2, 1, 3, 3), np.float32)
    w[0, 0, 1, 1] = 1.0  # map 0 reads the pixel at its own position
    w[1, 0, 1, 2] = 1.0  # map 1 reads the pixel to its right
    weights = pass_through_weights(config, w)
    t, x, y = window((T0 + 2, 5, 4))
    out = dense.run_window(config, weights, t, x, y, T0)
    assert spikes_at(out["conv1"]) == {(T0 + 2, 0, 4, 5), (T0 + 2, 1, 4, 4)}


# ------------------------------------------------------------------------------------------------
# Pooling and propagation through the layers


def test_pool_fires_at_the_first_spike_of_its_block_per_map() -> None:
    config = make_config(pool1={"kernel": 3, "stride": 2})
    weights = pass_through_weights(config, single_tap(3, 1, 1))
    # conv1 relays each pixel (centre tap). Pool (r, c) reads rows 2r..2r+2, cols 2c..2c+2, so
    # blocks overlap: (row 1, col 3) at t=8 lies in pool (0, 1) only; (row 2, col 4) at t=5 in
    # pools (0..1, 1..2); (row 0, col 6) at t=6 in pools (0, 2) and (0, 3).
    t, x, y = window((T0 + 8, 3, 1), (T0 + 5, 4, 2), (T0 + 6, 6, 0))
    out = dense.run_window(config, weights, t, x, y, T0)
    assert spikes_at(out["pool1"]) == {
        (T0 + 5, 0, 0, 1),
        (T0 + 5, 0, 0, 2),
        (T0 + 5, 0, 1, 1),
        (T0 + 5, 0, 1, 2),
        (T0 + 6, 0, 0, 3),
    }
    assert np.all(out["pool1"]["v"] == 0)


def test_same_pool_covers_the_ragged_edge() -> None:
    # 12 x 10 sensor, pool 4 stride 4, same: ceil gives 3 x 3 pools; the last row of pools reads
    # rows 8..9 only.
    config = make_config(pool1={"kernel": 4, "stride": 4})
    weights = pass_through_weights(config, single_tap(3, 1, 1))
    t, x, y = window((T0 + 1, 11, 9))
    out = dense.run_window(config, weights, t, x, y, T0)
    assert spikes_at(out["pool1"]) == {(T0 + 1, 0, 2, 2)}
    config["padding"] = "valid"  # floor((10 - 4) / 4) + 1 = 2 rows: the corner is not pooled
    config["conv1"]["kernel"] = 1
    weights = pass_through_weights(config, single_tap(1, 0, 0))
    out = dense.run_window(config, weights, t, x, y, T0)
    assert len(out["pool1"]) == 0


def test_a_spike_reaches_the_next_layer_at_its_own_time() -> None:
    config = make_config(pool1={"kernel": 2, "stride": 2})
    weights = pass_through_weights(config, single_tap(3, 1, 1))
    t, x, y = window((T0 + 17, 7, 5))
    out = dense.run_window(config, weights, t, x, y, T0)
    for layer in dense.LAYERS:
        assert out[layer]["t"].tolist() == [T0 + 17], layer
    assert (int(out["conv3"]["row"][0]), int(out["conv3"]["col"][0])) == (5 // 2, 7 // 2)


def test_spikes_are_sorted_by_time_map_row_col() -> None:
    config = make_config(
        conv1={"maps": 2, "lateral_inhibition": False}, pool1={"kernel": 1, "stride": 1}
    )
    w = np.zeros((2, 1, 3, 3), np.float32)
    w[:, 0, 1, 1] = 1.0
    weights = pass_through_weights(config, w)
    t, x, y = window((T0 + 3, 9, 1), (T0 + 3, 2, 8), (T0 + 1, 5, 5))
    out = dense.run_window(config, weights, t, x, y, T0)
    keys = [(int(s["t"]), int(s["map"]), int(s["row"]), int(s["col"])) for s in out["conv1"]]
    assert keys == sorted(keys)
    assert len(keys) == 6


# ------------------------------------------------------------------------------------------------
# conv1: Gabor kernels and PENT


def test_gabor_kernels_are_scaled_oriented_and_follow_the_formula() -> None:
    config = make_config(conv1={"kernel": 5, "maps": 4})
    kernels = dense.gabor_kernels(config)
    assert kernels.shape == (4, 1, 5, 5)
    assert kernels.dtype == np.float32
    assert np.all(kernels.min(axis=(1, 2, 3)) == 0)
    assert np.all(kernels.max(axis=(1, 2, 3)) == 1)
    # 0°: the wave runs along x, so the kernel is brightest down the centre column and
    # symmetric left-right and up-down (it responds to vertical edges).
    k0 = kernels[0, 0]
    assert np.all(k0[:, 2] == k0.max(axis=1))
    assert np.array_equal(k0, k0[:, ::-1])
    assert np.array_equal(k0, k0[::-1, :])
    # 90° is 0° turned a quarter; 135° mirrors 45° left-right.
    np.testing.assert_allclose(kernels[2, 0], k0.T, atol=1e-6)
    np.testing.assert_allclose(kernels[3, 0], kernels[1, 0][:, ::-1], atol=1e-6)

    # One value straight from §4's formula: 45°, x = 1 (right), y = -2 (up).
    sigma, lam, gamma = 1.5, 4.0, 0.5
    th = math.pi / 4

    def g(x: float, y: float) -> float:
        xr = x * math.cos(th) + y * math.sin(th)
        yr = -x * math.sin(th) + y * math.cos(th)
        return math.exp(-(xr**2 + gamma**2 * yr**2) / (2 * sigma**2)) * math.cos(
            2 * math.pi * xr / lam
        )

    values = [g(x, y) for x in range(-2, 3) for y in range(-2, 3)]
    expected = (g(1, -2) - min(values)) / (max(values) - min(values))
    assert kernels[1, 0, 0, 3] == pytest.approx(expected, abs=1e-6)


def test_pent_threshold_formula_and_floor() -> None:
    config = make_config(pent={"mode": "pent", "beta": 8.0, "theta_min": 1.0})
    conv1 = np.full((2, 1, 3, 3), 0.5, np.float32)
    conv1[1] = 0.25
    area = 12 * 10
    # θ1 = max(θ_min, β · N_in / (W·H) · K1), K1 = 4.5 for map 0 and 2.25 for map 1.
    theta = dense.pent_thresholds(config, conv1, 20)
    assert theta.dtype == np.float32
    assert theta[0] == np.float32(8.0 * (20 / area) * 4.5)
    assert theta[1] == np.float32(8.0 * (20 / area) * 2.25)
    # A sparse window falls back to θ_min.
    assert np.all(dense.pent_thresholds(config, conv1, 2) == np.float32(1.0))
    assert np.all(dense.pent_thresholds(config, conv1, 0) == np.float32(1.0))


def test_pent_in_run_window_counts_the_spikes_given_and_honours_n_in() -> None:
    config = make_config(
        pent={"mode": "pent", "beta": 40.0, "theta_min": 0.5}, pool1={"kernel": 1, "stride": 1}
    )
    weights = pass_through_weights(config, single_tap(3, 1, 1))
    # Three spikes given, one a repeat of pixel (7, 7): N_in = 3 (§4: the number of spikes
    # given), θ1 = 40 · 3/120 · 1 = 1.0, so the relay fires, once per pixel.
    t, x, y = window((T0 + 1, 2, 2), (T0 + 2, 7, 7), (T0 + 3, 7, 7))
    out = dense.run_window(config, weights, t, x, y, T0)
    assert out["thresholds"].tolist() == [np.float32(40.0 * (3 / 120) * 1.0)]
    assert spikes_at(out["conv1"]) == {(T0 + 1, 0, 2, 2), (T0 + 2, 0, 7, 7)}
    # n_in = 6 doubles the threshold above the relay weight: nothing fires.
    out = dense.run_window(config, weights, t, x, y, T0, n_in=6)
    assert out["thresholds"][0] == np.float32(40.0 * (6 / 120))
    assert len(out["conv1"]) == 0


def test_static_mode_uses_the_conv1_threshold_for_every_map() -> None:
    config = make_config(conv1={"maps": 3, "threshold": 2.5}, pent={"mode": "static"})
    conv1 = np.ones((3, 1, 3, 3), np.float32)
    weights = pass_through_weights(config, conv1)
    t, x, y = window(*[(T0 + i, i, 0) for i in range(12)])
    out = dense.run_window(config, weights, t, x, y, T0)
    assert out["thresholds"].tolist() == [2.5, 2.5, 2.5]


# ------------------------------------------------------------------------------------------------
# Detection


def test_receptive_field_composes_the_layers_and_clips_to_the_sensor() -> None:
    config = make_config(
        conv1={"kernel": 3},
        pool1={"kernel": 2, "stride": 2},
        conv2={"kernel": 3},
        pool2={"kernel": 1, "stride": 1},
        conv3={"kernel": 1},
    )
    # conv3 (2, 3) reads pool2 (2, 3) -> conv2 (2, 3) -> pool1 rows 1..3, cols 2..4 -> conv1
    # rows 2..7, cols 4..9 -> sensor rows 1..8, cols 3..10.
    assert dense.receptive_field(config, "conv3", 2, 3) == (3, 1, 10, 8)
    # At the corner the field is clipped: pool1 rows -1..1 -> 0..1 -> conv1 0..3 -> sensor 0..4.
    assert dense.receptive_field(config, "conv3", 0, 0) == (0, 0, 4, 4)
    # Overlapping pools (kernel 3, stride 2): pool1 rows 1..3 -> conv1 rows 2..8 -> sensor
    # rows 1..9; cols 2..4 -> conv1 4..10 -> sensor 3..11.
    config["pool1"] = {"kernel": 3, "stride": 2}
    assert dense.receptive_field(config, "conv3", 2, 3) == (3, 1, 11, 9)


def test_detection_carries_centre_and_causal_box() -> None:
    config = make_config(pool1={"kernel": 2, "stride": 2}, conv1={"threshold": 1.0})
    weights = pass_through_weights(config, np.ones((1, 1, 3, 3), np.float32))
    # conv3 (2, 3) reads pool1 (2, 3) -> conv1 rows 4..5, cols 6..7 -> sensor rows 3..6, cols 5..8.
    t, x, y = window((T0 + 1, 6, 5), (T0 + 1, 8, 3), (T0 + 9, 3, 6), (T0 + 1, 11, 9))
    out = dense.run_window(config, weights, t, x, y, T0)
    assert dense.receptive_field(config, "conv3", 2, 3) == (5, 3, 8, 6)
    det = out["detections"]
    assert len(det) == len(out["conv3"])
    one = det[(det["row"] == 2) & (det["col"] == 3)]
    assert len(one) == 1
    assert int(one["t"][0]) == T0 + 1
    # The centre of the half-open field [5, 9) × [3, 7).
    assert (one["x"][0], one["y"][0]) == (7.0, 5.0)
    # Inside the field with t <= T0 + 1: (6, 5) and (8, 3); (3, 6) is outside the field. The box
    # is half-open: one past the largest x and y.
    assert (one["x0"][0], one["y0"][0], one["x1"][0], one["y1"][0]) == (6, 3, 9, 6)


# ------------------------------------------------------------------------------------------------
# Training: winners


def wta_config(k: int = 8, radius: int = 1) -> dict:
    """conv1 with 1x1 kernels as the trained layer: each neuron reads exactly one pixel."""
    return make_config(
        conv1={"kernel": 1, "maps": 3, "threshold": 0.5, "wta_k": k, "wta_radius": radius}
    )


def wta_weights(config: dict) -> dict:
    # Map m has weight (m + 2) / 4, so every map crosses wherever a pixel fires, with potentials
    # 0.5 < 0.75 < 1.0: map 2 leads on potential.
    conv1 = np.array([0.5, 0.75, 1.0], np.float32).reshape(3, 1, 1, 1)
    return pass_through_weights(config, conv1)


def winner_keys(winners: np.ndarray) -> list[tuple[int, int, int, int]]:
    return [(int(w["t"]), int(w["map"]), int(w["row"]), int(w["col"])) for w in winners]


def test_winners_by_time_then_potential_one_per_map_outside_radius() -> None:
    config = wta_config(k=8, radius=1)
    weights = wta_weights(config)
    t, x, y = window((T0 + 1, 2, 2), (T0 + 1, 3, 2), (T0 + 2, 8, 8), (T0 + 3, 5, 5))
    winners, _ = dense.stdp_step(config, weights, "conv1", t, x, y, T0)
    # t = 1: map 2 (highest V) at (2, 2) — the lowest col among equals; (2, 3) is within radius.
    # t = 2: map 2 is taken; map 1 (next V) at (8, 8). t = 3: map 0 at (5, 5).
    assert winner_keys(winners) == [(T0 + 1, 2, 2, 2), (T0 + 2, 1, 8, 8), (T0 + 3, 0, 5, 5)]
    assert winners["v"].tolist() == [1.0, 0.75, 0.5]


def test_winners_stop_at_k_and_radius_zero_allows_neighbours() -> None:
    config = wta_config(k=2, radius=0)
    weights = wta_weights(config)
    t, x, y = window((T0 + 1, 2, 2), (T0 + 1, 3, 2), (T0 + 5, 8, 8))
    winners, _ = dense.stdp_step(config, weights, "conv1", t, x, y, T0)
    # Radius 0 only blocks the same position: map 2 at (2, 2), then map 2 is taken so map 2 at
    # (2, 3) is refused; map 1 at (2, 2) is at distance 0; map 1 at (2, 3) is accepted. k = 2 stops.
    assert winner_keys(winners) == [(T0 + 1, 2, 2, 2), (T0 + 1, 1, 2, 3)]


def test_trained_layer_runs_without_lateral_inhibition() -> None:
    config = wta_config(k=3, radius=0)
    weights = wta_weights(config)
    # One pixel: in inference only map 2 fires there; as the trained layer all three maps cross
    # there, and all but map 2 are within radius 0 of the first winner.
    t, x, y = window((T0 + 1, 4, 4))
    assert len(dense.run_window(config, weights, t, x, y, T0)["conv1"]) == 1
    winners, _ = dense.stdp_step(config, weights, "conv1", t, x, y, T0)
    assert winner_keys(winners) == [(T0 + 1, 2, 4, 4)]


def test_winners_tie_on_time_and_potential_go_to_the_lowest_map_then_row() -> None:
    config = make_config(
        conv1={"kernel": 1, "maps": 2, "threshold": 0.5, "wta_k": 4, "wta_radius": 0}
    )
    weights = pass_through_weights(config, np.full((2, 1, 1, 1), 0.75, np.float32))
    t, x, y = window((T0 + 1, 1, 6), (T0 + 1, 9, 3))
    winners, _ = dense.stdp_step(config, weights, "conv1", t, x, y, T0)
    assert winner_keys(winners) == [(T0 + 1, 0, 3, 9), (T0 + 1, 1, 6, 1)]


# ------------------------------------------------------------------------------------------------
# Training: STDP


def expected_update(w: float, a: float) -> np.float32:
    """§6's expression, float32 left to right, then clipped."""
    w32, a32 = np.float32(w), np.float32(a)
    return np.clip(w32 + ((a32 * w32) * (np.float32(1) - w32)), 0, 1).astype(np.float32)


def test_stdp_ltp_before_ltd_after_and_padding_ltd() -> None:
    config = make_config(
        conv1={"kernel": 3, "maps": 1, "threshold": 1.5, "wta_k": 1, "wta_radius": 0}
    )
    conv1 = np.full((1, 1, 3, 3), 0.5, np.float32)
    conv1[0, 0, 1, 1] = 0.75
    weights = pass_through_weights(config, conv1)
    # Neuron (0, 0) at the corner: taps dy = 0 or dx = 0 read padding. Pixels (0,0) t=1 and (1,0)
    # t=2 bring it to 0.75 + 0.5 + ... : (0,0) via the centre tap (0.75), (1,0) via (1,2) (0.5),
    # (0,1) at t=2 via (2,1) (0.5): V = 1.75 >= 1.5 at t = 2. (1, 1) fires later, at t = 9.
    t, x, y = window((T0 + 1, 0, 0), (T0 + 2, 1, 0), (T0 + 2, 0, 1), (T0 + 9, 1, 1))
    winners, new = dense.stdp_step(config, weights, "conv1", t, x, y, T0, a_plus=0.5, a_minus=-0.25)
    assert winner_keys(winners) == [(T0 + 2, 0, 0, 0)]
    assert winners["v"][0] == np.float32(1.75)
    w = new["conv1"][0, 0]
    ltp = {(1, 1), (1, 2), (2, 1)}  # fired at or before t_w
    for dy in range(3):
        for dx in range(3):
            a = 0.5 if (dy, dx) in ltp else -0.25  # (2, 2) fired after; others are padding
            assert w[dy, dx] == expected_update(conv1[0, 0, dy, dx], a), (dy, dx)
    assert new["conv2"] is not weights["conv2"]
    assert np.array_equal(new["conv2"], weights["conv2"])


def test_stdp_touches_only_winner_kernels_and_clips() -> None:
    config = make_config(
        conv1={"kernel": 1, "maps": 2, "threshold": 0.75, "wta_k": 2, "wta_radius": 0}
    )
    conv1 = np.array([0.5, 0.25], np.float32).reshape(2, 1, 1, 1)
    weights = pass_through_weights(config, conv1)
    t, x, y = window((T0 + 1, 4, 4))
    winners, new = dense.stdp_step(config, weights, "conv1", t, x, y, T0, a_plus=3.0)
    # Both weights are below the threshold 0.75: nothing crosses, nothing changes.
    assert len(winners) == 0
    assert np.array_equal(new["conv1"], conv1)
    config["conv1"]["threshold"] = 0.5
    winners, new = dense.stdp_step(config, weights, "conv1", t, x, y, T0, a_plus=3.0)
    assert winner_keys(winners) == [(T0 + 1, 0, 4, 4)]
    # 0.5 + 3 · 0.5 · 0.5 = 1.25, clipped to 1; map 1 did not win and keeps its weight.
    assert new["conv1"].ravel().tolist() == [1.0, 0.25]


def test_stdp_of_conv2_reads_pool1_times_and_keeps_weights_in_range() -> None:
    config = make_config(
        conv2={"kernel": 3, "maps": 2, "threshold": 1.0, "wta_k": 2, "wta_radius": 0}
    )
    weights = pass_through_weights(config, single_tap(3, 1, 1))
    weights["conv2"] = np.full((2, 1, 3, 3), 0.5, np.float32)
    # pool1 (2x2) turns pixels (4, 4) t=1 and (6, 4) t=1 into pool1 (2, 2) and (2, 3) at t=1; pool1
    # (3, 3) fires at t=5 from pixel (7, 7). conv2 (2, 2) reads pool1 rows 1..3, cols 1..3 and
    # reaches 1.0 at t = 1, and so do its neighbours that read both pool1 spikes; the first in
    # order (map 0, lowest row and col) wins.
    t, x, y = window((T0 + 1, 4, 4), (T0 + 1, 6, 4), (T0 + 5, 7, 7))
    winners, new = dense.stdp_step(config, weights, "conv2", t, x, y, T0)
    first = winner_keys(winners)[0]
    assert first[:2] == (T0 + 1, 0)
    row, col = first[2], first[3]
    kernel = new["conv2"][0, 0]
    pool1 = {(2, 2): 1, (2, 3): 1, (3, 3): 5}
    for dy in range(3):
        for dx in range(3):
            fired = pool1.get((row - 1 + dy, col - 1 + dx))
            a = 0.004 if fired is not None and fired <= 1 else -0.003
            assert kernel[dy, dx] == expected_update(0.5, a)
    assert np.all((new["conv2"] >= 0) & (new["conv2"] <= 1))


def test_learning_rate_schedule_doubles_up_to_the_cap_and_keeps_the_ratio() -> None:
    config = make_config(
        stdp={"a_plus": 0.004, "a_minus": -0.003, "a_plus_max": 0.015, "lr_every": 2}
    )
    rates = [dense.learning_rates(config, n) for n in range(7)]
    a_plus = [a for a, _ in rates]
    assert a_plus == [0.004, 0.004, 0.008, 0.008, 0.015, 0.015, 0.015]
    for a, b in rates:
        assert b == -0.003 * (a / 0.004)


def test_convergence_is_the_mean_of_w_times_one_minus_w() -> None:
    assert dense.convergence(np.array([0.0, 1.0, 0.5, 0.5])) == pytest.approx(0.125)


def test_the_reference_does_not_mutate_its_inputs() -> None:
    config = wta_config()
    weights = wta_weights(config)
    before = copy.deepcopy(weights)
    t, x, y = window((T0 + 1, 2, 2))
    dense.stdp_step(config, weights, "conv1", t, x, y, T0)
    for name, w in before.items():
        assert np.array_equal(weights[name], w)
