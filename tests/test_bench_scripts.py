"""Smoke tests of benches/python/bench_stream.py at a tiny size (a few seconds), and of the
readouts and features of benches/python/probe_readout.py."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from uavsnn.network import Network, default_config
from uavsnn.training import apply_overrides


@pytest.fixture(scope="module")
def bench(bench_script):
    return bench_script("bench_stream")


def test_scene_latency_of_a_detected_recording(bench):
    # Low thresholds, so that the untrained network surely fires on the scene.
    config = apply_overrides(default_config(), ["conv2.threshold=10", "conv3.threshold=1"])
    net = Network(config, seed=0)
    (lr,) = bench.uav_scenes(1, 1000, 0.2)
    first = bench.first_uav_event(lr)
    assert first is not None and 0 <= first < lr.end_us
    r = bench.scene_latency(net, lr, window_us=50_000, overlap=0.5, chunk=100)
    assert r["first_event_us"] == first
    assert isinstance(r["latency_us"], int) and 0 <= r["latency_us"] < lr.end_us
    assert r["released_latency_us"] >= r["latency_us"]
    assert r["holds_uav_latency_us"] is None or r["holds_uav_latency_us"] >= r["latency_us"]
    assert 0 < r["windows_detected"] <= r["windows"]
    s = bench.summarise([r["latency_us"], None])
    assert s["detected"] == 1 and s["recordings"] == 2
    assert s["median_us"] == s["p90_us"] == r["latency_us"]


def test_report_lines(bench, capsys):
    argv = ["--untrained", "--seconds", "1.5", "--recordings", "1"]
    argv += ["--scenes", "1", "--controls", "1", "--scene-seconds", "0.2"]
    assert bench.main(argv) == 0
    lines = capsys.readouterr().out.splitlines()
    starts = [
        "model: untrained (seed 0)",
        "synthetic moving blob: ",
        "push latency per chunk:",
        "       1 events: p50",
        "     100 events: p50",
        "   10000 events: p50",
        "sustained: stream ",
        "event-time latency on simulated UAV recordings ",
        "  seed 1000: ",
        "  first detection: median ",
        "  first detection whose box holds the UAV's centre: median ",
        "  first detection returned by push ",
        "  reference, scenes without a UAV ",
        "event-time latency, first blob event -> first detection ",
        "total ",
    ]
    assert len(lines) == len(starts)
    for line, start in zip(lines, starts, strict=True):
        assert line.startswith(start), (line, start)


def test_compare_boxes_rebuilds_the_field_box_and_scores_it(bench_script) -> None:
    import numpy as np

    from uavsnn.network import WINDOW_DETECTION_DTYPE, Inference
    from uavsnn.windows import Windows

    module = bench_script("compare_boxes")
    # One window on a 40x30 sensor: spikes at (2, 3) t=1, (5, 4) t=2 and (30, 25) t=9; one
    # detection of conv3 (0, 0) at t=2, whose field (default config) covers the whole sensor.
    config = apply_overrides(default_config(), ["width=40", "height=30"])
    net = Network(config, seed=0)
    w = Windows(
        (40, 30), 50, np.zeros(1, np.uint64), np.array([0, 3]), np.array([1, 2, 9]),
        np.array([2, 5, 30]), np.array([3, 4, 25]), np.zeros(1, np.int64),
    )  # fmt: skip
    d = np.zeros(1, dtype=WINDOW_DETECTION_DTYPE)
    d["t"] = 2
    inference = Inference(
        detected=np.array([True]), counts=np.zeros((1, 5), np.int64),
        first_detection_t=np.array([2], np.uint64), detections=d,
        thresholds=np.zeros((1, 4), np.float32),
    )  # fmt: skip
    boxes = module.field_boxes(net, w, inference, np.array([0]))
    assert boxes.tolist() == [[2, 3, 6, 5]]  # the later spike at t=9 is left out
    f = module.figures(boxes, np.array([[2.0, 3.0, 6.0, 5.0]]))
    assert f["iou_median"] == 1.0 and f["centre_error_px_median"] == 0.0
    assert (f["width_median"], f["height_median"]) == (4.0, 2.0)


@pytest.fixture(scope="module")
def probe(bench_script):
    return bench_script("probe_readout")


def test_probe_readouts_learn_what_is_there(probe):
    # The probe's "no better than the rule" means something only if its readouts find a label
    # that the features do carry: here one feature decides it, among noise features.
    rng = np.random.default_rng(0)
    x = rng.normal(size=(600, 6))
    y = x[:, 2] + 0.1 * rng.normal(size=600) > 0
    on_train, on_test = probe.logistic(x[:400], y[:400], x[400:])
    assert np.mean(on_train == y[:400]) > 0.95 and np.mean(on_test == y[400:]) > 0.95
    assert np.mean(probe.nearest(x[:400], y[:400], x[400:], 5) == y[400:]) > 0.75
    # and not where they do not: shuffled labels stay near chance on held-out windows
    shuffled = rng.permutation(y)
    _, on_test = probe.logistic(x[:400], shuffled[:400], x[400:])
    assert abs(np.mean(on_test == shuffled[400:]) - 0.5) < 0.15


def test_probe_features_of_a_small_set(probe, tmp_path):
    from uavsnn.dataset import build, load

    build(tmp_path / "d", "dvs", n_train=8, n_test=4, seed=3)
    data = load(tmp_path / "d", "train")
    config = apply_overrides(default_config(), ["conv2.threshold=10", "conv3.threshold=1"])
    net = Network(config, seed=0)
    x, conv3, rule = probe.features(net, data)
    maps = sum(net.shapes[layer][0] for layer in probe.LAYERS)
    assert x.shape == (len(data), maps + 2 * len(probe.LAYERS) + 3 + 6) == (len(data), len(conv3))
    assert conv3.sum() == net.shapes["conv3"][0] + 2 + 3
    assert np.isfinite(x).all()
    assert rule.tolist() == net.infer(data.windows).detected.tolist()


def test_identify_draws_joins_training_sets_keeping_recordings_apart(bench_script, tmp_path):
    from uavsnn.dataset import SceneSource, build, load

    draws = bench_script("identify_draws")
    source = SceneSource("dvs", (240, 180), 200.0, 0.3)
    for seed in (1, 2):
        build(tmp_path / f"s{seed}", "dvs", n_test=2, n_train=12, seed=seed, dvs=source)
    a, b = (load(tmp_path / f"s{seed}", "train") for seed in (1, 2))
    both = draws.joined(f"{tmp_path / 's1'},{tmp_path / 's2'}")
    assert len(both) == len(a) + len(b)
    # Every window of both sets, each set's recordings apart from the other's.
    assert sorted(both.windows.t0.tolist()) == sorted(a.windows.t0.tolist() + b.windows.t0.tolist())
    assert len(np.unique(both.recording)) == len(np.unique(a.recording)) + len(
        np.unique(b.recording)
    )
    assert len(draws.joined(str(tmp_path / "s1"))) == len(a)
    build(tmp_path / "s3", "dvs", n_test=2, n_train=6, seed=3, dvs=source)
    with pytest.raises(SystemExit, match="of one size"):
        draws.joined(f"{tmp_path / 's1'},{tmp_path / 's3'}")


def test_identify_draws_fits_each_group_of_features(bench_script, tmp_path, monkeypatch, capsys):
    """--group fits the features of each named group of identify.GROUPS, the same way."""
    import json

    from uavsnn import Network
    from uavsnn.dataset import SceneSource, build
    from uavsnn.identify import GROUPS
    from uavsnn.network import default_config
    from uavsnn.training import apply_overrides

    draws = bench_script("identify_draws")
    source = SceneSource("dvs", (240, 180), 200.0, 0.3)
    for seed in (11, 12):  # seeds whose scenes give both kinds of object to this network
        build(tmp_path / f"s{seed}", "dvs", n_test=2, n_train=24, seed=seed, dvs=source)
    config = apply_overrides(default_config(), ["conv2.threshold=5", "conv3.threshold=1"])
    Network(config, seed=0).save(tmp_path / "m.npz")
    s1, s2 = tmp_path / "s11", tmp_path / "s12"
    argv = ["identify_draws.py", str(tmp_path / "m.npz"), "--fit", str(s1), "--tune", str(s2)]
    argv += ["--score", str(s2), "--model", "logistic", "--json"]
    monkeypatch.setattr("sys.argv", [*argv, "--group", "all", "--group", "no_activity_history"])
    draws.main()
    out = json.loads(capsys.readouterr().out)
    assert list(out) == [f"{s1} [logistic]", f"{s1} [logistic] [no_activity_history]"]
    full, fewer = out.values()
    assert full["model"] == fewer["model"] == "logistic"
    assert set(full["scored"]) == set(fewer["scored"]) == {str(s2)}
    assert full["features"] == list(GROUPS["all"])
    assert fewer["features"] == list(GROUPS["no_activity_history"])
    # As text: these sets draw from fewer than 5 UAV-free recordings, so no interval ("nan-nan").
    monkeypatch.setattr("sys.argv", [a for a in argv if a != "--json"])
    draws.main()
    text = capsys.readouterr().out
    assert "set for 1 %: false alarms" in text and "nan" not in text
    assert "no 95 % interval: fewer than 5 recordings of a kind; 2 UAV-free" in text


def test_rss_noise_runs_a_level_in_parts_with_the_points_of_one(bench_script) -> None:
    import argparse

    bench = bench_script("rss_noise")
    args = argparse.Namespace(
        sensor="240x180", windows=8, fraction=0.05, density=0.02, box=32, seed=0
    )
    parts, whole = bench.run(args, 5000), bench.run(args, 10**9)
    # 864 signal and 2160 noise spikes a window: one window a part, against one part.
    assert (parts["parts"], whole["parts"]) == (8, 1)
    assert parts["input_spikes"] == whole["input_spikes"] >= 8 * 2160
    assert parts["points"] == whole["points"] and len(parts["points"]) == 2
    assert parts["peak_growth_mib"] >= 0


def test_infer_batch_times_one_call(bench_script, capsys) -> None:
    bench = bench_script("infer_batch")
    r = bench.measure(6, 0.01, (40, 30), 1, 2)
    assert r["windows"] == 6 and r["input_spikes"] > 0
    assert 0 <= r["cpu_s_best"] <= r["cpu_s_median"] and r["wall_s_best"] > 0
    assert bench.main(["--windows", "4", "--size", "40x30", "--repeats", "1", "--json"]) == 0
    assert '"windows": 4' in capsys.readouterr().out


def test_identify_by_domain_keeps_the_windows_of_the_domains_named(
    bench_script, tmp_path, monkeypatch
):
    from uavsnn.dataset import SceneSource, build, load

    by_domain = bench_script("identify_by_domain")
    dvs = SceneSource("dvs", (240, 180), 200.0, 0.3)
    sim = SceneSource("sim", (480, 360), None, 0.5, sensor=(240, 180))
    build(tmp_path / "c", "combined", n_test=2, n_train=12, seed=1, dvs=dvs, sim=sim)
    data = load(tmp_path / "c", "train")
    domain = {r["id"]: r["domain"] for r in data.manifest["recordings"]}
    seen = {domain[int(r)] for r in data.recording}
    assert seen == {"dvs", "sim"}
    for kept in ("dvs", "sim"):
        part = by_domain.of_domains(data, {kept})
        assert {domain[int(r)] for r in part.recording} == {kept}
        assert len(part) == sum(domain[int(r)] == kept for r in data.recording)
    assert len(by_domain.of_domains(data, {"dvs", "sim"})) == len(data)
    with pytest.raises(SystemExit, match="no window of a real recording"):
        by_domain.of_domains(data, {"real"})
    # Several sets together: every window of each, their recordings kept apart.
    both = by_domain.gathered([tmp_path / "c", tmp_path / "c"], None)
    assert len(both) == 2 * len(data)
    assert len(np.unique(both.recording)) == 2 * len(np.unique(data.recording))
    dvs_only = by_domain.gathered([tmp_path / "c", tmp_path / "c"], {"dvs"})
    assert len(dvs_only) == 2 * len(by_domain.of_domains(data, {"dvs"}))
    # Without --tune the fit is handed no tuning set (it holds recordings out, as `uavsnn
    # train` does), and the kept training windows.
    seen: list[Any] = []

    def fit(network: Any, train: Any, tune: Any) -> dict[str, str]:
        seen.append((train, tune))
        return {"skipped": "caught"}

    monkeypatch.setattr(by_domain, "fit_identification", fit)
    model = tmp_path / "m.npz"
    Network({"width": 240, "height": 180}, seed=0).save(model)
    argv = [str(model), str(tmp_path / "c"), "--domain", "dvs", "-o", str(tmp_path / "o.npz")]
    with pytest.raises(SystemExit, match="caught"):
        by_domain.main(argv)
    ((train, tune),) = seen
    assert tune is None and len(train) == len(by_domain.of_domains(data, {"dvs"}))


def test_feature_groups_fits_each_group_as_the_ablation_does(bench_script, tmp_path) -> None:
    from uavsnn import identify
    from uavsnn.dataset import SceneSource, build, load
    from uavsnn.experiments import recipe_config
    from uavsnn.training import train

    groups = bench_script("feature_groups")
    source = SceneSource("dvs", (240, 180), 200.0, 0.3)
    build(tmp_path / "a", "dvs", n_test=24, n_train=60, seed=21, dvs=source)
    build(tmp_path / "b", "dvs", n_test=2, n_train=40, seed=22, dvs=source)
    fit_on, test = load(tmp_path / "a", "train"), load(tmp_path / "a", "test")
    tune = load(tmp_path / "b", "train")
    net = train(Network(recipe_config(), seed=0), fit_on.windows, windows_per_layer=60).network
    rows = groups.measure(net, fit_on, tune, {"test": test}, ("track", "all"))
    assert list(rows) == ["track", "all"]
    assert 2 * np.count_nonzero(test.label) == len(test)
    # The same fit, tuning and scores as `uavsnn evaluate --ablation`'s.
    inf, tune_inf = net.infer(test.windows), net.infer(tune.windows)
    ablation = identify.ablation(
        identify.window_features(net, fit_on),
        identify.window_features(net, tune, tune_inf),
        identify.window_features(net, test, inf),
        tune_detected=tune_inf.detected, tune_label=tune.label,
        test_detected=inf.detected, test_label=test.label,
    )  # fmt: skip
    for name, row in rows.items():
        assert row["features"] == len(identify.GROUPS[name])
        for rate in ("0.01", "0.05"):
            key = f"detection_at_{rate}"
            assert row["test"][key] == ablation[name][key]
            assert 0 <= row["tune"][key] <= 1
        # On a test split half UAV, the balanced accuracy is the ablation's accuracy.
        assert row["test"]["balanced_accuracy"] == pytest.approx(ablation[name]["accuracy"])
        area = row["tune"]["object_roc_area"]
        assert area is None or 0 <= area <= 1


def test_roc_point_coverage_scores_a_noise_level_as_the_table3_sweep_does(
    bench_script, tmp_path
) -> None:
    """With --noise and --static-threshold the script scores the model and its static twin on
    the noisy windows a Table 3 level gives them: the same decisions as noise_level's."""
    from uavsnn.dataset import SceneSource, build, load
    from uavsnn.experiments import noise_level, noise_seed, with_config
    from uavsnn.identifier import Identifier
    from uavsnn.identify import FEATURES

    cover = bench_script("roc_point_coverage")
    root = build(
        tmp_path / "set", "dvs", n_test=24, n_train=0, seed=5,
        dvs=SceneSource("dvs", (240, 180), 200.0, 0.4),
    ).root  # fmt: skip
    net = Network({"width": 240, "height": 180, "conv2": {"threshold": 10.0}}, seed=0)
    k = len(FEATURES)
    net.identification = Identifier(
        FEATURES, np.r_[np.full(k, 0.1), -0.5], np.zeros(k), np.ones(k), 0.5, 1.0
    )
    static = with_config(net, pent={"mode": "static"}, conv1={"threshold": 3.0})
    data = load(root, "test")
    points = noise_level(
        {"pent": net, "static": static}, data, 0.05, seed=noise_seed(0, 0.05), threads=1
    )
    actual = np.asarray(data.label, bool)
    for point, model in zip(points, (net, static), strict=True):
        for any_spike in (False, True):
            got = cover.combined_scores(model, str(root), "test", noise=0.05, any_spike=any_spike)
            assert np.array_equal(got["actual"], actual)
            identified = point.identified
            assert identified is not None
            expected = (
                point.evaluation.accuracy if any_spike else identified["identified"]["accuracy"]
            )
            assert got["right"].mean() == pytest.approx(expected)
    clean = cover.combined_scores(net, str(root), "test")
    noisy = cover.combined_scores(net, str(root), "test", noise=0.05)
    assert not np.array_equal(clean["scores"], noisy["scores"])


def test_roc_interval_methods_read_four_intervals_off_the_same_draws(bench_script) -> None:
    from uavsnn.evaluation import roc_point_interval

    methods = bench_script("roc_interval_methods")
    r = np.random.default_rng(5)

    def scored_set(n_rec: int) -> dict[str, np.ndarray]:
        rec = np.repeat(np.arange(n_rec), 20)
        actual = np.tile(np.arange(20) < 10, n_rec)
        scores = r.normal(0, 1, rec.size) + 1.5 * actual + r.normal(0, 1, n_rec)[rec]
        return {"scores": scores, "actual": actual, "recording": rec}

    one = scored_set(30)
    got = methods.intervals(one["scores"], one["actual"], one["recording"], 0.05, 300, 7)
    assert set(got) == set(methods.METHODS)
    # The percentile interval is the one evaluate reports, off the same draws.
    assert got["percentile"] == roc_point_interval(
        one["scores"], one["actual"], one["recording"], 0.05, resamples=300, seed=7
    )
    point = methods.detection_at_false_alarm(one["scores"], one["actual"], 0.05)
    lo, hi = got["percentile"]
    assert got["basic"] == pytest.approx((2 * point - hi, 2 * point - lo))
    assert all(lo <= hi for lo, hi in got.values())
    # No unit moves the point of recordings all alike: no acceleration, BCa is BC.
    alike = {k: np.tile(v[:20], 8) for k, v in one.items() if k != "recording"}
    rec = np.repeat(np.arange(8), 20)
    assert methods.acceleration(alike["scores"], alike["actual"], rec, 0.05) == 0.0
    same = methods.intervals(alike["scores"], alike["actual"], rec, 0.05, 100, 0)
    assert same["bca"] == same["bc"]
    out = methods.compare([scored_set(30), scored_set(34)], 0.05, draws=20, resamples=100, seed=0)
    assert out["draws"] == 20 and set(out["methods"]) == set(methods.METHODS)
    for m in out["methods"].values():
        assert m["coverage"] + m["above_pool"] + m["below_pool"] == pytest.approx(1.0)
        assert m["mean_width"] > 0


def test_roc_point_coverage_draws_sets_of_recordings_from_the_pool(bench_script) -> None:
    cover = bench_script("roc_point_coverage")
    r = np.random.default_rng(3)

    def scored_set(n_rec: int, offset: float) -> dict[str, np.ndarray]:
        rec = np.repeat(np.arange(n_rec), 20)
        actual = np.tile(np.arange(20) < 10, n_rec)  # each recording both kinds
        scores = r.normal(0, 1, rec.size) + 1.5 * actual + offset * r.normal(0, 1, n_rec)[rec]
        return {"scores": scores, "actual": actual, "recording": rec}

    sets = [scored_set(30, 1.0), scored_set(34, 1.0)]
    free, uav = cover.units(sets)
    # Each recording's UAV-free windows and its UAV windows, as two units.
    assert len(free) == len(uav) == 64 and all(u.shape == (1, 10) for u in free + uav)
    s, a, rec = cover.draw_set(r, free, uav, 5, 7)
    assert s.shape == (1, 120) and a.sum() == 70 and (~a).sum() == 50 and len(np.unique(rec)) == 12
    assert all(len(np.unique(a[rec == i])) == 1 for i in np.unique(rec))
    got = cover.coverage(sets, 0.05, draws=40, resamples=200, seed=0)
    assert got["units_per_set"] == {"uav_free": 32, "uav": 32}
    assert got["point_spread"]["sd"] > 0 and got["mean_width"] > 0
    assert 0.5 <= got["coverage"] <= 1
    # The pool as one set: its interval holds its point, narrower than one set's on average.
    lo, hi = got["pool"]["interval"]
    assert lo <= got["pool"]["point"] <= hi and 0 < hi - lo < got["mean_width"]
    twice = cover.coverage(sets, 0.05, draws=40, resamples=200, seed=0, scale=2)
    assert twice["units_per_set"] == {"uav_free": 64, "uav": 64}
    # Units all alike: every drawn set is the pool again, its interval the pool's point.
    same = [{k: np.tile(v[:20], 8) if k != "recording" else np.repeat(np.arange(8), 20)
             for k, v in sets[0].items()}]  # fmt: skip
    alike = cover.coverage(same, 0.05, draws=10, resamples=100, seed=0)
    assert alike["coverage"] == 1.0 and alike["mean_width"] == 0.0
    assert alike["point_spread"]["sd"] == pytest.approx(0.0, abs=1e-12)
    assert alike["pool"]["interval"] == [alike["pool"]["point"]] * 2
    # Against a second score the units carry both, and the point is the lead: none for a
    # score that ranks the windows alike, on every draw; some for one that does not.
    for one in sets:
        one["against"] = 3 * one["scores"] - 1
    free, uav = cover.units(sets)
    assert all(u.shape == (2, 10) for u in free + uav)
    tied = cover.coverage(sets, 0.05, draws=20, resamples=100, seed=0)
    assert tied["paired"] and tied["pool"]["point"] == 0.0
    assert tied["coverage"] == 1.0 and tied["mean_width"] == 0.0
    for one in sets:
        one["against"] = one["scores"] + r.normal(0, 1, one["scores"].size)
    noisy = cover.coverage(sets, 0.05, draws=40, resamples=200, seed=0)
    assert noisy["pool"]["point"] > 0 and noisy["mean_width"] > 0
    assert 0.5 <= noisy["coverage"] <= 1
    # The accuracy at a model's threshold (rate None): the pool's share of windows decided
    # right; alike units give it on every draw, where the interval is Clopper-Pearson's over
    # the windows (recording_interval's, the draws saying nothing), which holds it.
    for one in sets + same:
        one["right"] = (one["scores"] >= 0.75) == one["actual"]
    acc = cover.coverage(sets, None, draws=40, resamples=200, seed=0)
    pooled = np.concatenate([one["right"] for one in sets])
    assert acc["pool"]["point"] == pytest.approx(pooled.mean())
    assert not acc["paired"] and acc["mean_width"] > 0 and 0.5 <= acc["coverage"] <= 1
    alike = cover.coverage(same, None, draws=10, resamples=100, seed=0)
    assert alike["coverage"] == 1.0 and alike["mean_width"] > 0
    # Paired: the lead over a model deciding each window alike is none on every draw.
    for one in sets:
        one["right_against"] = one["right"].copy()
    tied = cover.coverage(sets, None, draws=10, resamples=100, seed=0)
    assert tied["paired"] and tied["pool"]["point"] == 0.0 and tied["mean_width"] == 0.0
    for one in sets:
        one["right_against"] = (one["scores"] >= 1.5) == one["actual"]
    led = cover.coverage(sets, None, draws=40, resamples=200, seed=0)
    truth = pooled.mean() - np.concatenate([one["right_against"] for one in sets]).mean()
    assert led["pool"]["point"] == pytest.approx(truth) and led["mean_width"] > 0
    assert 0.5 <= led["coverage"] <= 1


def test_scene_bits_counts_what_differs_between_two_renders(bench_script, tmp_path) -> None:
    bits = bench_script("scene_bits")
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    frames = np.zeros((4, 3, 5), dtype=np.float32)
    events = np.arange(6)
    for domain in ("dvs", "sim"):
        np.save(a / f"{domain}-0-frames.npy", frames)
        np.save(a / f"{domain}-0-events.npy", events)
        other = frames.copy()
        if domain == "sim":
            other[1, 0, :2] = 1.0  # two values of frame 1
            other[3, 2, 4] = 1.0  # one of frame 3
        np.save(b / f"{domain}-0-frames.npy", other)
        np.save(b / f"{domain}-0-events.npy", events[:5] if domain == "sim" else events)
    got = bits.compare(a, b, 1)
    assert got["dvs"] == {
        "values": 60, "values_differ": 0, "frames": 4, "frames_differ": 0,
        "events": 6, "event_sets_differ": 0, "scenes": 1,
    }  # fmt: skip
    assert got["sim"]["values_differ"] == 3 and got["sim"]["frames_differ"] == 2
    assert got["sim"]["event_sets_differ"] == 1
    libc = np.arange(8.0).reshape(2, 4)
    np.save(a / "libc.npy", libc)
    libc[1, 2] = np.nextafter(libc[1, 2], 9.0)  # one value a bit off
    np.save(b / "libc.npy", libc)
    for folder in (a, b):
        np.save(folder / "conv1.npy", np.ones((4, 1, 5, 5), np.float32))
    assert bits.compare_libc(a, b) == {
        "values": 8, "values_differ": 1, "conv1_weights": 100, "conv1_weights_differ": 0,
    }  # fmt: skip
    assert "opencv" in bits.variants()


def test_the_push_cost_compares_the_same_pushes(bench_script) -> None:
    calls = bench_script("bench_python_calls")
    got = calls.push_cost(Network({"width": 16, "height": 12}), repeats=1, pushes=40)
    assert got["pushes"] == 40
    assert got["push_us_per_call"] > 0 and got["engine_push_us_per_call"] > 0
    assert got["python_us_per_push"] == pytest.approx(
        got["push_us_per_call"] - got["engine_push_us_per_call"]
    )


def test_pix2nvs_adaptive_counts_the_events_in_a_labelled_box(bench_script, tmp_path) -> None:
    """benches/python/pix2nvs_adaptive.py on a made clip: a bright square moving over a still
    grey frame, labelled frame by frame. Every setting's events are (nearly) all on the square;
    the late count is taken after the time asked."""
    import cv2

    module = bench_script("pix2nvs_adaptive")
    video = tmp_path / "V_DRONE_001.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (320, 240))
    assert writer.isOpened()
    rows = ["frame,x,y,w,h"]
    for k in range(30):
        frame = np.full((240, 320, 3), 90, np.uint8)
        x = 40 + 6 * k
        frame[100:132, x : x + 32] = 250
        writer.write(frame)
        rows.append(f"{k + 1},{x},100,32,32")
    writer.release()
    (tmp_path / "V_DRONE_001.csv").write_text("\n".join(rows) + "\n")
    got = module.measure(video, module.SETTINGS["adaptive=0 (our default)"], 5.0, 0.5, None)
    assert got["events"] > 0 and got["in_box_share"] > 0.9
    assert got["frames"] == 30 and got["events_per_frame_after"] is not None
    first = module.measure(video, module.Pix2NvsParams(), 5.0, 0.5, 0.5)
    assert first["frames"] == 15 and first["events_per_frame_after"] is None
