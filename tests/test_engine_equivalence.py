"""The event-driven engine equals the dense reference (issue 3, "Must show: Equivalence").

On random small networks (sensor 20x15 to 40x30, small kernels and map counts, same and valid
padding, PENT and static thresholds, lateral inhibition on and off, random thresholds) and random
windows with many equal timestamps, ``uavsnn.network.Network`` must give exactly what
``tests/reference/dense.py`` gives: the same spikes per layer with the same times and the same
float32 potentials, the same conv1 thresholds and detections, and in training the same winners
in the same order and bit-identical weights.

Weights. Potentials are float64 sums of float32 weights, exact whatever the order of addition
(docs/model.md §3) as long as every nonzero weight is at least 2**-21 and a neuron has fewer than
2**9 inputs, which these small networks keep to. Half of the networks draw arbitrary float32
weights; the other half draw multiples of 1/64, whose sums land exactly on thresholds (also
multiples of 1/64) and on each other, so that ``V >= θ`` at equality and the ties of lateral
inhibition and winner-take-all (equal time, equal potential) are common rather than never seen.
Some networks use the real Gabor kernels in conv1.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from reference import dense

network = pytest.importorskip(
    "uavsnn.network", reason="the engine's uavsnn.network (issue 3) is not built in this checkout"
)

QUANTUM = 64  # grid weights and thresholds are multiples of 1 / QUANTUM (see the docstring)
SMALLEST_EXACT = 2.0**-21  # nonzero weights at least this keep float64 sums exact (§3)


# ------------------------------------------------------------------------------------------------
# Random networks


def _conv_out(padding: str, size: int, k: int) -> int:
    return size if padding == "same" else size - k + 1


def _pool_out(padding: str, size: int, k: int, s: int) -> int:
    return math.ceil(size / s) if padding == "same" else (size - k) // s + 1


@st.composite
def configs(draw: st.DrawFn) -> dict:
    """A small random network config that fits its sensor under its padding."""
    config = network.default_config()
    width = draw(st.integers(20, 40))
    height = draw(st.integers(15, 30))
    padding = draw(st.sampled_from(["same", "valid"]))
    config.update(width=width, height=height, padding=padding)
    size = min(width, height)  # the tighter axis decides what fits
    channels = 1
    limits = {"conv1": (5, 4), "conv2": (4, 5), "conv3": (3, 4)}
    for layer in dense.LAYERS:
        if layer.startswith("pool"):
            k = draw(st.integers(1, min(3, size)))
            s = draw(st.integers(1, 3))
            config[layer] = {"kernel": k, "stride": s}
            size = _pool_out(padding, size, k, s)
            continue
        max_k, max_maps = limits[layer]
        k = draw(st.integers(1, min(max_k, size)))
        maps = draw(st.integers(1, max_maps))
        # Threshold: a random share of the largest potential (C·k·k), on the 1/64 grid.
        share = draw(st.sampled_from([0.03, 0.06, 0.1, 0.15, 0.25, 0.4]))
        threshold = max(1, round(share * channels * k * k * QUANTUM)) / QUANTUM
        config[layer] = {
            "kernel": k,
            "maps": maps,
            "threshold": threshold,
            "lateral_inhibition": draw(st.booleans()),
            "wta_k": draw(st.integers(1, 6)),
            "wta_radius": draw(st.integers(0, 3)),
        }
        size = _conv_out(padding, size, k)
        channels = maps
    config["pent"] = {
        "mode": draw(st.sampled_from(["pent", "static"])),
        "beta": draw(st.sampled_from([1.0, 2.0, 4.0, 8.0])),
        "theta_min": draw(st.integers(1, 2 * QUANTUM)) / QUANTUM,
        "estimate": "window",
    }
    config["stdp"] = {
        **config["stdp"],
        "a_plus": draw(st.sampled_from([0.004, 0.05, 0.5])),
        "a_minus": draw(st.sampled_from([-0.003, -0.04, -0.4])),
    }
    return config


def weights_for(config: dict, draw: st.DrawFn) -> dict[str, np.ndarray]:
    """Random kernels in [0, 1], on the 1/64 grid or free, each layer biased high or low."""
    weights = {}
    channels = 1
    on_grid = draw(st.booleans())
    for layer in dense.CONV_LAYERS:
        k, maps = config[layer]["kernel"], config[layer]["maps"]
        if layer == "conv1" and draw(st.integers(0, 3)) == 0:
            weights[layer] = dense.gabor_kernels(config)
            continue
        rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
        low = draw(st.sampled_from([0.0, 0.25, 0.5]))
        w = rng.uniform(low, 1.0, size=(maps, channels, k, k))
        if on_grid:
            w = np.round(w * QUANTUM) / QUANTUM
        w[rng.random(w.shape) < 0.1] = 0.0  # some silent synapses
        w = w.astype(np.float32)
        w[w < SMALLEST_EXACT] = 0.0
        weights[layer] = w
        channels = maps
    return weights


@st.composite
def windows(draw: st.DrawFn, config: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """A window's input spikes ``(t, x, y, t0)``: distinct pixels, sorted by t, many equal times.

    Part of the spikes fall in a random dense patch so that activity reaches the deep layers;
    times come from a short span so that many of them coincide.
    """
    width, height = config["width"], config["height"]
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    t0 = draw(st.sampled_from([0, 1, 1_000_000, 2**40]))
    span = draw(st.sampled_from([1, 2, 5, 50, 5_000]))
    density = draw(st.sampled_from([0.0, 0.02, 0.1, 0.3]))
    active = rng.random((height, width)) < density
    pw, ph = rng.integers(3, width // 2 + 1), rng.integers(3, height // 2 + 1)
    px, py = rng.integers(0, width - pw + 1), rng.integers(0, height - ph + 1)
    patch_density = draw(st.sampled_from([0.0, 0.5, 0.9]))
    active[py : py + ph, px : px + pw] |= rng.random((ph, pw)) < patch_density
    y, x = np.nonzero(active)
    order = rng.permutation(len(x))  # arrival order among equal times is random
    x, y = x[order], y[order]
    t = t0 + rng.integers(0, span, size=len(x))
    by_time = np.argsort(t, kind="stable")
    return (
        t[by_time].astype(np.uint64),
        x[by_time].astype(np.uint16),
        y[by_time].astype(np.uint16),
        t0,
    )


@st.composite
def cases(draw: st.DrawFn) -> tuple[dict, dict, tuple]:
    config = draw(configs())
    weights = weights_for(config, draw)
    return config, weights, draw(windows(config))


def engine_for(config: dict, weights: dict) -> Any:
    net = network.Network(config)
    for layer, w in weights.items():
        net.set_weights(layer, w)
    return net


# ------------------------------------------------------------------------------------------------
# Comparison


def _field(trace: Any, name: str) -> np.ndarray:
    """One entry of a WindowTrace, whether it exposes attributes or a mapping."""
    value = getattr(trace, name, None)
    if value is None:
        value = trace[name]
    return np.asarray(value)


def assert_same_spikes(engine: np.ndarray, reference: np.ndarray, what: str) -> None:
    assert engine.dtype.names is not None, f"{what}: not a structured array"
    for field in ("t", "map", "row", "col", "v"):
        got, want = engine[field], reference[field]
        assert len(got) == len(want), f"{what}: {len(got)} spikes, reference {len(want)}"
        assert np.array_equal(got.astype(want.dtype), want), (
            f"{what}.{field} differs: engine {got.tolist()[:20]}, reference {want.tolist()[:20]}"
        )
    assert engine["v"].dtype == np.float32, f"{what}.v is {engine['v'].dtype}"


def assert_same_detections(engine: np.ndarray, reference: np.ndarray) -> None:
    assert len(engine) == len(reference), f"{len(engine)} detections, reference {len(reference)}"
    names = set(engine.dtype.names or ())
    for field in ("t", "map", "row", "col", "x", "y", "x0", "y0", "x1", "y1"):
        if field in names:
            got = engine[field].astype(np.float64)
            want = reference[field].astype(np.float64)
            assert np.array_equal(got, want), (
                f"detections.{field}: engine {got.tolist()[:10]}, reference {want.tolist()[:10]}"
            )


# ------------------------------------------------------------------------------------------------
# The properties


@given(case=cases(), n_in=st.one_of(st.none(), st.integers(0, 2_000)))
def test_run_window_matches_the_reference(case: tuple, n_in: int | None) -> None:
    config, weights, (t, x, y, t0) = case
    net = engine_for(config, weights)
    trace = net.run_window(t, x, y, t0, n_in=n_in)
    want = dense.run_window(config, weights, t, x, y, t0, n_in=n_in)
    for layer in dense.LAYERS:
        assert_same_spikes(_field(trace, layer), want[layer], layer)
    thresholds = _field(trace, "thresholds")
    assert thresholds.dtype == np.float32
    assert np.array_equal(thresholds, want["thresholds"])
    assert_same_detections(_field(trace, "detections"), want["detections"])


@given(
    case=cases(),
    layer=st.sampled_from(dense.CONV_LAYERS),
    n_in=st.one_of(st.none(), st.integers(0, 2_000)),
)
def test_stdp_step_matches_the_reference(case: tuple, layer: str, n_in: int | None) -> None:
    config, weights, (t, x, y, t0) = case
    net = engine_for(config, weights)
    winners = np.asarray(net.stdp_step(layer, t, x, y, t0, n_in=n_in))
    want, new = dense.stdp_step(config, weights, layer, t, x, y, t0, n_in=n_in)
    assert_same_spikes(winners, want, f"{layer} winners")
    for name in dense.CONV_LAYERS:
        got = net.weights(name)
        assert got.dtype == np.float32
        assert np.array_equal(got, new[name]), f"{name} weights differ after training {layer}"


@given(config=configs(), layer=st.sampled_from(dense.CONV_LAYERS), data=st.data())
def test_consecutive_stdp_steps_match_the_reference(
    config: dict, layer: str, data: st.DataObject
) -> None:
    # Each step starts from the weights the previous step left, off any grid by then.
    weights = weights_for(config, data.draw)
    net = engine_for(config, weights)
    for step in range(3):
        t, x, y, t0 = data.draw(windows(config))
        winners = np.asarray(net.stdp_step(layer, t, x, y, t0))
        want, weights = dense.stdp_step(config, weights, layer, t, x, y, t0)
        assert_same_spikes(winners, want, f"step {step}: {layer} winners")
        assert np.array_equal(net.weights(layer), weights[layer]), f"step {step}: weights"


def test_default_conv1_holds_the_gabor_kernels() -> None:
    net = network.Network()
    # Both compute the kernels in float64 and round to float32; the engine's libm and NumPy may
    # differ in the last float64 bit, which can flip a float32 rounding: hence a tolerance of
    # about one float32 step near 1.
    np.testing.assert_allclose(
        net.weights("conv1"), dense.gabor_kernels(net.config), rtol=0, atol=1e-7
    )
