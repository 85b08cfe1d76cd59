"""The network's Python face: config, hand-computed cases per layer, STDP, batch inference,
training, model files, and typed errors for bad input (docs/model.md, docs/api.md)."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from reference.columns import WindowColumns

import uavsnn
from uavsnn.network import (
    DETECTION_DTYPE,
    LAYERS,
    SPIKE_DTYPE,
    Inference,
    Network,
    WindowTrace,
    default_config,
)


def make_windows(
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
    sensor_size: tuple[int, int],
    length_us: int,
    t0: list[int],
) -> WindowColumns:
    n_preceding = np.array([max(0, len(p[0]) - 3) for p in parts], dtype=np.int64)
    return WindowColumns.of_parts(parts, sensor_size, length_us, t0, n_preceding)


def small_config(**changes: Any) -> dict[str, Any]:
    """Table 1 on a 48x36 sensor with lower thresholds, so that every layer fires."""
    c = default_config()
    c.update(width=48, height=36)
    c["pent"]["theta_min"] = 2.0
    c["conv2"]["threshold"] = 6.0
    c["conv3"]["threshold"] = 2.0
    for key, value in changes.items():
        if isinstance(value, dict):
            c[key].update(value)
        else:
            c[key] = value
    return c


def random_window(
    rng: np.random.Generator, width: int, height: int, t0: int, length: int, n_lines: int = 6
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Short random line segments (structure that Gabor kernels see) plus noise, first event
    per pixel, sorted by time (many equal times)."""
    xs, ys, ts = [], [], []
    for _ in range(n_lines):
        x0, y0 = rng.integers(0, width), rng.integers(0, height)
        angle = rng.uniform(0, np.pi)
        start = rng.integers(0, length // 2)
        for step in range(int(rng.integers(4, 14))):
            xs.append(round(x0 + step * np.cos(angle)))
            ys.append(round(y0 + step * np.sin(angle)))
            ts.append(t0 + start + step * int(rng.integers(0, 4)))
    n_noise = int(rng.integers(0, width * height // 50 + 1))
    xs += list(rng.integers(0, width, n_noise))
    ys += list(rng.integers(0, height, n_noise))
    ts += list(t0 + rng.integers(0, length, n_noise))
    x, y, t = np.array(xs), np.array(ys), np.array(ts)
    keep = (x >= 0) & (x < width) & (y >= 0) & (y < height)
    x, y, t = x[keep], y[keep], t[keep]
    order = np.argsort(t, kind="stable")
    x, y, t = x[order], y[order], t[order]
    _, first = np.unique(y * width + x, return_index=True)
    first.sort()
    return t[first].astype(np.uint64), x[first].astype(np.uint16), y[first].astype(np.uint16)


# ------------------------------------------------------------------------------------ config


def test_default_config_is_table_1() -> None:
    c = default_config()
    assert c["version"] == 1
    assert (c["width"], c["height"]) == (240, 180)
    table1 = [("conv1", 5, 4), ("conv2", 10, 20), ("conv3", 5, 10)]
    for layer, kernel, maps in table1:
        assert (c[layer]["kernel"], c[layer]["maps"]) == (kernel, maps)
    assert (c["pool1"]["kernel"], c["pool1"]["stride"]) == (5, 5)
    assert (c["conv2"]["threshold"], c["conv3"]["threshold"]) == (45.0, 3.0)
    assert Network().config == c
    json.dumps(c)


def test_partial_config_takes_defaults_and_other_sensor_sizes() -> None:
    net = Network({"width": 1280, "height": 720})
    assert net.shapes["conv1"] == (4, 720, 1280)
    assert net.shapes["pool1"] == (4, 144, 256)
    assert net.config["conv2"] == default_config()["conv2"]


@pytest.mark.parametrize(
    ("change", "error"),
    [
        ({"version": 2}, uavsnn.ParameterError),
        ({"width": 0}, uavsnn.ParameterError),
        ({"conv2": {"kernel": 0}}, uavsnn.ParameterError),
        ({"conv2": {"threshold": -1.0}}, uavsnn.ParameterError),
        ({"conv3": {"threshold": float("nan")}}, uavsnn.ParameterError),
        ({"pent": {"theta_min": float("nan")}}, uavsnn.ParameterError),
        ({"pent": {"beta": -1.0}}, uavsnn.ParameterError),
        ({"pent": {"max_density": 0.0}}, uavsnn.ParameterError),
        ({"pent": {"max_density": 1.5}}, uavsnn.ParameterError),
        ({"pent": {"max_density": float("nan")}}, uavsnn.ParameterError),
        ({"pent": {"mode": "adaptive"}}, uavsnn.ParameterError),
        ({"stdp": {"a_minus": 0.1}}, uavsnn.ParameterError),
        ({"detection": {"min_detections": 0}}, uavsnn.ParameterError),
        ({"padding": "valid", "width": 20, "height": 20}, uavsnn.ShapeError),
        ({"padding": "valid", "conv1": {"kernel": 50}}, uavsnn.ShapeError),
        ({"widht": 240}, uavsnn.ParameterError),
    ],
)
def test_bad_config_is_refused(change: dict[str, Any], error: type[Exception]) -> None:
    c = default_config()
    for key, value in change.items():
        if isinstance(value, dict):
            c[key].update(value)
        else:
            c[key] = value
    with pytest.raises(error):
        Network(c)


def test_bad_config_types_are_refused() -> None:
    with pytest.raises(uavsnn.ParameterError):
        Network([1, 2])  # type: ignore[arg-type]
    with pytest.raises(uavsnn.ParameterError):
        Network({"width": object()})
    with pytest.raises(uavsnn.ParameterError):
        Network(seed=-1)


def test_seed_determines_weights() -> None:
    a, b, c = Network(seed=3), Network(seed=3), Network(seed=4)
    assert a == b and a != c
    for layer in ("conv2", "conv3"):
        w = a.weights(layer)
        assert w.dtype == np.float32
        assert np.all((w >= 0) & (w <= 1))
        assert abs(float(w.mean()) - 0.8) < 0.02
        assert np.array_equal(w, b.weights(layer))
        assert not np.array_equal(w, c.weights(layer))
    # conv1 holds the Gabor kernels, whatever the seed, each scaled into [0, 1].
    g = a.weights("conv1")
    assert g.shape == (4, 1, 5, 5)
    assert np.array_equal(g, c.weights("conv1"))
    assert np.allclose(g.min(axis=(1, 2, 3)), 0) and np.allclose(g.max(axis=(1, 2, 3)), 1)


# --------------------------------------------------------------------------- hand-computed


def chain_config(conv2_maps: int = 1, inhibition: bool = True) -> dict[str, Any]:
    """A 20x20 network whose conv2 and conv3 are 1x1 and pool2 is the identity, so that one
    conv1 spike can be followed by hand through every layer."""
    c = default_config()
    c.update(width=20, height=20)
    c["pent"]["mode"] = "static"
    c["conv2"].update(kernel=1, maps=conv2_maps, threshold=0.5, lateral_inhibition=inhibition)
    c["pool2"].update(kernel=1, stride=1)
    c["conv3"].update(kernel=1, maps=1, threshold=0.5)
    return c


def vertical_line() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Five pixels at x = 7, y = 5..9, one per microsecond from t = 10."""
    return np.arange(10, 15, dtype=np.uint64), np.full(5, 7, np.uint16), np.arange(5, 10)


def final_conv1_potentials(net: Network, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """conv1's potentials (float64) after all the given pixels, by direct correlation."""
    w = net.weights("conv1").astype(np.float64)[:, 0]
    c = net.config
    frame = np.zeros((c["height"] + 4, c["width"] + 4))
    frame[np.asarray(y) + 2, np.asarray(x) + 2] = 1
    v = np.zeros((w.shape[0], c["height"], c["width"]))
    for dy in range(5):
        for dx in range(5):
            v += w[:, dy, dx, None, None] * frame[dy : dy + c["height"], dx : dx + c["width"]]
    return v


def test_a_line_follows_the_chain_through_every_layer() -> None:
    probe = Network(chain_config())
    t, x, y = vertical_line()
    v = final_conv1_potentials(probe, x, y)
    # The threshold: the 0° (vertical-edge) neuron on the line's centre, at its final potential.
    centre = float(v[0, 7, 7])
    theta = np.float32(centre)
    if theta > centre:
        theta = np.nextafter(theta, np.float32(0))
    assert np.count_nonzero(v >= theta) == 1, "only the centre neuron may reach it"
    c = chain_config()
    c["conv1"]["threshold"] = float(theta)
    net = Network(c)
    net.set_weights("conv2", np.array([1, 0, 0, 0], np.float32).reshape(1, 4, 1, 1))
    net.set_weights("conv3", np.ones((1, 1, 1, 1), np.float32))
    trace = net.run_window(t, x, y, t0=0)
    # conv1: the neuron fires at the last pixel, when its whole centre column has arrived.
    assert trace.conv1.tolist() == [(14, 0, 7, 7, np.float32(centre))]
    # pool1 (5x5, stride 5): the block (1, 1) holds (7, 7); same time.
    assert trace.pool1[["t", "map", "row", "col"]].tolist() == [(14, 0, 1, 1)]
    # conv2 (1x1, weight 1 from map 0): fires with potential 1 at once.
    assert trace.conv2.tolist() == [(14, 0, 1, 1, 1.0)]
    assert trace.pool2[["t", "map", "row", "col"]].tolist() == [(14, 0, 1, 1)]
    assert trace.conv3.tolist() == [(14, 0, 1, 1, 1.0)]
    # The detection: conv3 (1, 1) sees pool1 block (1, 1) = conv1 rows/cols 5..9, which read
    # pixels 3..11 (kernel 5, same padding): centre 7.5; the box holds the line.
    (d,) = trace.detections.tolist()
    assert d == (14, 0, 1, 1, 7.5, 7.5, 7, 5, 8, 10)
    assert trace.detections.dtype == DETECTION_DTYPE
    assert trace.counts.tolist() == [1, 1, 1, 1, 1]
    assert list(trace.layers) == list(LAYERS)


@pytest.mark.parametrize(
    ("weights", "inhibition", "fired_maps"),
    [
        ((1.0, 0.75), True, [0]),  # the higher potential wins
        ((0.75, 1.0), True, [1]),
        ((1.0, 1.0), True, [0]),  # a tie goes to the lower map
        ((1.0, 0.75), False, [0, 1]),  # without inhibition both fire
    ],
)
def test_lateral_inhibition_at_conv2(
    weights: tuple[float, float], inhibition: bool, fired_maps: list[int]
) -> None:
    net = Network(chain_config(conv2_maps=2, inhibition=inhibition) | {"conv1": {"threshold": 4.0}})
    w = np.zeros((2, 4, 1, 1), np.float32)
    w[:, 0, 0, 0] = weights
    net.set_weights("conv2", w)
    t, x, y = vertical_line()
    trace = net.run_window(t, x, y, t0=0)
    assert len(trace.pool1) > 0
    first = trace.pool1[trace.pool1["map"] == 0][0]
    at_first = trace.conv2[
        (trace.conv2["row"] == first["row"]) & (trace.conv2["col"] == first["col"])
    ]
    assert at_first["map"].tolist() == fired_maps
    assert np.all(at_first["t"] == first["t"])
    assert at_first["v"].tolist() == [weights[m] for m in fired_maps]


def test_pool_fires_at_the_first_spike_of_its_block() -> None:
    net = Network(small_config(pent={"mode": "static"}, conv1={"threshold": 2.0}))
    rng = np.random.default_rng(5)
    t, x, y = random_window(rng, 48, 36, 0, 1000)
    trace = net.run_window(t, x, y, t0=0)
    assert len(trace.conv1) > 10
    expected: dict[tuple[int, int, int], int] = {}
    for s in trace.conv1:
        key = (int(s["map"]), int(s["row"]) // 5, int(s["col"]) // 5)
        expected[key] = min(expected.get(key, 2**63), int(s["t"]))
    got = {(int(s["map"]), int(s["row"]), int(s["col"])): int(s["t"]) for s in trace.pool1}
    assert got == expected


def test_pent_thresholds_follow_the_formula() -> None:
    c = small_config()
    net = Network(c)
    k1 = net.weights("conv1").astype(np.float64).sum(axis=(1, 2, 3))
    area = c["width"] * c["height"]
    for n_in in (0, 10, 300, 1500):
        raw = c["pent"]["beta"] * (n_in / area) * k1
        expected = np.maximum(c["pent"]["theta_min"], raw).astype(np.float32)
        assert np.array_equal(net.conv1_thresholds(n_in), expected)
    # With a cap on the density asked for, busy windows stop raising the bar at ρ_max · K1.
    capped = Network({**c, "pent": {**c["pent"], "max_density": 0.25}})
    for n_in in (0, 10, 300, 1500):
        asked = min(c["pent"]["beta"] * (n_in / area), 0.25)
        expected = np.maximum(c["pent"]["theta_min"], asked * k1).astype(np.float32)
        assert np.array_equal(capped.conv1_thresholds(n_in), expected)
    t, x, y = random_window(np.random.default_rng(1), 48, 36, 0, 1000)
    assert np.array_equal(net.run_window(t, x, y, 0).thresholds, net.conv1_thresholds(len(t)))
    assert np.array_equal(
        net.run_window(t, x, y, 0, n_in=1500).thresholds, net.conv1_thresholds(1500)
    )
    static = Network(small_config(pent={"mode": "static"}))
    assert np.all(static.run_window(t, x, y, 0).thresholds == c["conv1"]["threshold"])


def test_stdp_step_updates_only_the_winner_by_the_rule() -> None:
    net = Network(chain_config(conv2_maps=2, inhibition=True) | {"conv1": {"threshold": 4.0}})
    w = np.full((2, 4, 1, 1), 0.5, np.float32)
    w[0, 0, 0, 0], w[1, 0, 0, 0] = 0.75, 0.9
    net.set_weights("conv2", w)
    t, x, y = vertical_line()
    trace = net.run_window(t, x, y, t0=0)
    first = trace.pool1[trace.pool1["map"] == 0][0]
    c = net.config["stdp"]
    winners = net.stdp_step("conv2", t, x, y, t0=0)
    # Both maps cross at the first pool1 spike; map 1 has the higher potential and wins; map 0
    # at the same position is within the inhibition radius.
    assert winners.dtype == SPIKE_DTYPE
    assert winners[["t", "map", "row", "col"]].tolist() == [
        (first["t"], 1, first["row"], first["col"])
    ]
    after = net.weights("conv2")
    # Input channel 0 fired before the winner (a_plus); channels 1-3 did not fire at that
    # position by then (a_minus).
    fired = {
        int(s["map"])
        for s in trace.pool1
        if (s["row"], s["col"]) == (first["row"], first["col"]) and s["t"] <= first["t"]
    }
    for ch in range(4):
        a = np.float32(c["a_plus"] if ch in fired else c["a_minus"])
        old = w[1, ch, 0, 0]
        new = np.clip(old + (a * old) * (np.float32(1) - old), 0, 1)
        assert after[1, ch, 0, 0] == new
    assert np.array_equal(after[0], w[0])


# ----------------------------------------------------------------------- properties


@given(
    seed=st.integers(0, 2**32 - 1),
    layer=st.sampled_from(["conv1", "conv2", "conv3"]),
    a_plus=st.floats(1e-6, 1.0),
    a_minus=st.floats(-1.0, 0.0),
    values=st.sampled_from(["edges", "uniform"]),
)
def test_stdp_keeps_weights_in_unit_interval(
    seed: int, layer: str, a_plus: float, a_minus: float, values: str
) -> None:
    rng = np.random.default_rng(seed)
    net = Network(small_config(), seed=seed)
    for name in ("conv2", "conv3"):
        shape = net.weights(name).shape
        if values == "edges":
            w = rng.choice(np.array([0, 1e-30, 0.5, 1 - 1e-7, 1], np.float32), size=shape)
        else:
            w = rng.random(shape, dtype=np.float32)
        net.set_weights(name, w.astype(np.float32))
    before = net.weights(layer)
    for k in range(3):
        t, x, y = random_window(rng, 48, 36, 1000 * k, 1000)
        winners = net.stdp_step(layer, t, x, y, 1000 * k, a_plus=a_plus, a_minus=a_minus)
        w = net.weights(layer)
        assert np.all(np.isfinite(w)) and np.all((w >= 0) & (w <= 1))
        # Sparse: only the winners' kernels may change, and winners have distinct maps.
        assert len(set(winners["map"].tolist())) == len(winners)
        untouched = np.setdiff1d(np.arange(w.shape[0]), winners["map"])
        assert np.array_equal(w[untouched], before[untouched])
        before = w


@given(seed=st.integers(0, 2**32 - 1), estimate=st.sampled_from(["window", "preceding"]))
def test_batch_inference_equals_run_window(seed: int, estimate: str) -> None:
    rng = np.random.default_rng(seed)
    net = Network(small_config(pent={"estimate": estimate}), seed=seed)
    n = int(rng.integers(1, 6))
    parts = [random_window(rng, 48, 36, 2000 * i, 2000) for i in range(n)]
    windows = make_windows(parts, (48, 36), 2000, [2000 * i for i in range(n)])
    result = net.infer(windows, spikes=True)
    assert isinstance(result, Inference) and len(result) == n
    assert result.spikes is not None
    for i, (t, x, y) in enumerate(parts):
        n_in = len(t) if estimate == "window" else int(windows.n_preceding[i])
        trace = net.run_window(t, x, y, 2000 * i, n_in=n_in)
        assert result.counts[i].tolist() == trace.counts.tolist()
        assert np.array_equal(result.thresholds[i], trace.thresholds)
        mine = result.detections[result.detections["window"] == i]
        assert mine[list(DETECTION_DTYPE.names or ())].tolist() == trace.detections.tolist()
        assert result.detected[i] == (len(trace.conv3) >= 1)
        assert result.first_detection_t[i] == (trace.conv3["t"].min() if len(trace.conv3) else 0)
        for layer in LAYERS:
            got = result.spikes[layer][result.spikes[layer]["window"] == i]
            assert got[list(SPIKE_DTYPE.names or ())].tolist() == trace[layer].tolist()


def test_threads_do_not_change_results() -> None:
    rng = np.random.default_rng(7)
    net = Network(small_config(), seed=7)
    parts = [random_window(rng, 48, 36, 1000 * i, 1000) for i in range(40)]
    windows = make_windows(parts, (48, 36), 1000, [1000 * i for i in range(40)])
    one, two = net.infer(windows, threads=1), net.infer(windows, threads=2)
    assert one.detected.any(), "the test needs detections"
    for field in ("detected", "counts", "first_detection_t", "detections", "thresholds"):
        assert np.array_equal(getattr(one, field), getattr(two, field))


def test_inference_of_runs_concatenated_is_the_inference_at_once() -> None:
    rng = np.random.default_rng(8)
    net = Network(small_config(), seed=8)
    parts = [random_window(rng, 48, 36, 1000 * i, 1000) for i in range(12)]
    starts = [1000 * i for i in range(12)]
    whole = net.infer(make_windows(parts, (48, 36), 1000, starts), spikes=True)
    assert len(whole.detections) and whole.spikes is not None, "the test needs detections"
    runs = [
        net.infer(make_windows(parts[a:b], (48, 36), 1000, starts[a:b]), spikes=True)
        for a, b in ((0, 5), (5, 6), (6, 12))
    ]
    joined = Inference.concatenate(runs)
    for field in ("detected", "counts", "first_detection_t", "detections", "thresholds"):
        assert np.array_equal(getattr(joined, field), getattr(whole, field)), field
    assert joined.spikes is not None
    for layer in LAYERS:
        assert np.array_equal(joined.spikes[layer], whole.spikes[layer]), layer
    # Spikes only where every run has them; no runs is a ShapeError.
    runs[1] = net.infer(make_windows(parts[5:6], (48, 36), 1000, starts[5:6]))
    assert Inference.concatenate(runs).spikes is None
    with pytest.raises(uavsnn.ShapeError):
        Inference.concatenate([])


# --------------------------------------------------------------------------- training


def training_windows(seed: int, n: int) -> WindowColumns:
    rng = np.random.default_rng(seed)
    parts = [random_window(rng, 48, 36, 1000 * i, 1000, n_lines=10) for i in range(n)]
    return make_windows(parts, (48, 36), 1000, [1000 * i for i in range(n)])


def test_train_layer_is_deterministic_and_reports_convergence() -> None:
    windows = training_windows(3, 12)
    c = small_config(stdp={"lr_every": 5})
    a, b, other = Network(c, seed=1), Network(c, seed=1), Network(c, seed=1)
    calls: list[tuple[int, int, float]] = []
    report = a.train_layer(
        "conv2", windows, epochs=2, seed=9, every=4, callback=lambda *p: calls.append(p)
    )
    b.train_layer("conv2", windows, epochs=2, seed=9)
    other.train_layer("conv2", windows, epochs=2, seed=10)
    assert a == b and a != other
    assert report.windows_seen == 24 and len(report.convergence) == 24
    assert report.winners > 0
    # a_plus doubles every lr_every windows.
    assert report.a_plus[:5] == [c["stdp"]["a_plus"]] * 5
    assert report.a_plus[5] == 2 * c["stdp"]["a_plus"]
    w = a.weights("conv2").astype(np.float64)
    assert report.convergence[-1] == pytest.approx(float(np.mean(w * (1 - w))), rel=1e-12)
    assert [p[0] for p in calls] == [4, 8, 12, 16, 20, 24]
    assert all(p[1] == 24 for p in calls)
    # Only conv2 learned.
    fresh = Network(c, seed=1)
    assert np.array_equal(a.weights("conv3"), fresh.weights("conv3"))
    assert not np.array_equal(a.weights("conv2"), fresh.weights("conv2"))


def test_train_layer_equals_stdp_steps_in_order() -> None:
    windows = training_windows(4, 6)
    c = small_config()
    a, b = Network(c, seed=2), Network(c, seed=2)
    a.train_layer("conv3", windows, shuffle=False)
    for i in range(len(windows)):
        t, x, y = windows.spikes(i)
        b.stdp_step("conv3", t, x, y, int(windows.t0[i]))
    assert a == b


def test_callback_can_stop_training() -> None:
    windows = training_windows(5, 10)
    net = Network(small_config())
    report = net.train_layer("conv2", windows, every=3, callback=lambda done, total, c: False)
    assert report.windows_seen == 3


# ------------------------------------------------------------------------- model files


def test_save_load_round_trip_is_bit_exact(tmp_path: Path) -> None:
    net = Network(small_config(), seed=11)
    net.train_layer("conv2", training_windows(6, 5))
    path = tmp_path / "model.npz"
    net.save(path)
    back = Network.load(path)
    assert back == net and back.config == net.config
    for layer in ("conv1", "conv2", "conv3"):
        assert back.weights(layer).tobytes() == net.weights(layer).tobytes()
    # numpy reads the file without pickle.
    with np.load(path, allow_pickle=False) as data:
        assert np.array_equal(data["conv2"], net.weights("conv2"))
        assert json.loads(bytes(data["config"]).decode()) == net.config
    assert [p.name for p in tmp_path.iterdir()] == ["model.npz"]


def test_a_model_written_by_numpy_loads(tmp_path: Path) -> None:
    net = Network(small_config(), seed=1)
    path = tmp_path / "numpy.npz"
    with np.load(_saved(net, tmp_path), allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    arrays["conv3"] = np.full_like(arrays["conv3"], 0.25)
    np.savez(path, **arrays)
    back = Network.load(path)
    assert np.all(back.weights("conv3") == np.float32(0.25))


def _saved(net: Network, folder: Path) -> Path:
    path = folder / "saved.npz"
    net.save(path)
    return path


def _rewrite(path: Path, out: Path, change: dict[str, np.ndarray]) -> Path:
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    arrays.update(change)
    np.savez(out, **arrays)
    return out


def test_bad_model_files_raise_model_file_error(tmp_path: Path) -> None:
    net = Network(small_config())
    good = _saved(net, tmp_path)
    raw = good.read_bytes()
    config = net.config
    cases: dict[str, Path] = {}
    for name, data in {
        "empty": b"",
        "text": b"this is not a model",
        "truncated": raw[: len(raw) // 2],
        "cut_end": raw[:-5],
        "flipped": raw[:200] + bytes([raw[200] ^ 0xFF]) + raw[201:],
    }.items():
        cases[name] = tmp_path / f"{name}.npz"
        cases[name].write_bytes(data)
    cases["missing"] = tmp_path / "does-not-exist.npz"
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, a=np.zeros(3))
    cases["foreign"] = foreign
    v2 = json.dumps(config | {"version": 2}).encode()
    cases["version"] = _rewrite(good, tmp_path / "v2.npz", {"config": np.frombuffer(v2, np.uint8)})
    w = net.weights("conv2")
    cases["range"] = _rewrite(good, tmp_path / "range.npz", {"conv2": w + 1})
    cases["nan"] = _rewrite(good, tmp_path / "nan.npz", {"conv2": w * np.nan})
    cases["shape"] = _rewrite(good, tmp_path / "shape.npz", {"conv2": w[:3]})
    cases["dtype"] = _rewrite(good, tmp_path / "dtype.npz", {"conv2": w.astype(np.float64)})
    compressed = tmp_path / "compressed.npz"
    with zipfile.ZipFile(good) as z, zipfile.ZipFile(compressed, "w", zipfile.ZIP_DEFLATED) as out:
        for item in z.namelist():
            out.writestr(item, z.read(item))
    cases["compressed"] = compressed
    for name, path in cases.items():
        with pytest.raises(uavsnn.ModelFileError):
            Network.load(path)
        assert name  # each case is a distinct file


def test_version_error_says_which_version(tmp_path: Path) -> None:
    net = Network(small_config())
    v2 = json.dumps(net.config | {"version": 2}).encode()
    path = _rewrite(
        _saved(net, tmp_path), tmp_path / "v2.npz", {"config": np.frombuffer(v2, np.uint8)}
    )
    with pytest.raises(uavsnn.ModelFileError, match="version 2"):
        Network.load(path)


# -------------------------------------------------------------------------- bad input


def test_bad_spikes_raise_typed_errors() -> None:
    net = Network(small_config())
    t, x, y = np.array([5, 6], np.uint64), np.array([1, 2]), np.array([1, 1])
    with pytest.raises(uavsnn.ShapeError):
        net.run_window(t, x[:1], y, 0)
    with pytest.raises(uavsnn.ShapeError):
        net.run_window(t.reshape(2, 1), x, y, 0)
    with pytest.raises(uavsnn.EventError):
        net.run_window(t.astype(np.float64), x, y, 0)
    with pytest.raises(uavsnn.EventError):
        net.run_window(t, x.astype(np.float32), y, 0)
    with pytest.raises(uavsnn.EventError):
        net.run_window(t, np.array([-1, 2]), y, 0)
    with pytest.raises(uavsnn.EventError, match="outside"):
        net.run_window(t, np.array([48, 2]), y, 0)
    with pytest.raises(uavsnn.EventError, match="backwards"):
        net.run_window(t[::-1].copy(), x, y, 0)
    with pytest.raises(uavsnn.EventError, match="before"):
        net.run_window(t, x, y, 6)
    with pytest.raises(uavsnn.ParameterError):
        net.run_window(t, x, y, -1)
    with pytest.raises(uavsnn.ParameterError):
        net.stdp_step("conv4", t, x, y, 0)
    with pytest.raises(uavsnn.ParameterError):
        net.stdp_step("conv2", t, x, y, 0, a_plus=float("nan"))
    # An empty window is fine.
    assert net.run_window([], [], [], 0).counts.tolist() == [0] * 5


def test_bad_weights_raise_typed_errors() -> None:
    net = Network(small_config())
    w = net.weights("conv2")
    with pytest.raises(uavsnn.ShapeError):
        net.set_weights("conv2", w[:, :, :5])
    with pytest.raises(uavsnn.ShapeError):
        net.set_weights("conv2", w[0])
    with pytest.raises(uavsnn.ParameterError):
        net.set_weights("conv2", w.astype(np.float64))
    for bad in (np.nan, -0.5, 1.5, np.inf):
        v = w.copy()
        v[0, 0, 0, 0] = bad
        with pytest.raises(uavsnn.ParameterError):
            net.set_weights("conv2", v)
    with pytest.raises(uavsnn.ParameterError):
        net.weights("pool1")
    assert np.array_equal(net.weights("conv2"), w), "failed calls change nothing"


@pytest.mark.parametrize(
    ("rates", "message"),
    [
        ({"a_plus": -0.5}, "a_plus must be >"),
        ({"a_plus": 0.0}, "a_plus must be >"),
        ({"a_plus": 1e-50}, "a_plus must be > 0 as a float32"),
        ({"a_plus": 1e50}, "a_plus must be <="),
        ({"a_minus": 0.5}, "a_minus must be <="),
        ({"a_minus": -1e50}, "a_minus must be >="),
        ({"a_plus": "x"}, "a_plus must be a number"),
        ({"a_plus": np.array([0.1, 0.2])}, "a_plus must be a number"),
        ({"a_minus": True}, "a_minus must be a number"),
        ({"a_minus": float("nan")}, "a_minus must be finite"),
    ],
)
def test_stdp_rate_overrides_keep_the_configs_signs(rates: dict[str, Any], message: str) -> None:
    # The config refuses a_plus <= 0 and a_minus > 0; an override is refused the same way
    # (a_plus = -0.5 would depress the winners' weights), and the weights are left alone.
    net = Network(chain_config(conv2_maps=2, inhibition=True) | {"conv1": {"threshold": 4.0}})
    t, x, y = vertical_line()
    before = net.weights("conv2")
    with pytest.raises(uavsnn.ParameterError, match=message):
        net.stdp_step("conv2", t, x, y, 0, **rates)
    assert np.array_equal(net.weights("conv2"), before)
    # The rates the config accepts are accepted as overrides, NumPy scalars included.
    assert len(net.stdp_step("conv2", t, x, y, 0, a_plus=np.float32(0.25), a_minus=0))


def test_a_config_of_numpy_scalars_is_the_config_of_their_numbers() -> None:
    given = small_config(conv1={"maps": np.int64(4)}, pent={"beta": np.float32(2.5)})
    assert Network(given) == Network(small_config(conv1={"maps": 4}, pent={"beta": 2.5}))
    with pytest.raises(uavsnn.ParameterError, match=r"config\.pent\.beta"):
        Network(small_config(pent={"beta": np.float32("nan")}))


@pytest.mark.parametrize("layer", [None, 3, b"conv2"])
def test_a_layer_that_is_no_name_is_a_parameter_error(layer: Any) -> None:
    net = Network(small_config())
    t, x, y = random_window(np.random.default_rng(1), 48, 36, 0, 1000)
    w = net.weights("conv2")
    with pytest.raises(uavsnn.ParameterError, match="layer"):
        net.weights(layer)
    with pytest.raises(uavsnn.ParameterError, match="layer"):
        net.set_weights(layer, w)
    with pytest.raises(uavsnn.ParameterError, match="layer"):
        net.stdp_step(layer, t, x, y, 0)
    with pytest.raises(uavsnn.ParameterError, match="layer"):
        net.train_layer(layer, training_windows(1, 2))
    assert np.array_equal(net.weights("conv2"), w)


def test_a_model_path_of_bytes_is_a_parameter_error(tmp_path: Path) -> None:
    net = Network(small_config())
    target = tmp_path / "m.npz"
    with pytest.raises(uavsnn.ParameterError, match="path"):
        net.save(bytes(target))
    assert not target.exists()
    net.save(target)
    with pytest.raises(uavsnn.ParameterError, match="path"):
        Network.load(bytes(target))


def test_inference_concatenate_takes_an_iterable_of_inferences_only() -> None:
    net = Network(small_config())
    windows = training_windows(2, 3)
    run = net.infer(windows)
    twice = Inference.concatenate([run, run])
    joined = Inference.concatenate(iter([run, run]))
    for field in ("detected", "counts", "first_detection_t", "detections", "thresholds"):
        assert np.array_equal(getattr(joined, field), getattr(twice, field)), field
    for parts in ([run, 3], [run, None], 3, run):
        with pytest.raises(uavsnn.ParameterError):
            Inference.concatenate(parts)  # type: ignore[arg-type]


def test_windows_of_a_fractional_sensor_size_are_refused() -> None:
    net = Network(small_config())
    good = training_windows(1, 2)
    for size in ((48.9, 36.2), (True, 36), ("48", "36")):
        with pytest.raises(uavsnn.ParameterError, match="sensor_size"):
            net.infer(WindowColumns(**(vars(good) | {"sensor_size": size})))
    assert len(net.infer(WindowColumns(**(vars(good) | {"sensor_size": (48.0, 36.0)}))))


def test_bad_windows_raise_typed_errors() -> None:
    net = Network(small_config())
    good = training_windows(1, 3)
    with pytest.raises(uavsnn.ShapeError, match="sensor_size"):
        net.infer(WindowColumns(**(vars(good) | {"sensor_size": (40, 36)})))
    with pytest.raises(uavsnn.ShapeError):
        net.infer(WindowColumns(**(vars(good) | {"offsets": good.offsets[:-1]})))
    with pytest.raises(uavsnn.ShapeError):
        net.infer(WindowColumns(**(vars(good) | {"n_preceding": good.n_preceding[:1]})))
    with pytest.raises(uavsnn.EventError):
        net.infer(WindowColumns(**(vars(good) | {"t": good.t.astype(np.float32)})))
    with pytest.raises(uavsnn.EventError, match="outside its window"):
        net.infer(WindowColumns(**(vars(good) | {"length_us": 10})))
    with pytest.raises(uavsnn.ParameterError):
        net.infer(WindowColumns(**(vars(good) | {"length_us": 0})))
    with pytest.raises(uavsnn.ParameterError):
        net.infer(good, threads=0)
    with pytest.raises(uavsnn.ParameterError):
        net.infer(object())  # type: ignore[arg-type]
    with pytest.raises(uavsnn.ParameterError):
        net.train_layer("conv2", good, epochs=0)
    with pytest.raises(uavsnn.ParameterError):
        net.train_layer("pool2", good)


def test_window_trace_lookup() -> None:
    trace = Network(small_config()).run_window([3], [4], [5], 0)
    assert isinstance(trace, WindowTrace)
    assert trace["conv1"] is trace.conv1
    with pytest.raises(uavsnn.ParameterError):
        trace["conv4"]


# ------------------------------------------------------------------- with the real windows


def _check_batch_against_single(net: Network, windows: Any) -> Inference:
    result = net.infer(windows)
    for i in range(len(windows)):
        t, x, y = windows.spikes(i)
        trace = net.run_window(t, x, y, int(windows.t0[i]))
        assert result.counts[i].tolist() == trace.counts.tolist()
    return result


def test_infer_reads_uavsnn_windows() -> None:
    windows_module = pytest.importorskip("uavsnn.windows", reason="uavsnn.windows not merged")
    rng = np.random.default_rng(2)
    events = np.zeros(3000, dtype=uavsnn.EVENT_DTYPE)
    events["t"] = np.sort(rng.integers(0, 20_000, len(events)))
    # A vertical bar sweeping right, and noise.
    events["x"] = (events["t"] // 500 + rng.integers(0, 3, len(events))) % 48
    events["y"] = rng.integers(5, 30, len(events))
    events["p"] = rng.random(len(events)) < 0.5
    recording = uavsnn.Recording(events, (48, 36))
    windows = windows_module.make_windows(recording, 5_000, 0.5)
    result = _check_batch_against_single(Network(small_config()), windows)
    assert result.counts[:, 0].sum() > 0


def test_a_real_dvs_recording_at_its_own_sensor_size(shared_data: Path) -> None:
    io = pytest.importorskip("uavsnn.io", reason="uavsnn.io not merged")
    windows_module = pytest.importorskip("uavsnn.windows", reason="uavsnn.windows not merged")
    recording = io.read(shared_data / "dvs" / "aestream_davis346_lab.aedat4")
    width, height = recording.sensor_size
    windows = windows_module.make_windows(recording, 20_000)
    net = Network({"width": width, "height": height}, seed=0)
    result = _check_batch_against_single(net, windows)
    assert len(result) == len(windows) and result.counts[:, 0].sum() > 0
