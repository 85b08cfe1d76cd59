"""Identification (uavsnn.identify) and the figures that report it (uavsnn.evaluation)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from uavsnn import EVENT_DTYPE, Detector, Network
from uavsnn.dataset import LabelledWindows
from uavsnn.dataset.format import RawEvents
from uavsnn.errors import DatasetError, ModelFileError, ParameterError, ShapeError
from uavsnn.evaluation import (
    identification_figures,
    roc_curve,
    threshold_at_false_alarm,
)
from uavsnn.events import Recording
from uavsnn.identify import (
    FEATURES,
    Identifier,
    fit,
    fit_logistic,
    object_features,
    predict_logistic,
    window_features,
)
from uavsnn.windows import make_windows

SIZE = (40, 30)


def small_net() -> Network:
    config = {
        "width": SIZE[0],
        "height": SIZE[1],
        "pent": {"mode": "pent", "beta": 2.0, "theta_min": 1.5, "estimate": "preceding"},
        "conv2": {"threshold": 3.0},
        "conv3": {"threshold": 1.5},
    }
    return Network(config, seed=3)


# ---------------------------------------------------------------- the logistic fit


def test_the_fit_recovers_a_separable_rule() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(size=(400, 3))
    y = x[:, 0] + 2 * x[:, 1] > 0.5  # x[:, 2] is noise
    coef = fit_logistic(x, y, l2=1e-3)
    assert np.all((predict_logistic(coef, x) >= 0.5) == y)
    direction = coef[:3] / np.linalg.norm(coef[:3])
    assert direction @ np.array([1, 2, 0]) / np.sqrt(5) > 0.98
    # The intercept places the boundary at x0 + 2 x1 = 0.5.
    assert -coef[3] / coef[0] == pytest.approx(0.5, abs=0.1)
    # A strong penalty shrinks the weights.
    assert np.linalg.norm(fit_logistic(x, y, l2=100.0)[:3]) < np.linalg.norm(coef[:3])


@pytest.mark.parametrize(
    ("x", "y", "l2", "error"),
    [
        (np.zeros((3, 2)), np.zeros(4, bool), 1.0, ShapeError),
        (np.zeros((3, 2)), np.zeros(3), 1.0, ParameterError),
        (np.full((3, 2), np.nan), np.zeros(3, bool), 1.0, ParameterError),
        (np.zeros((3, 2)), np.zeros(3, bool), -1.0, ParameterError),
    ],
)
def test_bad_fit_inputs_are_typed_errors(x, y, l2, error) -> None:
    with pytest.raises(error):
        fit_logistic(x, y, l2=l2)


def test_fit_refuses_a_set_without_both_kinds() -> None:
    from uavsnn.identify import WindowFeatures

    x = np.zeros((4, len(FEATURES)))
    feats = WindowFeatures(
        x, np.arange(4), np.zeros((4, 4)), 4, np.zeros(4, bool), np.ones(4, bool)
    )
    with pytest.raises(DatasetError):
        fit(feats, feats)


# ---------------------------------------------------------------- the model file


def model(threshold: float = 0.3) -> Identifier:
    k = len(FEATURES)
    return Identifier(
        FEATURES, np.linspace(-1, 1, k + 1), np.arange(k) * 0.5, np.ones(k) * 2, threshold, 0.1
    )


def test_save_load_round_trip_with_identification(tmp_path: Path) -> None:
    net = small_net()
    net.identification = model()
    net.save(tmp_path / "m.npz")
    back = Network.load(tmp_path / "m.npz")
    assert back == net and back.load_note is None
    ident = back.identification
    assert ident is not None and ident.features == FEATURES and ident.threshold == 0.3
    for name in ("coef", "mean", "scale"):
        np.testing.assert_array_equal(getattr(ident, name), getattr(net.identification, name))
    x = np.random.default_rng(1).normal(size=(5, len(FEATURES)))
    np.testing.assert_array_equal(ident.scores(x), net.identification.scores(x))
    # No pickle in the file: every array loads with allow_pickle=False.
    with np.load(tmp_path / "m.npz", allow_pickle=False) as z:
        assert int(z["identify.version"]) == 1


def test_an_old_model_loads_with_the_any_spike_rule_and_a_note(tmp_path: Path) -> None:
    net = small_net()
    net.save(tmp_path / "old.npz")
    back = Network.load(tmp_path / "old.npz")
    assert back.identification is None
    assert back.load_note is not None and "any-spike rule" in back.load_note
    Detector(tmp_path / "old.npz", window_us=3_000)  # still runs


def test_another_identification_version_is_refused(tmp_path: Path) -> None:
    from uavsnn.network import _add_arrays

    net = small_net()
    net.identification = model()
    net.save(tmp_path / "m.npz")
    _add_arrays(str(tmp_path / "m.npz"), {"identify.version": np.array(99)})
    with pytest.raises(ModelFileError, match="version 99"):
        Network.load(tmp_path / "m.npz")
    _add_arrays(
        str(tmp_path / "m.npz"), {"identify.version": np.array(1), "identify.coef": np.zeros(3)}
    )
    with pytest.raises(ModelFileError, match="inconsistent"):
        Network.load(tmp_path / "m.npz")


# ---------------------------------------------------------------- batch equals streaming


def scene() -> np.ndarray:
    """A blob drifting right over sparse noise, and a square flickering at 400 Hz."""
    rng = np.random.default_rng(0)
    n = 6000
    t = 5_000 + np.cumsum(rng.integers(0, 20, n) * (rng.random(n) < 0.7))
    noise = rng.random(n) < 0.2
    cx = 3 + np.arange(n) * 15 // n
    blob = np.zeros(n, dtype=EVENT_DTYPE)
    blob["t"] = t
    blob["x"] = np.where(noise, rng.integers(0, SIZE[0], n), cx + rng.integers(0, 5, n))
    blob["y"] = np.where(noise, rng.integers(0, SIZE[1], n), 4 + rng.integers(0, 5, n))
    blob["p"] = rng.random(n) < 0.5
    period = 2_500
    rows = [
        (5_000 + c * period + half + rep, x, y, p)
        for c in range(int((t[-1] - 5_000) // period))
        for half, p in ((0, 1), (period // 2, 0))
        for rep in range(2)
        for x in range(28, 34)
        for y in range(18, 24)
    ]
    flick = np.array(rows, dtype=[("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("p", "u1")])
    out = np.zeros(len(flick), dtype=EVENT_DTYPE)
    for f in ("t", "x", "y", "p"):
        out[f] = flick[f]
    both = np.concatenate([blob, out])
    return both[np.argsort(both["t"], kind="stable")]


def test_batch_features_equal_what_the_streaming_detector_sees() -> None:
    net = small_net()
    net.identification = model()
    events = scene()
    window_us = 10_000
    det = Detector(net, window_us=window_us, overlap=0.5, start_us=int(events["t"][0]))
    reports = det.push_windows(events[: len(events) // 2])
    reports += det.push_windows(events[len(events) // 2 :]) + det.flush_windows()
    windows = make_windows(Recording(events, SIZE), window_us, 0.5)
    n = len(windows)
    raw = RawEvents.of_recording(events, np.asarray(windows.t0), window_us, window_us)
    data = LabelledWindows(
        windows, np.zeros(n, bool), np.full(n, "none"), np.zeros(n, np.int64),
        np.full((n, 4), np.nan, np.float32), raw=raw,
    )  # fmt: skip
    batch = window_features(net, data)
    t = events["t"].astype(np.int64)
    streaming = []
    by_t0 = {int(t0): i for i, t0 in enumerate(np.asarray(windows.t0))}
    for r in reports:
        inside = events[np.searchsorted(t, r.t0) : np.searchsorted(t, r.t1)]
        for o in r.objects:
            assert o.rotor is not None
            streaming.append(
                (by_t0[r.t0], o.box, object_features(o.box, o.spikes, inside, rotor=o.rotor))
            )
    assert len(streaming) == len(batch.x) > 3
    for (i, box, x), j, b, y in zip(streaming, batch.window, batch.boxes, batch.x, strict=True):
        assert (i, box) == (int(j), tuple(int(v) for v in b))
        np.testing.assert_array_equal(x, y)
    # The streaming detector scores each object with the model, as the batch path does.
    scored = [(o.uav_score, o.class_guess) for r in reports for o in r.objects]
    expected = net.identification.scores(batch.x)
    assert [s for s, _ in scored] == pytest.approx(expected.tolist(), rel=1e-12)
    assert [g for _, g in scored] == ["uav" if s >= 0.3 else "other" for s in expected]
    # The flickering square's rotor is in the features (log of ~400 Hz, detected).
    rotor = batch.x[:, FEATURES.index("rotor_detected")] == 1
    assert rotor.any()
    hz = np.expm1(batch.x[rotor, FEATURES.index("rotor_log_hz")])
    assert np.all(np.abs(hz - 400) < 12)


def test_features_of_a_dataset_without_raw_events_are_refused() -> None:
    events = scene()[:2000]
    windows = make_windows(Recording(events, SIZE), 10_000, 0.5)
    n = len(windows)
    data = LabelledWindows(
        windows, np.zeros(n, bool), np.full(n, "none"), np.zeros(n, np.int64),
        np.full((n, 4), np.nan, np.float32),
    )  # fmt: skip
    with pytest.raises(DatasetError, match="raw events"):
        window_features(small_net(), data)
    other = Network({"width": 48, "height": 30}, seed=0)
    with pytest.raises(ShapeError, match="40x30 but the model's input is 48x30"):
        window_features(other, data)


# ---------------------------------------------------------------- the figures


def test_roc_and_detection_at_a_false_alarm_rate_on_hand_made_scores() -> None:
    actual = np.array([True] * 4 + [False] * 4)
    scores = np.array([0.9, 0.8, 0.3, -np.inf, 0.85, 0.2, 0.1, -np.inf])
    fa, pd = roc_curve(scores, actual)
    np.testing.assert_allclose(fa, [0, 0, 0.25, 0.25, 0.25, 0.5, 0.75])
    np.testing.assert_allclose(pd, [0, 0.25, 0.25, 0.5, 0.75, 0.75, 0.75])
    # 25 % of 4 UAV-free windows: one may alarm (0.85), so the threshold sits just above 0.2.
    t = threshold_at_false_alarm(scores, actual, 0.25)
    assert 0.2 < t < 0.3
    assert np.mean(scores[actual] >= t) == 0.75
    # 0 %: just above the highest UAV-free score.
    assert 0.85 < threshold_at_false_alarm(scores, actual, 0.0) < 0.9
    with pytest.raises(ParameterError):
        threshold_at_false_alarm(scores, actual, 1.5)
    with pytest.raises(ShapeError):
        roc_curve(scores[:3], actual)


def test_identification_figures_on_hand_made_windows() -> None:
    n = 200
    rng = np.random.default_rng(2)
    label = np.arange(n) < 100
    cls = np.where(label, "drone", np.where(np.arange(n) % 2, "bird", "ball"))
    size = np.where(label, np.where(np.arange(n) < 50, 4.0, 20.0), np.nan).astype(np.float32)
    # UAVs of 20 px score high, UAVs of 4 px below the birds; the balls low.
    scores = np.where(label, np.where(size > 10, 0.9, 0.3), np.where(cls == "ball", 0.1, 0.5))
    scores = scores + rng.uniform(0, 0.01, n)
    detected = np.ones(n, bool)
    windows = make_windows(Recording(scene()[:50], SIZE), 100_000, 0.0)
    data = LabelledWindows(
        windows.select(np.zeros(n, np.int64)), label, cls, np.zeros(n, np.int64),
        np.full((n, 4), np.nan, np.float32), size_px=size,
    )  # fmt: skip
    f = identification_figures(detected, scores, data, threshold=0.7)
    assert f["any_spike"]["confusion"] == [[100, 0], [100, 0]]
    assert f["identified"]["confusion"] == [[50, 50], [0, 100]]
    assert f["identified"]["accuracy"] == 0.75
    # Big UAVs, then birds, then small UAVs, then balls: 0.5 * 0.5 + 0.5 * 1.0.
    assert f["roc"]["area_reachable"] == pytest.approx(0.75)
    at1 = f["at_false_alarm"][0]
    assert at1["false_alarm_rate"] <= 0.01
    assert at1["detection_rate"] == 0.5
    sizes = {z["low"]: z["rate"] for z in at1["by_size_px"]}
    assert sizes == {0.0: 0.0, 12.0: 1.0}
    assert at1["false_alarms_per_class"]["ball"] == 0.0
    at5 = f["at_false_alarm"][1]
    assert at5["false_alarms_per_class"]["bird"] <= 0.1
    with pytest.raises(ShapeError):
        identification_figures(detected[:3], scores, data, 0.5)


# ---------------------------------------------------------------- the commands


def test_train_fits_identification_and_evaluate_reports_both_rules(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import json

    from uavsnn.cli import main
    from uavsnn.dataset import SceneSource, build

    data = tmp_path / "set"
    build(
        data, "dvs", n_test=20, n_train=40, seed=11, dvs=SceneSource("dvs", (240, 180), 200.0, 0.3)
    )
    model = tmp_path / "m.npz"
    args = ["train", str(data), "-o", str(model), "--windows-per-layer", "100", "--quiet"]
    # --tune names the same set here: this checks the plumbing (a real one holds other recordings).
    assert main([*args, "--set", "conv2.threshold=10", "--tune", str(data), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)["identify"]
    assert summary["tune"] == "a separate tuning set" and 0 <= summary["threshold"] <= 1
    roc = tmp_path / "roc.png"
    assert main(["evaluate", str(model), str(data), "--json", "--roc", str(roc)]) == 0
    figures = json.loads(capsys.readouterr().out)
    ident = figures["identification"]
    assert ident["any_spike"]["confusion"] == figures["confusion"]
    assert sum(map(sum, ident["identified"]["confusion"])) == 20
    assert [p["false_alarm_target"] for p in ident["at_false_alarm"]] == [0.01, 0.05]
    assert roc.exists() and roc.stat().st_size > 0
    # Without identification: the any-spike rule, a note, and --roc refused.
    bare = tmp_path / "bare.npz"
    assert main([*args, "-o", str(bare), "--no-identify"]) == 0
    capsys.readouterr()
    assert main(["evaluate", str(bare), str(data)]) == 0
    assert "only the any-spike rule" in capsys.readouterr().out
    assert main(["evaluate", str(bare), str(data), "--roc", str(roc)]) == 2


def test_streaming_scores_every_object_of_a_window() -> None:
    # Two objects in one window: the second one's rotor and score are measured on its own
    # events (the scorer once reused the name of the event columns for the first's features).
    from uavsnn.detector import WindowObject, WindowReport, _with_rotor

    events = scene()
    ident = model()
    objects = (WindowObject((28, 18, 34, 24), 3), WindowObject((2, 3, 20, 10), 2))
    t0 = int(events["t"][0])
    report = WindowReport(0, t0, t0 + 10_000, True, np.zeros(0), objects)
    out = _with_rotor(report, events, ident)
    t = events["t"].astype(np.int64)
    inside = events[np.searchsorted(t, t0) : np.searchsorted(t, t0 + 10_000)]
    for obj in out.objects:
        assert obj.rotor is not None and obj.uav_score is not None
        x = object_features(obj.box, obj.spikes, inside)
        assert obj.uav_score == pytest.approx(float(ident.scores(x[None, :])[0]), rel=1e-12)
    assert out.objects[0].rotor.detected and not out.objects[1].rotor.detected
