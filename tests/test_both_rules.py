"""Both rules side by side where the experiments report them (SPEC §3, §5): identification
fitted in ``uavsnn.experiments``, kept through copies and Ray, scored under noise (with noise on
the raw events too), and written by ``uavsnn.report``."""

from __future__ import annotations

import pickle
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from uavsnn import EVENT_DTYPE, Network
from uavsnn.dataset import SceneSource, build, load
from uavsnn.errors import ParameterError
from uavsnn.experiments import (
    both_rules,
    fit_identification,
    noise_level,
    recipe_config,
    static_twin,
    with_config,
)
from uavsnn.identify import Identifier, raw_noise_events
from uavsnn.report import class_markdown, identification_markdown, noise_table, roc_chart

SENSOR = (240, 180)


def _identifier() -> Identifier:
    names = ("log_width", "log_height")
    return Identifier(names, np.array([0.5, -0.25, 0.1]), np.zeros(2), np.ones(2), 0.4, 1.0)


# ---------------------------------------------------------------- noise on the raw events


def test_raw_noise_has_the_windows_density_and_is_repeatable() -> None:
    rng = np.random.default_rng(0)
    events = np.zeros(500, dtype=EVENT_DTYPE)
    events["t"] = np.sort(rng.integers(50_000, 150_000, 500))
    events["x"], events["y"] = rng.integers(0, 240, 500), rng.integers(0, 180, 500)
    fraction = 0.01  # 432 events in each half of the 240x180 sensor's [t0 - L, t0 + L)
    out = raw_noise_events(events, 100_000, 50_000, SENSOR, fraction, 7, window=3)
    assert len(out) == 500 + 2 * 432
    assert np.all(np.diff(out["t"].astype(np.int64)) >= 0)
    t = out["t"].astype(np.int64)
    assert t.min() >= 50_000 and t.max() < 150_000
    # The signal's events are all there, in their order.
    kept = out[np.isin(out, events)]
    np.testing.assert_array_equal(np.sort(kept, order="t")["t"], events["t"])
    assert out["x"].max() < 240 and out["y"].max() < 180
    # Half before the window, half inside it.
    added = len(out) - 500
    inside = np.count_nonzero(t >= 100_000) - np.count_nonzero(events["t"] >= 100_000)
    assert inside == added // 2
    # The same window and seed: the same noise; another window: other noise.
    again = raw_noise_events(events, 100_000, 50_000, SENSOR, fraction, 7, window=3)
    np.testing.assert_array_equal(out, again)
    other = raw_noise_events(events, 100_000, 50_000, SENSOR, fraction, 7, window=4)
    assert not np.array_equal(out, other)
    # No noise, no change; a bad fraction is a typed error.
    assert raw_noise_events(events, 100_000, 50_000, SENSOR, 0.0, 7, window=3) is events
    with pytest.raises(ParameterError):
        raw_noise_events(events, 100_000, 50_000, SENSOR, 1.5, 7, window=3)


def test_raw_noise_in_the_measured_boxes_measures_as_all_of_it() -> None:
    """window_features keeps only the noise inside the boxes it measures (the same draws):
    measure_box reads nothing else, so each box measures the same; and the noise lies after
    the signal's events of the same time, as a stable sort of both puts it."""
    from uavsnn.signature import measure_box

    rng = np.random.default_rng(3)
    for trial in range(12):
        n = int(rng.integers(0, 2000))
        events = np.zeros(n, dtype=EVENT_DTYPE)
        events["t"] = np.sort(rng.integers(50_000, 150_000, n))
        if trial == 5:
            events["t"] = events["t"][::-1].copy()  # not in time order: sorted with the noise
        events["x"], events["y"] = rng.integers(0, 240, n), rng.integers(0, 180, n)
        events["p"] = rng.random(n) < 0.5
        fraction = (0.001, 0.02, 0.2)[trial % 3]
        full = raw_noise_events(events, 100_000, 50_000, SENSOR, fraction, 9, window=trial)
        noise = full[~np.isin(full, events)] if n else full
        both = np.concatenate([events, noise])
        np.testing.assert_array_equal(full["t"], np.sort(both["t"], kind="stable"))
        boxes = [
            (
                int(rng.integers(0, 200)),
                int(rng.integers(0, 150)),
                int(rng.integers(1, 60)),
                int(rng.integers(1, 40)),
            )
            for _ in range(int(rng.integers(1, 4)))
        ]
        kept = raw_noise_events(
            events, 100_000, 50_000, SENSOR, fraction, 9, window=trial, boxes=boxes
        )
        assert len(kept) <= len(full)
        for box in boxes:
            rate = (100_000, 5_000, 10)
            assert measure_box(kept, box, rate=rate) == measure_box(full, box, rate=rate)


# ---------------------------------------------------------------- the network's identification


def test_identification_travels_with_copies_static_twins_and_pickles() -> None:
    import uavsnn.distributed  # noqa: F401  (registers how networks are pickled)

    net = Network({"width": 40, "height": 30})
    net.identification = _identifier()
    assert net.copy().identification is net.identification
    assert with_config(net, pent={"mode": "static"}).identification is net.identification
    back = pickle.loads(pickle.dumps(net))
    assert back == net
    np.testing.assert_array_equal(back.identification.coef, net.identification.coef)
    assert back.identification.threshold == 0.4
    bare = pickle.loads(pickle.dumps(Network({"width": 40, "height": 30})))
    assert bare.identification is None


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> tuple[Network, object, object]:
    """A network trained a little on a small dvs set, with identification fitted."""
    from uavsnn.training import train

    root = tmp_path_factory.mktemp("both") / "set"
    source = SceneSource("dvs", SENSOR, 200.0, 0.3)
    build(root, "dvs", n_test=24, n_train=60, seed=21, dvs=source)
    data, test = load(root, "train"), load(root, "test")
    net = train(Network(recipe_config(), seed=0), data.windows, windows_per_layer=60).network
    summary = fit_identification(net, data)
    return net, summary, test


def test_fit_identification_attaches_a_model_or_says_why_not(tiny) -> None:
    net, summary, _ = tiny
    if "skipped" in summary:
        assert net.identification is None and "identification needs" in summary["skipped"]
    else:
        assert net.identification is not None
        assert summary["tune"] == "held-out training recordings"
        assert summary["train_windows"] + summary["tune_windows"] == 60
    # A set without any UAV object cannot fit one: skipped, and the network keeps none.
    fresh = net.copy()
    fresh.identification = None
    _, _, test = tiny
    empty = test.select(np.flatnonzero(~np.asarray(test.label, bool)))
    assert "skipped" in fit_identification(fresh, empty)
    assert fresh.identification is None


def test_noise_levels_score_both_rules_on_the_same_noisy_windows(
    tiny, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The tiny set has fewer test recordings of a kind than an interval needs
    # (evaluation.MIN_INTERVAL_RECORDINGS); the intervals' plumbing is what is checked here.
    monkeypatch.setattr("uavsnn.evaluation.MIN_INTERVAL_RECORDINGS", 1)

    net, _, test = tiny
    if net.identification is None:
        net = net.copy()
        net.identification = _identifier()
    static, _ = static_twin(net, test.windows)
    # Identification at a noise level measures the raw events with that level's noise.
    from uavsnn import identify

    raw_noise: list[Any] = []
    measured = identify.window_features

    def features_seen(*args: Any, **kwargs: Any) -> Any:
        raw_noise.append(kwargs.get("raw_noise"))
        return measured(*args, **kwargs)

    monkeypatch.setattr(identify, "window_features", features_seen)
    clean = noise_level({"pent": net, "static": static}, test, 0.0, seed=5)
    assert set(raw_noise) == {None}
    raw_noise.clear()
    noisy = noise_level({"pent": net, "static": static}, test, 0.02, seed=5)
    assert raw_noise == [(0.02, 5)] * 2
    monkeypatch.undo()
    monkeypatch.setattr("uavsnn.evaluation.MIN_INTERVAL_RECORDINGS", 1)
    for point in clean + noisy:
        ident = point.identified
        assert ident is not None
        # The any-spike half of the figures is the evaluation's own.
        assert ident["any_spike"]["confusion"] == point.evaluation.confusion.tolist()
        assert sum(map(sum, ident["identified"]["confusion"])) == len(test)
        assert point.to_dict()["identified"]["accuracy"] == ident["identified"]["accuracy"]
    # The noise is there (more input spikes at 2 % than clean, under both thresholds), and the
    # static twin is not PENT under another name: at 2 % they call other windows UAV.
    assert [p.mode for p in noisy] == ["pent", "static"]
    for c, n in zip(clean, noisy, strict=True):
        assert n.evaluation.input_spikes > c.evaluation.input_spikes
    assert static.config["pent"]["mode"] == "static" != net.config["pent"]["mode"]
    assert not np.array_equal(noisy[0].evaluation.predicted, noisy[1].evaluation.predicted)
    # At no noise the figures are both_rules' on the clean windows.
    from uavsnn.evaluation import evaluate

    e = evaluate(net, test, keep_inference=True)
    assert both_rules(net, test, e.inference) == clean[0].identified
    # PENT's lead over the static twin at each false-alarm rate, on the same windows, with its
    # paired interval over the recordings; the static point carries none.
    from uavsnn.evaluation import detection_at_false_alarm, roc_point_interval

    def combined(network: Network) -> np.ndarray:
        inference = evaluate(network, test, keep_inference=True).inference
        assert network.identification is not None and inference is not None
        scores = network.identification.window_scores(
            identify.window_features(network, test, inference)
        )
        return np.where(inference.detected, scores, -np.inf)

    mine, theirs = combined(net), combined(static)
    assert clean[0].leads is not None and clean[1].leads is None
    assert list(clean[0].leads) == ["static"]
    for rate in (0.01, 0.05):
        lead = clean[0].leads["static"][f"{rate:g}"]
        assert lead["lead"] == detection_at_false_alarm(
            mine, test.label, rate
        ) - detection_at_false_alarm(theirs, test.label, rate)
        assert tuple(lead["interval"]) == roc_point_interval(
            mine, test.label, test.recording, rate, against=theirs
        )
    assert clean[0].to_dict()["leads"] == clean[0].leads
    assert noisy[0].leads is not None and noisy[0].leads != clean[0].leads
    # PENT's accuracy lead by each rule: the difference of the two points' accuracies, with
    # the interval of the windows each decides right, drawn on the same recordings, UAV and
    # UAV-free apart.
    from uavsnn.evaluation import recording_interval

    for c, n in ((clean, 0.0), (noisy, 0.02)):
        assert c[0].accuracy_leads is not None and c[1].accuracy_leads is None
        by_rule = c[0].accuracy_leads["static"]
        assert list(by_rule) == ["any_spike", "identified"]
        for rule in by_rule:
            accuracy = [
                p.evaluation.accuracy
                if rule == "any_spike"
                else p.identified["identified"]["accuracy"]
                for p in c
            ]
            assert by_rule[rule]["lead"] == pytest.approx(accuracy[0] - accuracy[1], abs=1e-12), (
                n,
                rule,
            )
        assert c[0].to_dict()["accuracy_leads"] == c[0].accuracy_leads
    actual = np.asarray(test.label, bool)
    # Each evaluation's accuracy carries its interval over the recordings, UAV and UAV-free
    # drawn apart, in its JSON and its report.
    from uavsnn.report import evaluation_markdown

    lo, hi = e.accuracy_interval
    assert (lo, hi) == recording_interval(e.predicted == actual, test.recording, strata=actual)
    assert lo <= e.accuracy <= hi and e.to_dict()["accuracy_interval"] == [lo, hi]
    assert f"({100 * lo:.1f}–{100 * hi:.1f}) on {len(test)} windows" in evaluation_markdown(e)
    right = [p.evaluation.predicted == actual for p in noisy]
    assert tuple(noisy[0].accuracy_leads["static"]["any_spike"]["interval"]) == recording_interval(
        right[0], test.recording, against=right[1], strata=actual
    )
    # Identification measures noisy raw events at a noise level: its features change.
    from uavsnn.features import window_features

    plain = window_features(net, test, e.inference)
    raw = window_features(net, test, e.inference, raw_noise=(0.02, 5))
    assert len(plain.x) and plain.x.shape == raw.x.shape
    assert not np.allclose(plain.x, raw.x, equal_nan=True)
    # Without identification: the any-spike rule only.
    bare = net.copy()
    bare.identification = None
    assert noise_level({"pent": bare}, test, 0.02, seed=5)[0].identified is None
    assert both_rules(bare, test, e.inference) is None
    table = noise_table(clean + noisy)
    assert (
        "| pent + identification | static + identification | the paper (PENT), SPEC §5's point "
        "| pent − static | pent − static (+ identification) |" in table
    )
    first, _, second = table.partition("The paper's Table 3")
    assert first.count("\n| ") == 2  # one row per level after the header
    # The paper's figure beside SPEC §5's share of 2 % (its fourth, 72 %), none at 0 %; then
    # PENT's accuracy leads with their intervals.
    row2 = first.split("\n| 2 % |")[1].split("\n")[0].split(" | ")
    assert row2[-3] == "72 %"
    assert first.split("\n| 0 % |")[1].split("\n")[0].split(" | ")[-3] == ""
    for rule, cell in zip(("any_spike", "identified"), row2[-2:], strict=True):
        lead = noisy[0].accuracy_leads["static"][rule]
        lo, hi = lead["interval"]
        text = f"{100 * lead['lead']:+.1f} ({100 * lo:+.1f} to {100 * hi:+.1f})"
        assert cell.rstrip(" |") == text
    assert "pent − static: the accuracy lead in points" in second
    # Detection at fixed false-alarm rates, per mode and level, for both modes.
    assert "| pent, at 1 % false alarms | pent, at 5 % false alarms | static, at 1 %" in second
    assert second.count("\n| 0 % |") == 1 and second.count("\n| 2 % |") == 1
    # With PENT's lead over static, in points, beside them.
    assert "| pent − static, at 1 % | pent − static, at 5 % |" in second
    lead = clean[0].leads["static"]["0.01"]
    lo, hi = lead["interval"]
    cell = f"{100 * lead['lead']:+.1f} ({100 * lo:+.1f} to {100 * hi:+.1f})"
    assert second.split("\n| 0 % |")[1].split("\n")[0].count(cell) >= 1


def test_noise_levels_in_parts_are_the_noise_levels_at_once(tiny) -> None:
    """The noisy windows are made and run a part at a time (so a large sensor's fit in
    memory); the points do not depend on the parts."""
    net, _, test = tiny
    if net.identification is None:
        net = net.copy()
        net.identification = _identifier()
    static, _ = static_twin(net, test.windows)
    nets = {"pent": net, "static": static}
    whole = noise_level(nets, test, 0.05, seed=3)
    assert whole[0].evaluation.predicted.any(), "the test needs detections"
    spikes = int(np.diff(test.windows.offsets).max()) + round(0.05 * 240 * 180)
    for budget in (1, 3 * spikes):  # every window its own part; a few windows a part
        parts = noise_level(nets, test, 0.05, seed=3, part_spikes=budget)
        for a, b in zip(whole, parts, strict=True):
            assert a.to_dict() == b.to_dict()
            assert a.snr_db == b.snr_db and a.identified == b.identified
            for name in ("predicted", "latency_us", "latency_from_start_us", "box_iou"):
                np.testing.assert_array_equal(
                    getattr(a.evaluation, name), getattr(b.evaluation, name)
                )
            assert a.evaluation.input_spikes == b.evaluation.input_spikes
    with pytest.raises(ParameterError, match="part_spikes"):
        noise_level(nets, test, 0.05, seed=3, part_spikes=0)


def test_noise_parts_hold_whole_windows_up_to_the_budget() -> None:
    from uavsnn.experiments import _noise_parts

    spikes = np.array([3, 0, 5, 9, 1, 1])
    assert _noise_parts(spikes, 1, 7) == [(0, 2), (2, 3), (3, 4), (4, 6)]
    assert _noise_parts(spikes, 0, 100) == [(0, 6)]
    assert _noise_parts(spikes, 0, 1) == [(0, 1), (1, 2), (2, 3), (3, 4), (4, 5), (5, 6)]
    assert _noise_parts(np.zeros(0, np.int64), 4, 10) == []


# ---------------------------------------------------------------- the report


def test_class_markdown_names_each_class_and_its_mistakes() -> None:
    figures = {
        "classes": ["uav", "bird", "clutter"],
        "objects": 10,
        "accuracy": 0.6,
        "balanced_accuracy": 0.5,
        "per_class": {
            "ball": {"objects": 2, "recall": 0.0},
            "bird": {"objects": 4, "recall": 0.5},
            "uav": {"objects": 4, "recall": 1.0},
        },
        "confusion": {
            "ball": {"uav": 2},
            "bird": {"bird": 2, "clutter": 1, "uav": 1},
            "uav": {"uav": 4},
        },
    }
    text = class_markdown(figures)
    assert "| ball (not a class of the model) | 2 | 0.0 % | uav (100.0 %) |" in text
    assert "| bird | 4 | 50.0 % | uav (25.0 %) |" in text  # a tie: the later name
    assert "| uav | 4 | 100.0 % | - |" in text
    assert "60.0 % right" in text
    assert "No class model" in class_markdown({"classes": [], "objects": 0})
    # Test objects of none of the model's classes: no balanced figure, and no error.
    only_ball = {
        **figures,
        "objects": 2,
        "accuracy": 0.0,
        "balanced_accuracy": None,
        "per_class": {"ball": figures["per_class"]["ball"]},
        "confusion": {"ball": figures["confusion"]["ball"]},
    }
    assert "balanced over the model's classes – (none of them" in class_markdown(only_ball)
    # At a point set beforehand with a higher threshold, fewer objects are guessed uav.
    strict = {
        **figures,
        "false_alarm_target": 0.05,
        "accuracy": 0.5,
        "balanced_accuracy": 0.6,
        "per_class": {
            "ball": {"objects": 2, "recall": 0.0},
            "bird": {"objects": 4, "recall": 0.75},
            "uav": {"objects": 4, "recall": 0.5},
        },
    }
    text = class_markdown(figures, [strict])
    assert "| class | objects | guessed right | taken most often for | right, set for 5 % |" in text
    assert "| bird | 4 | 50.0 % | uav (25.0 %) | 75.0 % |" in text
    assert "| uav | 4 | 100.0 % | - | 50.0 % |" in text
    assert "at the threshold set for 5 % false alarms 50.0 %, balanced 60.0 %" in text
    assert class_markdown(figures, []) == class_markdown(figures)


def test_the_combined_score_is_the_uav_score_where_the_network_detects(tiny) -> None:
    from uavsnn import identify
    from uavsnn.errors import ShapeError

    net, _, test = tiny
    ident = net.identification if net.identification is not None else _identifier()
    inference = net.infer(test.windows)
    feats = identify.window_features(net, test, inference)
    detected = np.asarray(inference.detected, bool)
    assert detected.any() and not detected.all(), "the test needs both kinds of window"
    got = ident.combined_scores(feats, inference.detected)
    np.testing.assert_array_equal(got[detected], ident.window_scores(feats)[detected])
    assert np.all(got[~detected] == -np.inf)
    with pytest.raises(ShapeError, match="detected must be"):
        ident.combined_scores(feats, detected[:-1])


def test_identification_markdown_and_roc_chart(
    tiny, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from uavsnn import pictures

    # Too few test recordings for an interval (evaluation.MIN_INTERVAL_RECORDINGS): the
    # plumbing is what is checked here.
    monkeypatch.setattr("uavsnn.evaluation.MIN_INTERVAL_RECORDINGS", 1)

    net, _, test = tiny
    base = net.identification if net.identification is not None else _identifier()
    net = net.copy()
    # Points set beforehand on either side of the model's threshold.
    net.identification = replace(base, alarm_thresholds=((0.01, 0.95), (0.05, 0.05)))
    from uavsnn.evaluation import evaluate

    figures = both_rules(net, test, evaluate(net, test, keep_inference=True).inference)
    assert figures is not None
    text = identification_markdown(figures)
    (tp, fn), (fp, tn) = figures["identified"]["confusion"]
    assert f"| any-spike + identification | {tp} | {fn} | {fp} | {tn} |" in text
    assert "at 1 % false alarms" in text and "at 5 % false alarms" in text
    # Each point read off the ROC with its interval over the recordings, the threshold read
    # again on each draw (evaluation.roc_point_interval), in the text beside its detection.
    from uavsnn import identify
    from uavsnn.evaluation import roc_point_interval

    inference = net.infer(test.windows)
    feats = identify.window_features(net, test, inference)
    combined = np.where(inference.detected, net.identification.window_scores(feats), -np.inf)
    for point in figures["at_false_alarm"]:
        lo, hi = point["detection_interval"]
        assert (lo, hi) == roc_point_interval(
            combined, test.label, test.recording, point["false_alarm_target"]
        )
        assert lo <= point["detection_rate"] <= hi
        assert f"{100 * point['detection_rate']:.1f} % ({100 * lo:.1f}–{100 * hi:.1f})" in text
    for cls in figures["any_spike"]["per_class"]:
        assert f"| {cls} |" in text
    classes = class_markdown(figures["classes"])
    if figures["classes"]["classes"] and figures["classes"]["objects"]:
        for cls, row in figures["classes"]["per_class"].items():
            assert f"| {cls}" in classes and f"| {row['objects']} |" in classes
    # The class guess at each point set beforehand follows that point's UAV decision.
    ident = net.identification
    points = figures["classes_at_tuned"]
    assert points and [p["false_alarm_target"] for p in points] == [
        r for r, _ in ident.alarm_thresholds
    ]
    for point in points:
        assert point["objects"] == figures["classes"]["objects"]
        strict = ident.at_false_alarm(point["false_alarm_target"])
        for cls, row in point["confusion"].items():
            uav_here = row.get("uav", 0)
            uav_there = figures["classes"]["confusion"][cls].get("uav", 0)
            if strict.threshold >= ident.threshold:
                assert uav_here <= uav_there
            else:
                assert uav_here >= uav_there
    chart = roc_chart({"a": figures["roc"], "b": figures["roc"]}, "ROC")
    assert chart.ndim == 3 and chart.shape[2] == 3
    # With the points read off each ROC, their detection intervals are drawn as bars.
    barred = roc_chart(
        {"a": figures["roc"], "b": figures["roc"]}, "ROC", points={"a": figures["at_false_alarm"]}
    )
    assert barred.shape == chart.shape and (barred != chart).any()
    assert pictures.write_png(tmp_path / "roc.png", chart).stat().st_size > 0


# ---------------------------------------------------------------- streaming


def test_streaming_scores_every_object_of_a_window() -> None:
    """A window with several objects gets a rotor, score and guess for each, equal to the
    batch features' score (a name reused inside the loop once broke the second object)."""
    from uavsnn.detector import _with_rotor, _with_scores
    from uavsnn.grouping import WindowObject, WindowReport
    from uavsnn.identify import object_features

    rng = np.random.default_rng(4)
    events = np.zeros(3000, dtype=EVENT_DTYPE)
    events["t"] = np.sort(rng.integers(0, 50_000, 3000))
    events["x"], events["y"] = rng.integers(0, 40, 3000), rng.integers(0, 30, 3000)
    events["p"] = rng.integers(0, 2, 3000)
    boxes = [(2, 2, 12, 10), (20, 5, 36, 25), (0, 20, 8, 30)]
    objects = tuple(WindowObject(b, 3 + k) for k, b in enumerate(boxes))
    report = WindowReport(0, 0, 50_000, True, np.zeros(0), objects)
    ident = Identifier(
        ("log_width", "log_area", "log_events_per_px"),
        np.array([0.8, -0.3, 0.5, 0.1]), np.zeros(3), np.ones(3), 0.5, 1.0,
    )  # fmt: skip
    out = _with_scores(*_with_rotor(report, [events]), ident)
    assert len(out.objects) == 3
    for obj in out.objects:
        assert obj.rotor is not None and obj.class_guess in ("uav", "other")
        x0, y0, x1, y1 = obj.box
        x, y = events["x"], events["y"]
        inside = events[(x >= x0) & (x < x1) & (y >= y0) & (y < y1)]
        feats = object_features(obj.box, obj.spikes, inside, window=(0, 50_000))
        expected = ident.scores(feats[None, :])[0]
        assert obj.uav_score == pytest.approx(float(expected), abs=0)


# ---------------------------------------------------------------- the threshold's tuning


def _one_object_per_window(x: np.ndarray, label: np.ndarray):
    from uavsnn.identify import FEATURES, WindowFeatures

    full = np.zeros((len(x), len(FEATURES)))
    full[:, FEATURES.index("log_width")] = x
    n = len(x)
    return WindowFeatures(
        full, np.arange(n), np.zeros((n, 4), np.int64), n, label, np.ones(n, bool)
    )


def test_the_threshold_does_not_follow_the_tuning_sets_share_of_uavs() -> None:
    """The threshold maximises balanced accuracy: a tuning set with many more UAV-free windows
    (the real footage's held-out recordings) must not push it to reject every window."""
    from uavsnn.identify import fit

    rng = np.random.default_rng(9)
    n = 400
    label = np.arange(n) < n // 2
    x = np.where(label, 1.0, -1.0) + rng.normal(0, 1.0, n)  # overlapping classes
    train = _one_object_per_window(x, label)
    # The tuning set: the same kind of objects, four times as many UAV-free ones.
    keep = np.concatenate([np.arange(n // 2, n)] * 4 + [np.arange(n // 8)])
    tune = _one_object_per_window(x[keep], label[keep])
    names = ("log_width",)
    balanced = fit(
        train, train, tune_detected=np.ones(n, bool), tune_label=label, features=names
    ).threshold
    skewed = fit(
        train, tune, tune_detected=np.ones(len(keep), bool), tune_label=label[keep], features=names
    ).threshold
    # Both thresholds sit between the classes; the skewed set's is near the balanced one's.
    scores = fit(train, train, features=names).window_scores(train)
    assert np.mean(scores[label] >= skewed) > 0.5
    assert abs(balanced - skewed) < 0.25


# ---------------------------------------------------------------- operating points set beforehand


def test_alarm_thresholds_hold_the_tuning_sets_false_alarm_share() -> None:
    """fit sets a threshold for each share of FALSE_ALARM_RATES on the tuning windows: at it,
    at most that share of the tuning set's UAV-free windows alarm (windows the any-spike rule
    misses never do), and the next score below it would pass the share."""
    from uavsnn.evaluation import FALSE_ALARM_RATES
    from uavsnn.identify import fit

    rng = np.random.default_rng(3)
    n = 600
    label = np.arange(n) % 2 == 0
    x = np.where(label, 1.0, -1.0) + rng.normal(0, 1.2, n)
    train = _one_object_per_window(x, label)
    tune = _one_object_per_window(x[::-1].copy(), label[::-1].copy())
    detected = rng.random(n) < 0.8
    ident = fit(
        train, tune, tune_detected=detected, tune_label=label[::-1], features=("log_width",)
    )
    assert [rate for rate, _ in ident.alarm_thresholds] == list(FALSE_ALARM_RATES)
    score = np.where(detected, ident.window_scores(tune), -np.inf)
    free = score[~label[::-1]]
    for rate, threshold in ident.alarm_thresholds:
        alarms = int((free >= threshold).sum())
        assert alarms <= rate * len(free)
        # The next UAV-free score below the threshold would be too many alarms (with every
        # window tied at it: a tree model's scores take few values).
        below = free[(free < threshold) & np.isfinite(free)]
        assert len(below) == 0 or alarms + np.sum(free == below.max()) > rate * len(free)
    # The stricter share needs the higher threshold.
    (_, t1), (_, t5) = ident.alarm_thresholds
    assert t1 >= t5
    # Switching to one: the same model, that threshold.
    assert ident.at_false_alarm(0.01).threshold == t1
    assert ident.at_false_alarm(0.01).coef is ident.coef
    with pytest.raises(ParameterError, match=r"not tuned for a false-alarm share of 0\.02"):
        ident.at_false_alarm(0.02)
    # Without tuning windows there are none, and the error says so.
    bare = fit(train, tune, features=("log_width",))
    assert bare.alarm_thresholds == ()
    with pytest.raises(ParameterError, match=r"tuned shares: none"):
        bare.at_false_alarm(0.01)


@pytest.mark.parametrize(
    ("pairs", "minutes", "message"),
    [
        (((0.0, 0.5),), 10.0, "positive rate of false tracks"),
        (((0.1, float("nan")),), 10.0, "finite threshold"),
        (((0.1, 0.5), (0.1, 0.6)), 10.0, "name a rate twice"),
        (((0.1, 0.5),), 0.0, "track_alarm_minutes must be positive"),
        ((), 10.0, "0 without"),
    ],
)
def test_track_alarm_thresholds_are_checked(pairs, minutes, message) -> None:
    from uavsnn.identify import Identifier

    with pytest.raises(ParameterError, match=message):
        Identifier(
            ("log_width",), np.zeros(2), np.zeros(1), np.ones(1), 0.5, 1.0,
            track_alarm_thresholds=pairs, track_alarm_minutes=minutes,
        )  # fmt: skip


def test_alarm_thresholds_pass_every_detection_when_the_share_allows_it() -> None:
    """When the any-spike rule raises fewer false alarms on the tuning set than the share
    allows, the operating point is 'every detection alarms' (0.0), not a negative score."""
    from uavsnn.identify import fit

    n = 200
    label = np.arange(n) % 2 == 0
    x = np.where(label, 1.0, -1.0)
    train = _one_object_per_window(x, label)
    detected = label.copy()  # the rule calls no UAV-free window
    ident = fit(train, train, tune_detected=detected, tune_label=label, features=("log_width",))
    assert [t for _, t in ident.alarm_thresholds] == [0.0, 0.0]


@pytest.mark.parametrize(
    "pairs",
    [((0.0, 0.5),), ((1.0, 0.5),), ((0.01, float("nan")),), ((0.01, 0.5), (0.01, 0.6))],
)
def test_bad_alarm_thresholds_are_refused(pairs) -> None:
    base = _identifier()
    with pytest.raises(ParameterError, match="alarm thresholds"):
        Identifier(
            base.features, base.coef, base.mean, base.scale, 0.4, 1.0, alarm_thresholds=pairs
        )


def test_alarm_thresholds_travel_in_the_model_file(tmp_path: Path) -> None:
    from dataclasses import replace

    net = Network({"width": 40, "height": 30})
    net.identification = replace(_identifier(), alarm_thresholds=((0.01, 0.9), (0.05, 0.7)))
    net.save(tmp_path / "m.npz")
    back = Network.load(tmp_path / "m.npz")
    assert back.identification is not None
    assert back.identification.alarm_thresholds == ((0.01, 0.9), (0.05, 0.7))
    # A file written before them loads with none.
    net.identification = _identifier()
    net.save(tmp_path / "old.npz")
    old = Network.load(tmp_path / "old.npz").identification
    assert old is not None and old.alarm_thresholds == ()


def test_figures_at_the_thresholds_set_beforehand(tiny, monkeypatch: pytest.MonkeyPatch) -> None:
    """identification_figures measures the shares and detection at the tuned thresholds; its
    ROC-read points are unchanged by them; the report writes a row for each."""
    # Too few test recordings for an interval (evaluation.MIN_INTERVAL_RECORDINGS): the
    # plumbing is what is checked here.
    monkeypatch.setattr("uavsnn.evaluation.MIN_INTERVAL_RECORDINGS", 1)
    from dataclasses import replace

    from uavsnn.evaluation import evaluate

    net, _, test = tiny
    net = net.copy()
    net.identification = replace(
        net.identification or _identifier(), alarm_thresholds=((0.01, 0.8), (0.05, 0.3))
    )
    inference = evaluate(net, test, keep_inference=True).inference
    figures = both_rules(net, test, inference)
    assert figures is not None
    plain = both_rules(_without_alarms(net), test, inference)
    assert plain is not None and "at_tuned_false_alarm" not in plain
    assert plain["at_false_alarm"] == figures["at_false_alarm"]
    from uavsnn import identify

    scores = net.identification.window_scores(identify.window_features(net, test, inference))
    combined = np.where(inference.detected, scores, -np.inf)
    actual = np.asarray(test.label, bool)
    for point, (rate, threshold) in zip(
        figures["at_tuned_false_alarm"], net.identification.alarm_thresholds, strict=True
    ):
        assert point["false_alarm_target"] == rate and point["threshold"] == threshold
        assert point["false_alarm_rate"] == np.mean(combined[~actual] >= threshold)
        assert point["detection_rate"] == np.mean(combined[actual] >= threshold)
        # Each share with its interval over the recordings (evaluation.recording_interval).
        from uavsnn.evaluation import recording_interval

        rec = np.asarray(test.recording)
        assert point["false_alarm_interval"] == list(
            recording_interval(combined[~actual] >= threshold, rec[~actual])
        )
        assert point["detection_interval"] == list(
            recording_interval(combined[actual] >= threshold, rec[actual])
        )
    text = identification_markdown(figures)
    assert "| 1 % false alarms | 0.800 |" in text and "| 5 % false alarms | 0.300 |" in text
    lo, hi = figures["at_tuned_false_alarm"][0]["false_alarm_interval"]
    assert f"({100 * lo:.1f}–{100 * hi:.1f})" in text


def _without_alarms(net: Network) -> Network:
    from dataclasses import replace

    out = net.copy()
    assert out.identification is not None
    out.identification = replace(out.identification, alarm_thresholds=())
    return out


def test_mix_windows_draws_equal_shares_of_each_part(tiny) -> None:
    """The combined network's training set: as many windows of each part, each part's own
    (drawn without replacement), its recordings kept apart from the other part's."""
    from uavsnn.experiments import mix_windows

    _, _, test = tiny
    n = len(test)
    other = replace(test, cls=np.full(n, "from-sim"))
    mixed = mix_windows([test, other], 20, seed=4)
    assert len(mixed) == 20
    first, second = mixed.cls[:10], mixed.cls[10:]
    assert "from-sim" not in set(first.tolist()) and set(second.tolist()) == {"from-sim"}
    rec = np.asarray(mixed.recording)
    assert not set(rec[:10].tolist()) & set(rec[10:].tolist())
    assert rec[10:].min() > np.asarray(test.recording).max()
    # Without replacement: ten different windows of each part (a window is its recording and
    # its start), each one of the part's.
    t0 = np.asarray(mixed.windows.t0)
    have = set(
        zip(np.asarray(test.recording).tolist(), np.asarray(test.windows.t0).tolist(), strict=True)
    )
    offset = int(np.asarray(test.recording).max()) + 1  # the second part's numbers follow
    for half, shift in ((slice(0, 10), 0), (slice(10, 20), offset)):
        keys = set(zip((rec[half] - shift).tolist(), t0[half].tolist(), strict=True))
        assert len(keys) == 10 and keys <= have
    again = mix_windows([test, other], 20, seed=4)  # the same seed, the same draw
    assert np.array_equal(again.windows.t0, t0) and np.array_equal(again.recording, rec)
    # No total: the parts joined whole, each in its order, their recordings kept apart.
    whole = mix_windows([test, other], None, seed=4)
    assert len(whole) == 2 * n
    t0_test = np.asarray(test.windows.t0)
    assert np.array_equal(np.asarray(whole.windows.t0), np.concatenate([t0_test, t0_test]))
    rec_test = np.asarray(test.recording)
    assert np.array_equal(whole.recording, np.concatenate([rec_test, rec_test + offset]))
    assert np.array_equal(whole.cls[n:], other.cls)


def test_a_detection_lead_from_too_few_recordings_has_no_interval() -> None:
    """The noise sweep's detection lead at a false-alarm rate takes the minimum of recordings
    every interval over the recordings takes (evaluation.MIN_INTERVAL_RECORDINGS)."""
    from uavsnn.evaluation import MIN_INTERVAL_RECORDINGS, roc_point_interval
    from uavsnn.experiments import _lead

    rng = np.random.default_rng(0)
    n = 40
    label = np.arange(n) % 2 == 0
    mine, theirs = rng.random(n), rng.random(n)
    for per_kind, drawn in ((MIN_INTERVAL_RECORDINGS - 1, False), (MIN_INTERVAL_RECORDINGS, True)):
        # per_kind UAV and as many UAV-free recordings, windows dealt out in turn.
        recording = np.where(label, np.arange(n) % per_kind, per_kind + np.arange(n) % per_kind)
        data = SimpleNamespace(label=label, recording=recording)
        lead = _lead(mine, theirs, data, 0.05)  # type: ignore[arg-type]
        if drawn:
            want = roc_point_interval(mine, label, recording, 0.05, against=theirs)
            assert tuple(lead["interval"]) == want
        else:
            assert np.isnan(lead["interval"]).all()


# ------------------------------------------------ operating points as the texts name them


def _point(target: float, reached: float) -> dict[str, Any]:
    """An operating point of identification_figures by hand: 10 UAV windows under 6 px (none
    detected), 20 from 6 to 12 px (1 detected) and 10 of 48 px or more (5 detected)."""
    return {
        "false_alarm_target": target, "threshold": 0.5, "false_alarm_rate": reached,
        "detection_rate": 6 / 40, "detection_interval": [0.05, 0.3],
        "false_alarm_interval": [0.0, 0.02],
        "by_size_px": [
            {"low": 0.0, "high": 6.0, "windows": 10, "detected": 0, "rate": 0.0},
            {"low": 6.0, "high": 12.0, "windows": 20, "detected": 1, "rate": 0.05},
            {"low": 48.0, "high": None, "windows": 10, "detected": 5, "rate": 0.5},
        ],
        "by_range_m": [], "false_alarms_per_class": {"bird": reached},
    }  # fmt: skip


def test_a_point_is_named_with_the_false_alarms_it_reached() -> None:
    """The size and class tables were headed "at 1 % false alarms" where the threshold read off
    the ROC reached 0.9 %; and the drones of the target's size (≥ 6 px) are given beside all
    drones, at the points read off the ROC and at those set beforehand."""
    from uavsnn.report import at_point_text, detection_from_size

    points = [_point(0.01, 0.009), _point(0.05, 0.048)]
    assert at_point_text(points[0]) == "at 1 % false alarms (0.9 % reached)"
    assert at_point_text({"false_alarm_target": 0.01}) == "at 1 % false alarms"
    assert detection_from_size(points[0]["by_size_px"]) == {
        "detected": 6, "windows": 30, "rate": 0.2,
    }  # fmt: skip
    assert detection_from_size(points[0]["by_size_px"][:1]) is None
    with pytest.raises(ParameterError, match="not an edge"):
        detection_from_size(points[0]["by_size_px"], 8.0)
    rule = {"confusion": [[6, 34], [1, 39]], "accuracy": 0.5625, "per_class": {"uav": 0.15}}
    figures = {
        "threshold": 0.5, "any_spike": rule, "identified": rule,
        "roc": {"false_alarm": [0.0, 0.1], "detection": [0.0, 0.5], "area_reachable": 0.02},
        "at_false_alarm": points, "at_tuned_false_alarm": [_point(0.01, 0.03)],
    }  # fmt: skip
    text = identification_markdown(figures)
    assert (
        "| size | UAV windows | at 1 % false alarms (0.9 % reached) | at 5 % false alarms" in text
    )
    assert "| class | at 1 % false alarms (0.9 % reached) |" in text
    assert "| 0–6 px | 10 | 0 (0.0 %) |" in text and "| ≥ 48 px | 10 |" in text
    assert (
        "at 0.9 % false alarms (of the drones ≥ 6 px, the target's size: 6 of 30, 20.0 %)" in text
    )
    assert "| detection here, drones ≥ 6 px |" in text and "| 6 of 30 (20.0 %) |" in text


def test_the_report_counts_recordings_and_gives_false_alarms_per_class_set_beforehand() -> None:
    """An analyst's walk: the size bins gave windows only (a bin of 82 windows was three
    recordings), the false alarms per class were given at the points read off the ROC only, not
    at those set beforehand, the class ``none`` read as an empty scene, and the ROC's partial
    area came without the most it could be."""
    from uavsnn.report import NONE_TEXT

    def counted(target: float, reached: float) -> dict[str, Any]:
        point = _point(target, reached)
        for b, recordings in zip(point["by_size_px"], (2, 3, 1), strict=True):
            b["recordings"] = recordings
        point["false_alarms_per_class"] = {"bird": reached, "none": 0.0}
        return point

    rule = {
        "confusion": [[6, 34], [1, 39]], "accuracy": 0.5625,
        "per_class": {"drone": 0.15, "none": 0.0},
    }  # fmt: skip
    figures = {
        "threshold": 0.5, "any_spike": rule, "identified": rule,
        "roc": {"false_alarm": [0.0, 0.1], "detection": [0.0, 0.5], "area_reachable": 0.02},
        "at_false_alarm": [counted(0.01, 0.009), counted(0.05, 0.048)],
        "at_tuned_false_alarm": [counted(0.01, 0.171), counted(0.05, 0.25)],
    }  # fmt: skip
    text = identification_markdown(figures)
    assert "| size | UAV windows (their recordings) | at 1 % false alarms" in text
    assert "| 0–6 px | 10 (2) | 0 (0.0 %) |" in text and "| ≥ 48 px | 10 (1) |" in text
    assert "| class | set for 1 % | set for 5 % |" in text
    assert "| bird | 17.1 % | 25.0 % |" in text  # at the thresholds set beforehand
    assert "| bird | 0.9 % | 4.8 % |" in text  # at the points read off the ROC
    assert text.count(NONE_TEXT) == 1 and "not an empty scene" in NONE_TEXT
    assert "area up to there 0.020, of at most 0.100" in text
    # Figures of an older run, without recordings per bin, read as before.
    figures["at_false_alarm"] = [_point(0.01, 0.009)]
    assert "| size | UAV windows | at 1 % false alarms" in identification_markdown(figures)


def test_table2_gives_the_false_alarms_reached_and_the_target_size() -> None:
    from uavsnn.cli._results_text import TABLE2_HEAD, table2_row

    rule = {"confusion": [[6, 34], [1, 39]], "accuracy": 0.5625, "accuracy_interval": [0.4, 0.7]}
    ident = {
        "any_spike": rule, "identified": rule,
        "at_false_alarm": [_point(0.01, 0.009), _point(0.05, 0.048)],
        "at_tuned_false_alarm": [_point(0.01, 0.03), _point(0.05, 0.06)],
    }  # fmt: skip
    e = SimpleNamespace(confusion=np.array([[6, 34], [1, 39]]), accuracy=0.5625)
    row = table2_row("combined", e, None, ident)  # type: ignore[arg-type]
    assert "| 15.0 % (5.0–30.0) at 0.9 %; ≥ 6 px: 20.0 % |" in row
    assert "| 15.0 % (3.0 %; 0.0–2.0); ≥ 6 px: 20.0 % |" in row
    assert "at the false alarms reached; drones ≥ 6 px" in TABLE2_HEAD[0]
    assert row.count("|") == TABLE2_HEAD[0].count("|")


def test_evaluate_names_sizes_as_the_report_does(capsys: pytest.CaptureFixture[str]) -> None:
    """`uavsnn evaluate` wrote "48-inf px" and whole per cents ("1 %" for 0.6 %); RESULTS.md
    writes "≥ 48 px" and one decimal. It also gives the false alarms reached and the drones
    of the target size."""
    from uavsnn.cli.evaluate import _print_identification

    rule = {"confusion": [[6, 34], [1, 39]], "accuracy": 0.5625, "accuracy_interval": [0.4, 0.7]}
    ident = {
        "any_spike": rule, "identified": rule, "roc": {}, "at_false_alarm": [_point(0.01, 0.009)],
        "at_tuned_false_alarm": [_point(0.01, 0.03)],
        "rotor_coverage": [{
            "low_px": 48.0, "high_px": None, "uav_windows": 10, "object_on_uav": 9,
            "rotor_votes": 3, "rotor_detected": 1,
        }],
    }  # fmt: skip
    _print_identification(ident)
    out = capsys.readouterr().out
    assert "at 1 % false alarms (0.9 % reached): detection 15.0 %" in out
    assert "drones ≥ 6 px 6 of 30 (20.0 %); by drawn size: 0–6 px 0.0 %, 6–12 px 5.0 %" in out
    assert "≥ 48 px 50.0 %)" in out and "inf" not in out
    assert "detection 15.0 %; drones ≥ 6 px 6 of 30 (20.0 %)" in out  # set beforehand
    assert "UAV ≥ 48 px: 10 windows" in out


def test_evaluate_gives_the_false_alarms_per_class_at_every_point(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """`uavsnn evaluate` printed the false alarms per class of other object nowhere (an
    analyst's walk: with the threshold set beforehand for 1 %, insects alarmed 17 % of the time,
    in the JSON only); it gives them at the points read off the ROC and at those set
    beforehand, named as RESULTS.md names them."""
    from uavsnn.cli.evaluate import _print_identification

    rule = {"confusion": [[6, 34], [1, 39]], "accuracy": 0.5625, "accuracy_interval": [0.4, 0.7]}
    ident = {
        "any_spike": rule, "identified": rule, "roc": {}, "rotor_coverage": [],
        "at_false_alarm": [_point(0.01, 0.009)], "at_tuned_false_alarm": [_point(0.01, 0.171)],
    }  # fmt: skip
    _print_identification(ident)
    out = capsys.readouterr().out
    assert "(20.0 %); by drawn size: 0–6 px 0.0 %, 6–12 px 5.0 %, ≥ 48 px 50.0 %); false " in out
    assert "false alarms per class: bird 0.9 %" in out
    assert "at the threshold set beforehand for 1 % false alarms (0.500)" in out
    assert "(20.0 %); false alarms per class: bird 17.1 %" in out
    assert "tuned for" not in out
