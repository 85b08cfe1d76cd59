"""Smoke tests of benches/python/bench_identify.py at a tiny size: each part of --section runs
on the same windows as the timed bench (count_identify.py counts those parts under
callgrind); of benches/python/network_shape.py's spike counts per object; of
benches/python/rate_swing.py's bins and wingbeat_probe.py's spectrum."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from uavsnn import EVENT_DTYPE, Network, identify
from uavsnn.dataset import LabelledWindows
from uavsnn.dataset.format import RawEvents
from uavsnn.events import Recording
from uavsnn.identify import FEATURES, Identifier, alarm_threshold, best_threshold
from uavsnn.windows import make_windows

SIZE = (40, 30)


@pytest.fixture(scope="module")
def bench(bench_script):
    return bench_script("bench_identify")


def tiny() -> tuple[Network, LabelledWindows]:
    """An untrained network that fires on a drifting blob, with an identification model, and
    the blob's windows as a dataset with raw events (one recording)."""
    config = {
        "width": SIZE[0],
        "height": SIZE[1],
        "pent": {"mode": "pent", "beta": 2.0, "theta_min": 1.5, "estimate": "preceding"},
        "conv2": {"threshold": 3.0},
        "conv3": {"threshold": 1.5},
    }
    net = Network(config, seed=3)
    k = len(FEATURES)
    net.identification = Identifier(
        FEATURES, np.r_[np.full(k, 0.1), -0.5], np.zeros(k), np.ones(k), 0.5, 1.0
    )
    rng = np.random.default_rng(0)
    n = 6000
    ev = np.zeros(n, dtype=EVENT_DTYPE)
    ev["t"] = 5_000 + np.arange(n) * 5
    ev["x"] = 3 + np.arange(n) * 15 // n + rng.integers(0, 5, n)
    ev["y"] = 4 + rng.integers(0, 5, n)
    ev["p"] = rng.random(n) < 0.5
    windows = make_windows(Recording(ev, SIZE), 10_000, 0.5)
    m = len(windows)
    raw = RawEvents.of_recording(ev, np.asarray(windows.t0), 10_000, 10_000)
    data = LabelledWindows(
        windows, np.zeros(m, bool), np.full(m, "none"), np.zeros(m, np.int64),
        np.full((m, 4), np.nan, np.float32), raw=raw,
    )  # fmt: skip
    return net, data


def test_each_section_runs_its_part_once_inside_functools_reduce(bench, monkeypatch) -> None:
    net, data = tiny()
    spikes = int(np.diff(np.asarray(data.windows.offsets, dtype=np.int64)).sum())
    calls = []
    reduce = functools.reduce

    def counted(*args):
        calls.append(1)
        return reduce(*args)

    monkeypatch.setattr(bench.functools, "reduce", counted)
    out = {s: bench._section(s, net, data, spikes, 1) for s in bench.SECTIONS}
    assert len(calls) == len(bench.SECTIONS)
    assert out["network"]["events"] == out["identification"]["events"] == spikes > 0
    raw = sum(len(s) for s in bench._streams(data, 1))
    assert out["stream-network"]["events"] == out["stream-full"]["events"] == raw > 0
    # The streamed windows hold objects (the full path measured, tracked and scored them).
    assert bench._stream(net, bench._streams(data, 1), True) > 0


def test_network_shape_counts_each_objects_spikes_inside_its_box(bench_script, monkeypatch):
    shape = bench_script("network_shape")
    net, data = tiny()
    found = shape.objects(net, data)
    assert len(found.feats.x) > 0
    # A merged box holds exactly its own conv3 detections: per map they add up to the object's
    # spike count, which the identification's features hold as log1p.
    spikes = np.expm1(found.feats.x[:, FEATURES.index("log_spikes")])
    np.testing.assert_allclose(found.conv3.sum(axis=1), spikes, rtol=1e-9)
    assert found.conv2.sum() > 0
    # Recording conv2 two windows at a time gives the same counts as the default chunks.
    monkeypatch.setattr(shape, "CHUNK", 2)
    np.testing.assert_array_equal(shape.objects(net, data).conv2, found.conv2)
    # Each variant's columns come out with one row per object.
    for extra in shape.VARIANTS.values():
        assert len(extra(found)) == len(found.feats.x)


def test_rate_swing_bench_counts_the_bins_the_feature_counts(bench_script):
    """benches/python/rate_swing.py counts each object's box with NumPy over the window and the
    one before it; the window's own bins give the engine's feature exactly: the first object of
    each track has the feature's swing as its track mean."""
    bench = bench_script("rate_swing")
    rng = np.random.default_rng(5)
    t = np.sort(rng.uniform(5_000, 305_000, 120_000))
    t = t[rng.random(len(t)) < 0.5 + 0.45 * np.sin(2 * np.pi * 60 * t / 1e6)]  # 60 Hz swing
    ev = np.zeros(len(t), dtype=EVENT_DTYPE)
    ev["t"] = t.astype(np.uint64)
    ev["x"] = 5 + (t - 5_000).astype(np.int64) * 15 // 300_000 + rng.integers(0, 5, len(t))
    ev["y"] = 4 + rng.integers(0, 5, len(t))
    ev["p"] = rng.random(len(t)) < 0.5
    windows = make_windows(Recording(ev, SIZE), 50_000, 0.5)
    m = len(windows)
    data = LabelledWindows(
        windows, np.zeros(m, bool), np.full(m, "none"), np.zeros(m, np.int64),
        np.full((m, 4), np.nan, np.float32),
        raw=RawEvents.of_recording(ev, np.asarray(windows.t0), 50_000, 50_000),
    )  # fmt: skip
    net = tiny()[0]
    found = bench.objects(net, data)
    swing = np.expm1(found.feats.x[:, FEATURES.index("log_rate_swing")])
    assert len(swing) > 2 and np.all(swing > 0)
    first = {}
    for r in np.argsort(found.feats.window, kind="stable"):
        first.setdefault(int(found.feats.track[r]), int(r))
    rows = [r for track, r in first.items() if track != 0]
    assert rows
    np.testing.assert_allclose(found.spans[rows, 1], swing[rows], rtol=1e-12)
    assert np.all(np.isfinite(found.spans)) and np.all(found.spans >= 0)


def test_wingbeat_probe_finds_a_rate_that_rises_and_falls(bench_script):
    """The probe's spectrum: a rate swinging by 40 % at 12 Hz gives its line at 12 Hz and a
    swing near 0.4 / sqrt(2); a steady Poisson rate of the same mean gives almost none."""
    probe = bench_script("wingbeat_probe")
    rng = np.random.default_rng(2)
    t = np.arange(200) * 5.0  # 1 s in 5 ms bins
    wave = rng.poisson(400 * (1 + 0.4 * np.sin(2 * np.pi * 12 * t / 1000)))
    swing, prominence, peak = probe.spectrum(wave, 5.0, (3.0, 40.0), 250.0)
    assert peak == pytest.approx(12.0, abs=1.0)
    assert swing == pytest.approx(0.4 / np.sqrt(2), rel=0.15)
    assert prominence > 20
    steady, _, _ = probe.spectrum(rng.poisson(400, 200), 5.0, (3.0, 40.0), 250.0)
    assert steady < 0.03
    assert probe.spectrum(np.zeros(200), 5.0, (3.0, 40.0), 250.0) == (0.0, 0.0, 0.0)


def test_tune_halves_balanced_accuracy_weighs_both_kinds_alike(bench_script):
    halves = bench_script("tune_halves")
    label = np.array([True, True, True, True, False, False])
    # 3 of 4 UAV windows called, 1 of 2 UAV-free windows left alone
    call = np.array([True, True, True, False, True, False])
    assert halves.balanced(call, label) == 0.5 * (0.75 + 0.5)
    assert halves.balanced(label, label) == 1.0 and halves.balanced(~label, label) == 0.0


def test_tune_halves_near_best_spans_the_thresholds_of_a_flat_best(bench_script):
    halves = bench_script("tune_halves")
    # UAV windows score 0.6-0.9, UAV-free ones 0.1-0.4 (and one the rule missed): every
    # threshold from 0.5 to 0.6 separates them; 0.4 lets one UAV-free window through.
    label = np.array([True] * 4 + [False] * 5)
    score = np.array([0.6, 0.7, 0.8, 0.9, 0.1, 0.2, 0.3, 0.4, -1.0])
    assert halves.near_best(score, label, 0.0) == (0.5, 0.6, 2)
    assert halves.near_best(score, label, 0.15) == (0.4, 0.7, 4)
    # the rule of fit: the highest of the best
    assert best_threshold(score, label, within=0.0) == 0.6


def test_tune_halves_scores_the_held_out_recordings_train_tunes_on(bench_script, monkeypatch):
    halves = bench_script("tune_halves")
    net, data = tiny()
    m = len(data)
    # four recordings in turn (windows 0-5): split_by_recording holds out recording 0
    data = LabelledWindows(
        data.windows, np.arange(m) % 2 == 0, data.cls, np.arange(m) % 4, data.box, raw=data.raw
    )
    monkeypatch.setattr(halves, "load", lambda path, split: data)
    fired, score, label, recording, cls = halves.tuning_scores(net, "any", held_out=True)
    held = identify.split_by_recording(data)[1]
    assert list(recording) == [0, 0] and np.array_equal(recording, held.recording)
    assert np.array_equal(label, held.label) and len(fired) == len(score) == len(held)
    assert np.array_equal(cls, held.cls)
    whole = halves.tuning_scores(net, "any")
    assert np.array_equal(whole[3], data.recording)
    # the held-out windows score as they do among all the windows
    assert np.array_equal(score, whole[1][data.recording == 0])


def test_tune_spread_sets_points_on_redrawn_recordings(bench_script):
    spread = bench_script("tune_spread")
    # UAV-free recordings 0..9 of 10 windows each, recording k scoring k / 10; UAV windows
    # (recording 99) never count.
    recording = np.concatenate([np.repeat(np.arange(10), 10), np.full(5, 99)])
    label = recording == 99
    score = np.where(label, 0.99, recording / 10.0)
    # On the whole set: 10 % of 100 windows may alarm, so the threshold lies just above
    # recording 8's score and only recording 9 alarms; 1 % alarms on part of recording 9.
    own = alarm_threshold(score, label, 0.10)
    assert 0.8 < own <= 0.9 + 1e-12 and (score[~label] >= own).mean() == 0.10
    again = spread.redrawn_thresholds(score, label, recording, (0.01, 0.10), 300, seed=4)
    assert again.shape == (300, 2)
    # A redraw holding recording 9 twice sets the 10 % point at 0.9; one without it lower.
    assert again[:, 1].max() > 0.9 - 1e-9 and again[:, 1].min() < 0.8
    assert np.array_equal(
        again, spread.redrawn_thresholds(score, label, recording, (0.01, 0.10), 300, seed=4)
    )
    # Windows the any-spike rule misses score -1: the point never goes below 0.
    assert alarm_threshold(np.full(20, -1.0), np.zeros(20, bool), 0.05) == 0.0
    # One UAV-free recording: every redraw is the set itself.
    one = recording < 1
    same = spread.redrawn_thresholds(score[one], label[one], recording[one], (0.05,), 20)
    assert np.all(same == alarm_threshold(score[one], label[one], 0.05))


def test_threshold_rule_sets_each_rule_on_the_flat_best(bench_script):
    rule = bench_script("threshold_rule")
    # UAV windows 0.6-0.9, UAV-free 0.1-0.45: 0.5 and 0.6 separate them (balanced accuracy
    # 1), 0.45 and 0.7 each miss one window of four (0.875)
    label = np.array([True] * 4 + [False] * 4)
    score = np.array([0.6, 0.7, 0.8, 0.9, 0.1, 0.2, 0.3, 0.45])
    assert rule.rule_thresholds(score, label, (0.0, 0.125)) == {
        rule.SMALLEST: 0.5,
        "within 0": 0.6,
        "within 0.125": 0.7,
    }
    # two recordings a kind, drawn again apart: the best separates the drawn windows exactly,
    # so "within 0" is the lowest UAV score drawn: 0.6 with UAV recording 0, 0.8 without it;
    # the smallest of the best stays 0.5 (above either UAV-free recording's scores)
    recording = np.array([0, 0, 2, 2, 1, 1, 3, 3])
    again = rule.redrawn_thresholds(score, label, recording, (0.0,), 100, seed=1)
    assert set(again) == {rule.SMALLEST, "within 0"} and again["within 0"].shape == (100,)
    assert set(again["within 0"]) == {0.6, 0.8} and set(again[rule.SMALLEST]) == {0.5}
    assert np.array_equal(
        again["within 0"],
        rule.redrawn_thresholds(score, label, recording, (0.0,), 100, seed=1)["within 0"],
    )


def test_threshold_rule_class_share_holds_every_other_class_under_the_share(bench_script):
    rule = bench_script("threshold_rule")
    # UAV windows 0.5-0.9; four birds 0.1-0.4, two helicopters 0.6 and 0.85, four empty scenes
    # 0.05 and one the any-spike rule missed (-1)
    label = np.array([True] * 5 + [False] * 10)
    cls = np.array(["drone"] * 5 + ["bird"] * 4 + ["helicopter"] * 2 + ["none"] * 4)
    score = np.r_[0.5, 0.6, 0.7, 0.8, 0.9, 0.1, 0.2, 0.3, 0.4, 0.6, 0.85, 0.05, 0.05, 0.05, -1]
    # half of the helicopters may pass: just above the lower one (the birds never reach it)
    assert rule.class_share_threshold(score, label, cls, 0.5) == 0.7
    # none: above the higher helicopter, though only 2 of 10 UAV-free windows score above 0.6
    assert rule.class_share_threshold(score, label, cls, 0.25) == 0.9
    # every class of other object at or above every UAV window: above every score
    cls[9:11] = "bird"
    score[5:11] = 0.95
    assert rule.class_share_threshold(score, label, cls, 0.0) > 0.95


def test_polarity_flips_count_each_pixels_flips_in_time_order(bench_script):
    flips = bench_script("polarity_flips")

    def events(rows: list[tuple[int, int, int, bool]]) -> np.ndarray:
        ev = np.zeros(len(rows), dtype=EVENT_DTYPE)
        for k, (t, x, y, on) in enumerate(rows):
            ev[k] = (t, x, y, on)
        return ev[np.argsort(ev["t"], kind="stable")]

    box = (2, 2, 6, 6)
    # pixel (3, 3) alternates ON/OFF every 1 ms (9 flips of 10 events, all fast); pixel (4, 4)
    # gives two ON events 10 ms apart (no flip); (8, 8) lies outside the box
    rows = [(1_000 * k, 3, 3, k % 2 == 0) for k in range(10)]
    rows += [(500, 4, 4, True), (10_500, 4, 4, True), (700, 8, 8, False), (800, 8, 8, True)]
    got = flips.flip_columns(events(rows), box, 16)
    assert got == pytest.approx([9 / 12, 9 / 12, 1 / 2])
    # every 5 ms: the same flips, none fast
    slow = [(5_000 * k, 3, 3, k % 2 == 0) for k in range(10)]
    assert flips.flip_columns(events(slow), box, 16) == pytest.approx([0.9, 0.0, 1.0])
    # the pixels are told apart by row too: (3, 3) all ON and (3, 4) all OFF, interleaved
    mixed = [(1_000 * k, 3, 3 + k % 2, k % 2 == 0) for k in range(10)]
    assert flips.flip_columns(events(mixed), box, 16) == pytest.approx([0.0, 0.0, 0.0])
    assert list(flips.flip_columns(events(rows[-2:]), box, 16)) == [0.0, 0.0, 0.0]
    # timed from the pixel's flip before, its first flip is never fast: 8 of the 12 events
    assert flips.flip_columns(events(rows), box, 16, "flip") == pytest.approx([0.75, 8 / 12, 0.5])
    # two pixels flipping 1 ms apart, once each: neither is timed from the other's flip
    two = [(0, 3, 3, True), (1_000, 3, 3, False), (500, 4, 4, True), (2_000, 4, 4, False)]
    assert flips.flip_columns(events(two), box, 16, "flip") == pytest.approx([0.5, 0.0, 0.0])
    assert flips.flip_columns(events(two), box, 16) == pytest.approx([0.5, 0.5, 0.0])


def test_class_ranking_gives_each_class_its_own_area(bench_script):
    ranking = bench_script("class_ranking")
    label = np.array([True, True, False, False, False, False, False])
    cls = np.array(["uav", "uav", "bird", "bird", "helicopter", "helicopter", ""])
    score = np.array([0.9, 0.6, 0.1, 0.2, 0.95, 0.7, 0.99])
    usable = np.ones(7, bool)
    areas = ranking.class_areas(score, label, cls, usable)
    # Birds rank below both UAVs; each helicopter ranks above one UAV; unnamed objects are left out.
    assert areas == {"bird": 1.0, "helicopter": 0.25}
    usable[4] = False  # the helicopter above both UAVs
    assert ranking.class_areas(score, label, cls, usable)["helicopter"] == 0.5
    assert ranking.class_areas(score, ~np.ones(7, bool), cls, np.ones(7, bool)) == {
        "bird": None,
        "helicopter": None,
        "uav": None,
    }


def test_track_roc_counts_false_tracks_from_the_peaks(bench_script):
    roc = bench_script("track_roc")
    free = {"minutes": 2.0, "track_peaks": [0.9, 0.8, 0.8, 0.3]}
    assert roc.false_tracks(free, 0.8) == 1.5 and roc.false_tracks(free, 0.95) == 0.0
    calls = []

    def found(threshold):
        calls.append(threshold)
        return {"found": int(10 * threshold), "time_to_alarm_ms": {"median": None}}

    other = {"minutes": 1.0, "track_peaks": [0.85]}
    table = roc.rows(found, [free, other], [("a", 0.8), ("b", 0.5)])
    assert calls == [0.8, 0.5]
    assert [r["found"] for r in table] == [8, 5]
    assert [r["false_tracks_per_minute"] for r in table] == [[1.5, 1.0], [1.5, 1.0]]


def test_stream_points_set_a_share_of_streamed_windows(bench_script):
    points = bench_script("stream_points")
    free = {"windows": 10, "window_peaks": [0.9, 0.8, 0.8, 0.3]}
    assert list(points.window_scores(free)) == [0.9, 0.8, 0.8, 0.3, *[-1.0] * 6]
    # 10 % of 10 windows: one may alarm, so the point lies just above the second peak.
    t = points.stream_point(free, 0.1)
    assert 0.8 < t <= 0.9 and points.share(free, t) == 0.1
    # 50 %: more than every detection allows: 0.0, every scored window alarms.
    assert points.stream_point(free, 0.5) == 0.0 and points.share(free, 0.0) == 0.4


def test_rotor_by_class_reads_the_labelled_drones_blade_pass(bench_script):
    """benches/python/rotor_by_class.py reads each window's own labelled box: a hovering
    Phantom's lines lie at its blade pass (two blades, the scene's rotor rate), a
    helicopter scene's windows are the helicopter's, and each box's speed is measured to the
    next window (none for the last)."""
    from uavsnn.dataset.splits import WindowCut
    from uavsnn.dataset.synthetic import SceneSource, scene_spec

    rotor = bench_script("rotor_by_class")
    source = SceneSource("dvs", (240, 180), 500.0, 0.5, sensor=(240, 180))
    cut = WindowCut(50_000, 0.5, 0.5)
    (phantom,) = scene_spec(source, "uav", 500).objects
    rows = rotor.windows_of(source, cut, "uav", 500)
    # The rate spectrum finds the line in a few of the windows (a dim crossing scene, light
    # 0.08; the edge estimator in fewer since the frames are drawn as finely as the samples
    # between them, docs/identification.md, "Fast parts drawn alike at frames and between").
    found = [r["spectrum"].frequency_hz for r in rows if r["spectrum"].detected]
    assert len(found) >= len(rows) // 6
    assert np.allclose(found, 2 * phantom.rate_hz, rtol=0.05)
    assert all(np.isfinite(r["speed"]) for r in rows[:-1]) and np.isnan(rows[-1]["speed"])
    assert rotor.lines(rows, "spectrum").startswith(f"{len(found)} of {len(rows)} ")
    heli = rotor.windows_of(source, cut, "helicopter", 500)
    assert heli and all(r["rec"] == 500 for r in heli)
    assert scene_spec(source, "object", 500, "helicopter").objects[0].kind == "helicopter"


def test_pix2nvs_choice_leads_pair_windows_and_clips_by_name(bench_script):
    choice = bench_script("pix2nvs_choice")

    def read(name, keys, label, called, clip_right):
        n = len(keys)
        label = np.array(label)
        rows = [
            {"clip": c, "uav": u, "rules": {"identified": {"alarmed": u == ok}}}
            for c, (u, ok) in clip_right.items()
        ]
        clip = np.array([k[0] for k in keys])
        flags = np.array(called)
        return choice.Read(name, keys, label, clip, flags, flags, np.zeros(n), rows)

    # clip a: two UAV windows; clip b: two UAV-free ones; c: one of each
    keys = [("a", 0), ("a", 25), ("b", 0), ("b", 25), ("c", 0), ("c", 25)]
    label = [True, True, False, False, True, False]
    clips = {"a": (True, True), "b": (False, True), "c": (True, True)}
    ref = read("ref", keys, label, [True, False, False, False, False, False], clips)
    # the same calls listed in another order, and a window the reference does not keep
    order = [5, 4, 3, 2, 1, 0]
    same = read(
        "same",
        [keys[i] for i in order] + [("d", 0)],
        [label[i] for i in order] + [True],
        [ref.called[i] for i in order] + [True],
        clips,
    )
    assert choice.window_lead(same, ref, "called") == (0.0, (0.0, 0.0), 6)
    # one more UAV window called (of three) and one UAV-free window called (of three)
    mine = read("mine", keys, label, [True, True, False, True, False, False], clips)
    lead, (lo, hi), n = choice.window_lead(mine, ref, "fired")
    assert n == 6 and lead == pytest.approx(0.5 * (1 / 3 - 1 / 3)) and lo <= lead <= hi
    better = read("better", keys, label, [True, True, False, False, True, False], clips)
    lead, (lo, hi), _ = choice.window_lead(better, ref, "called")
    assert lead == pytest.approx(0.5 * 2 / 3) and 0 < lo <= lead <= hi
    # a shared window labelled otherwise is two datasets' disagreement, not a lead
    relabelled = read("x", keys, [not v for v in label], ref.called.tolist(), clips)
    with pytest.raises(SystemExit, match="label a shared window differently"):
        choice.window_lead(relabelled, ref, "called")
    # clips: b decided wrong by the other, paired by name
    wrong_b = read("w", keys, label, ref.called.tolist(), clips | {"b": (False, False)})
    assert choice.clip_right(wrong_b, "identified") == {"a": True, "b": False, "c": True}
    diff, (lo, hi) = choice.clip_lead(wrong_b, ref, "identified")
    assert diff == -1 and lo <= -1 / 3 <= hi <= 0
