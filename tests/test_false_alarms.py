"""False alarms over long UAV-free recording, streamed (``uavsnn.false_alarms``): the counting
rules on handmade windows, the scenes, and a tiny run end to end."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from uavsnn import Network
from uavsnn.errors import ParameterError
from uavsnn.false_alarms import (
    TUNE_KEY,
    alarm_rules,
    count_alarms,
    false_alarm_figures,
    false_alarm_table,
    stream_batch,
    summarise,
    track_alarm_threshold,
    tune_track_alarms,
    uav_free_scenes,
)
from uavsnn.grouping import WindowObject, WindowReport


def _obj(score, track, confirmed, track_score):
    return WindowObject(
        (0, 0, 4, 4), 1, uav_score=score, track_id=track, track_confirmed=confirmed,
        track_score=track_score,
    )  # fmt: skip


def test_windows_and_tracks_alarm_per_rule() -> None:
    none = np.zeros(0)
    reports = [
        # Detected: one object scoring 0.9 on a tentative track, one scoring 0.3.
        WindowReport(0, 0, 50, True, none, (_obj(0.9, 1, False, 0.9), _obj(0.3, 2, True, 0.3))),
        # Not detected: nothing alarms, whatever its objects.
        WindowReport(1, 25, 75, False, none, (_obj(0.99, 1, True, 0.95),)),
        # Detected: track 1 now confirmed at a mean of 0.7; an object without a score.
        WindowReport(2, 50, 100, True, none, (_obj(0.5, 1, True, 0.7), _obj(None, 3, True, None))),
    ]
    rules = {"any_spike": None, "strict": 0.8, "loose": 0.4}
    got = count_alarms(reports, rules)
    assert got["alarming"] == {"any_spike": 2, "strict": 1, "loose": 2}
    # any-spike: every confirmed track of a detected window (2, 1, 3); strict: none reaches
    # 0.8 while confirmed; loose: track 1 (0.7).
    assert got["tracks"] == {"any_spike": 3, "strict": 0, "loose": 1}


def test_the_scenes_are_uav_free_and_their_own() -> None:
    drawn = uav_free_scenes(0, 200)
    assert drawn == uav_free_scenes(0, 200) and drawn != uav_free_scenes(1, 200)
    assert {k for k, _ in drawn} == {"object", "empty"}
    assert 0.6 < sum(k == "object" for k, _ in drawn) / 200 < 0.8
    assert len({s for _, s in drawn}) == 200


def test_a_tiny_run_end_to_end() -> None:
    """Three recordings of 1 s through an untrained network: the figures are the rows'
    summary, per rule of the model (the any-spike rule alone without identification), and
    the same run gives the same figures."""
    net = Network(seed=0)
    assert alarm_rules(net) == {"any_spike": None}
    figures = false_alarm_figures(net, minutes=0.05, seed=3)
    assert figures["recordings"] == 3 and figures["minutes"] == pytest.approx(0.05)
    rows = stream_batch(net, uav_free_scenes(3, 3))
    assert figures == summarise(rows, alarm_rules(net)) | {"seed": 3}
    rule = figures["rules"]["any_spike"]
    assert rule["false_tracks"] == sum(r["tracks"]["any_spike"] for r in rows)
    assert rule["false_tracks_per_minute_upper95"] >= rule["false_tracks_per_minute"]
    assert figures["windows"] == sum(r["windows"] for r in rows) > 0
    assert "| any-spike |" in false_alarm_table(figures)
    assert false_alarm_figures(net, minutes=0.05, seed=3) == figures


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"minutes": 0}, "minutes must be in"),
        ({"minutes": 601}, "minutes must be in"),
        ({"minutes": 1, "seed": -1}, "seed must be"),
    ],
)
def test_bad_arguments_are_parameter_errors(kwargs, message) -> None:
    with pytest.raises(ParameterError, match=message):
        false_alarm_figures(Network(seed=0), **kwargs)


# ---------------------------------------------------------------- track alarm thresholds


def test_peaks_give_the_tracks_that_alarm_at_any_threshold() -> None:
    """count_alarms' peaks: each confirmed, scored track's highest running mean while
    confirmed in a detected window; the tracks alarming at a threshold are those whose peak
    reaches it."""
    none = np.zeros(0)
    reports = [
        WindowReport(0, 0, 50, True, none, (_obj(0.9, 1, False, 0.9), _obj(0.3, 2, True, 0.3))),
        WindowReport(1, 25, 75, False, none, (_obj(0.99, 1, True, 0.95),)),
        WindowReport(2, 50, 100, True, none, (_obj(0.5, 1, True, 0.7), _obj(0.2, 2, True, 0.25))),
        WindowReport(3, 75, 125, True, none, (_obj(None, 3, True, None),)),
    ]
    rules = {f"at {t}": t for t in (0.2, 0.3, 0.5, 0.7, 0.71, 0.95)}
    got = count_alarms(reports, rules)
    # Track 1's 0.9 was tentative and its 0.95 in a window not detected; track 2 peaked at
    # 0.3; track 3 has no score.
    assert got["track_peaks"] == [0.7, 0.3]
    # Windows 0 and 2 are detected with scores (0.9, 0.5); window 3 has none scored.
    assert got["window_peaks"] == [0.9, 0.5]
    for rule, t in rules.items():
        assert got["tracks"][rule] == sum(p >= t for p in got["track_peaks"])
        assert got["alarming"][rule] == sum(p >= t for p in got["window_peaks"])


@given(
    peaks=st.lists(st.floats(0.0, 1.0), max_size=40),
    minutes=st.floats(0.5, 60.0),
    rate=st.sampled_from([0.05, 0.1, 0.5, 1.0, 3.0]),
)
def test_track_alarm_threshold_is_the_lowest_that_holds_the_rate(peaks, minutes, rate) -> None:
    threshold = track_alarm_threshold(peaks, minutes, rate)
    alarms = sum(p >= threshold for p in peaks)
    assert 0.0 <= threshold and alarms <= rate * minutes + 1e-9
    # Any lower threshold that lets one more peak through breaks the rate.
    below = [p for p in peaks if p < threshold]
    if below:
        assert alarms + sum(p == max(below) for p in peaks) > rate * minutes


def test_track_alarm_threshold_refuses_bad_input() -> None:
    assert track_alarm_threshold([0.5, 0.4], 10.0, 0.1) == np.nextafter(0.4, 1.0)
    assert track_alarm_threshold([0.5], 10.0, 0.1) == 0.0  # one track in 10 minutes allowed
    for minutes, rate in ((0.0, 0.1), (10.0, -1.0), (float("inf"), 0.1), (10.0, float("nan"))):
        with pytest.raises(ParameterError, match="must be positive and finite"):
            track_alarm_threshold([0.5], minutes, rate)
    with pytest.raises(ParameterError, match="finite"):
        track_alarm_threshold([float("nan")], 10.0, 0.1)


def _identified(net: Network) -> Network:
    from uavsnn.identify import Identifier

    model = net.copy()
    model.identification = Identifier(
        ("log_width", "log_height"), np.array([0.2, 0.4, 0.3]), np.zeros(2), np.ones(2), 0.5, 1.0,
    )  # fmt: skip
    return model


def test_tune_track_alarms_sets_thresholds_on_recordings_of_its_own(tmp_path: Path) -> None:
    """The thresholds are track_alarm_threshold of the peaks of TUNE_KEY's recordings (never
    FREE_KEY's, which false_alarm_figures measures on); the model switches to one with
    at_false_tracks, keeps them through a save and load, and false_alarm_figures then
    measures each as a rule."""
    from uavsnn.network import default_config
    from uavsnn.training import apply_overrides

    # Untrained, with thresholds low enough that its tracks confirm (5 here; rate 40 per
    # minute allows 2 of them in 0.05 minutes, so the threshold lies between two peaks).
    config = apply_overrides(default_config(), ["conv2.threshold=5", "conv3.threshold=1"])
    net = _identified(Network(config, seed=0))
    tuned, summary = tune_track_alarms(net, minutes=0.05, seed=3, rates=(0.1, 40.0))
    scenes = uav_free_scenes(3, 3, TUNE_KEY)
    assert not set(scenes) & set(uav_free_scenes(3, 3))
    rows = stream_batch(net, scenes)
    peaks = [p for r in rows for p in r["track_peaks"]]
    minutes = sum(r["seconds"] for r in rows) / 60
    want = tuple((r, track_alarm_threshold(peaks, minutes, r)) for r in (0.1, 40.0))
    assert len(peaks) >= 3 and tuned.track_alarm_thresholds == want
    assert 0 < want[1][1] < want[0][1]
    assert tuned.track_alarm_minutes == pytest.approx(0.05)
    assert summary["confirmed_tracks"] == len(peaks) and summary["seed"] == 3
    assert tuned.at_false_tracks(0.1).threshold == want[0][1]
    with pytest.raises(ParameterError, match=r"not tuned for 0\.5 false tracks per minute"):
        tuned.at_false_tracks(0.5)
    model = net.copy()
    model.identification = tuned
    model.save(tmp_path / "m.npz")
    loaded = Network.load(tmp_path / "m.npz").identification
    assert loaded is not None and loaded.track_alarm_thresholds == want
    assert loaded.track_alarm_minutes == tuned.track_alarm_minutes
    rules = alarm_rules(model)
    assert rules["identified_tracks_at_0.1"] == want[0][1]
    with pytest.raises(ParameterError, match="need a network with identification"):
        tune_track_alarms(Network(seed=0), minutes=0.05, seed=3)
    with pytest.raises(ParameterError, match="rates must be"):
        tune_track_alarms(net, minutes=0.05, seed=3, rates=(0.1, 0.1))


def test_stream_batch_follows_the_confirmation_rule_it_is_given() -> None:
    """A looser rule confirms at least the tracks the default one does, and on this untrained
    network with low thresholds strictly more; the default is the tracker's (3 of 5)."""
    from uavsnn.network import default_config
    from uavsnn.training import apply_overrides

    config = apply_overrides(default_config(), ["conv2.threshold=5", "conv3.threshold=1"])
    net = _identified(Network(config, seed=0))
    scenes = uav_free_scenes(3, 3, TUNE_KEY)
    default = stream_batch(net, scenes)
    assert stream_batch(net, scenes, (3, 5)) == default
    loose = stream_batch(net, scenes, (1, 1))
    n_default = sum(len(r["track_peaks"]) for r in default)
    assert sum(len(r["track_peaks"]) for r in loose) > n_default >= 3


def test_track_points_hold_for_the_confirmation_rule_they_were_set_with(tmp_path: Path) -> None:
    """Points set on a 1-of-1 stream are recorded with that rule, kept through a save and
    load, and counted only in streams that follow it; a bad rule is refused."""
    from uavsnn.network import default_config
    from uavsnn.training import apply_overrides

    config = apply_overrides(default_config(), ["conv2.threshold=5", "conv3.threshold=1"])
    net = _identified(Network(config, seed=0))
    tuned, summary = tune_track_alarms(net, minutes=0.05, seed=3, confirm=(1, 1))
    assert tuned.track_alarm_confirm == (1, 1) and summary["confirm"] == "1/1"
    loose = stream_batch(net, uav_free_scenes(3, 3, TUNE_KEY), (1, 1))
    peaks = [p for r in loose for p in r["track_peaks"]]
    assert tuned.track_alarm_thresholds[0][1] == track_alarm_threshold(peaks, 0.05, 0.1)
    model = net.copy()
    model.identification = tuned
    model.save(tmp_path / "m.npz")
    loaded = Network.load(tmp_path / "m.npz")
    assert loaded.identification is not None
    assert loaded.identification.track_alarm_confirm == (1, 1)
    assert "identified_tracks_at_0.1" not in alarm_rules(loaded)  # a 3-of-5 stream
    assert "identified_tracks_at_0.1" in alarm_rules(loaded, (1, 1))
    for bad in ((0, 5), (5, 3), (2,)):
        with pytest.raises(ParameterError):
            tune_track_alarms(net, minutes=0.05, seed=3, confirm=bad)


def _tiny_run(tmp_path: Path, *, n_train: int) -> tuple[Path, Path]:
    """An untrained network with thresholds low enough to detect, with a handmade
    identification, saved; and a tiny dvs set (12 test windows, ``n_train`` train ones)."""
    from uavsnn.dataset import SceneSource, build
    from uavsnn.network import default_config
    from uavsnn.training import apply_overrides

    config = apply_overrides(default_config(), ["conv2.threshold=5", "conv3.threshold=1"])
    model = tmp_path / "m.npz"
    _identified(Network(config, seed=0)).save(model)
    root = build(
        tmp_path / "set", "dvs", n_test=12, n_train=n_train, seed=5,
        dvs=SceneSource("dvs", (240, 180), 200.0, 0.4),
    ).root  # fmt: skip
    return model, root


def test_the_track_evidence_bench_reads_the_running_mean_and_sums_log_odds(
    tmp_path: Path, bench_script, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    """benches/python/track_evidence.py: its running mean is the detector's track score (it
    checks), the summed log-odds add each object's logit less the drift, and on a tiny run
    each statistic alarms on more tracks at a higher rate, every confirmed scored track at a
    rate above their count."""
    import json

    from uavsnn.clips import clip_set

    bench = bench_script("track_evidence")
    objs = [_obj(0.9, 1, False, None), _obj(0.2, 1, True, None), _obj(0.6, None, None, None)]
    reports = [WindowReport(k, 0, 1, True, np.zeros(0), (o,)) for k, o in enumerate(objs)]
    summed = bench.rescore(reports, 1.0)
    assert summed[0].objects[0].track_score == pytest.approx(bench.logit(0.9) - 1)
    assert summed[1].objects[0].track_score == pytest.approx(
        bench.logit(0.9) + bench.logit(0.2) - 2
    )
    assert summed[2].objects[0].track_score is None  # no track
    mean = bench.rescore(reports, None)
    assert mean[1].objects[0].track_score == pytest.approx(0.55)
    with pytest.raises(AssertionError, match="running mean"):
        bench.rescore([WindowReport(0, 0, 1, True, np.zeros(0), (_obj(0.9, 1, True, 0.5),))], None)
    # The bench's thresholds: track_alarm_threshold without a floor.
    assert track_alarm_threshold([3.0, -2.0], 1.0, 1.0, floor=-np.inf) == np.nextafter(-2.0, np.inf)
    assert track_alarm_threshold([3.0, -2.0], 1.0, 2.0, floor=-np.inf) == -np.inf

    model, root = _tiny_run(tmp_path, n_train=0)
    out = tmp_path / "rows.json"
    argv = ["track_evidence.py", str(model), str(root), "--minutes", "0.05", "--drifts", "0"]
    monkeypatch.setattr("sys.argv", [*argv, "--rates", "1,1000", "--json", str(out)])
    bench.main()
    rows = json.loads(out.read_text())
    assert [(r["drift"], r["rate"]) for r in rows] == [(None, 1), (None, 1000), (0, 1), (0, 1000)]
    for low, high in ((rows[0], rows[1]), (rows[2], rows[3])):
        assert high["threshold"] == -np.inf and low["threshold"] > -np.inf
        assert high["free_false_tracks"] >= low["free_false_tracks"] >= 0
        assert (
            high["uav_found"] >= low["uav_found"] and high["other_alarmed"] >= low["other_alarmed"]
        )
    # At a rate above their count every confirmed, scored track alarms, whatever the statistic.
    assert rows[1]["free_false_tracks"] == rows[3]["free_false_tracks"] > 0
    assert "| running mean | 1 |" in capsys.readouterr().out
    # --split picks the recordings streamed: this set's train split holds none.
    from uavsnn.errors import UavsnnError

    net = Network.load(model)
    assert len(bench.test_streams(net, root, "test")) == len(clip_set(root, "test").clips)
    with pytest.raises(UavsnnError):
        bench.test_streams(net, root, "train")


def test_the_track_window_score_bench_reads_each_track_in_time_order(
    tmp_path: Path, bench_script, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    """benches/python/track_window_score.py: each object reads its own track's scores up to its
    window, in time order, tracks of one id in two recordings apart; an object without a track
    keeps its score; a window the any-spike rule misses never alarms; and a tiny run gives
    every rule's figures, the object's own score first."""
    import json

    from uavsnn.features import FEATURES, WindowFeatures

    bench = bench_script("track_window_score")
    # Windows 0-2 of recording 0 (given out of time order), 3-4 of recording 1; track 1 in
    # both recordings, object 5 without a track.
    recording = np.array([0, 0, 0, 1, 1])
    t0 = np.array([50, 0, 25, 0, 25])
    feats = WindowFeatures(
        x=np.zeros((6, len(FEATURES))),
        window=np.array([0, 1, 2, 3, 4, 4]),
        boxes=np.zeros((6, 4), dtype=np.int64),
        windows=5,
        track=np.array([1, 1, 1, 1, 1, 0]),
    )
    s = np.array([0.9, 0.1, 0.5, 0.8, 0.2, 0.7])
    # Recording 0's track in time order: 0.1 (window 1), 0.5 (window 2), 0.9 (window 0).
    mean = bench.track_scores(feats, recording, t0, s, "mean")
    assert mean == pytest.approx([0.5, 0.1, 0.3, 0.8, 0.5, 0.7])
    last = bench.track_scores(feats, recording, t0, s, "last3")
    assert last == pytest.approx(mean)  # no track is longer than 3
    assert bench.track_scores(feats, recording, t0, s, "own") == pytest.approx(s)
    logit = bench.track_scores(feats, recording, t0, s, "logit")
    # Recording 0: logit(0.1) and logit(0.5) = 0 average to logit(0.25); with logit(0.9) to 0.
    assert logit[2] == pytest.approx(0.25) and logit[0] == pytest.approx(0.5) and logit[5] == 0.7
    assert logit[4] == pytest.approx(0.5)  # logit(0.8) + logit(0.2) = 0
    longer = WindowFeatures(
        x=np.zeros((4, len(FEATURES))), window=np.arange(4), boxes=np.zeros((4, 4), np.int64),
        windows=4, track=np.full(4, 2),
    )  # fmt: skip
    four = np.array([0.1, 0.2, 0.3, 0.9])
    got = bench.track_scores(longer, np.zeros(4, int), np.arange(4) * 25, four, "last3")
    assert got == pytest.approx([0.1, 0.15, 0.2, (0.2 + 0.3 + 0.9) / 3])
    with pytest.raises(ValueError):
        bench.track_scores(feats, recording, t0, s, "median")
    fired = np.array([True, True, False, True, True])
    assert bench.window_scores(feats, mean, fired) == pytest.approx([0.5, 0.1, -1.0, 0.8, 0.7])

    model, root = _tiny_run(tmp_path, n_train=12)
    out = tmp_path / "rows.json"
    argv = ["track_window_score.py", str(model), str(root), "--tune", str(root), "--json", str(out)]
    monkeypatch.setattr("sys.argv", argv)
    bench.main()
    figures = json.loads(out.read_text())
    assert list(figures) == list(bench.RULES)
    for rule in figures.values():
        for part in ("tune", "measured"):
            assert set(rule[part]["detection"]) == {"0.01", "0.05"}
            assert all(0 <= v <= 1 for v in rule[part]["detection"].values())
        for point in rule["set_beforehand"].values():
            assert 0 <= point["false_alarms"] <= 1 and point["threshold"] >= 0
    assert capsys.readouterr().out.splitlines()[2].startswith("| own |")


def test_the_size_table_bench_reads_each_cell_from_evaluates_json(
    tmp_path: Path, bench_script, capsys
) -> None:
    """benches/python/size_table.py: each cell is the figure of `uavsnn evaluate --tracks
    --json` it names, one column per file; a file without identification is refused."""
    import json

    from uavsnn.cli import main

    bench = bench_script("size_table")
    model, root = _tiny_run(tmp_path, n_train=0)
    assert main(["evaluate", str(model), str(root), "--tracks", "--json"]) == 0
    out = tmp_path / "eval.json"
    out.write_text(capsys.readouterr().out)
    f = json.loads(out.read_text())
    ident = f["identification"]
    bench.main([f"a={out}", f"b={out}"])
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "| | a | b |"
    rows = [line.removeprefix("| ").removesuffix(" |").split(" | ") for line in lines[2:]]
    cells = {name: rest for name, *rest in rows}
    assert len(cells) == len(lines) - 2 and all(len(c) == 2 for c in cells.values())
    assert cells["any-spike rule"][0] == f"{100 * f['accuracy']:.1f} %"
    assert cells["with identification"][0] == f"{100 * ident['identified']['accuracy']:.1f} %"
    at1 = ident["at_false_alarm"][0]
    assert at1["false_alarm_target"] == 0.01
    row = "detection at 1 % false alarms (test ROC)"
    assert cells[row][0] == f"{100 * at1['detection_rate']:.1f} %"
    drones = f["per_class"]["drone"]
    assert cells["drones called UAV (any-spike)"][0] == (
        f"{100 * drones['called_uav_rate']:.1f} % of {drones['windows']}"
    )
    assert cells["drones called UAV with identification"] == 2 * [
        f"{100 * ident['identified']['per_class']['drone']:.1f} %"
    ]
    rule = f["tracks"]["rules"]["any_spike"]
    found = f"{rule['found']} of {f['tracks']['uav_recordings']}; "
    assert cells["tracks, any-spike: UAV recordings found; false tracks per minute"][1] == (
        found + f"{rule['false_tracks_per_minute']:.1f}"
    )
    bare = tmp_path / "bare.json"
    bare.write_text(json.dumps({k: v for k, v in f.items() if k != "identification"}))
    with pytest.raises(SystemExit):
        bench.main([f"a={bare}"])
    with pytest.raises(SystemExit):
        bench.main([str(out)])


def test_the_missed_drones_bench_counts_each_bin_and_matches_evaluate(
    tmp_path: Path, bench_script, capsys
) -> None:
    """benches/python/missed_drones.py: a window's rotor is any of its objects'; the bins count
    each UAV window once, an unknown speed apart; on a tiny run its totals are the detection
    `uavsnn evaluate` reads off the same ROC."""
    import json

    from uavsnn.cli import main

    bench = bench_script("missed_drones")
    rotor = bench.window_rotor(np.array([0.0, 1.0, 0.0, 0.0]), np.array([0, 0, 2, 3]), 5)
    assert rotor.tolist() == [True, False, False, False, False]
    light = np.array([0.05, 0.05, 0.5, 0.5, 0.2])
    speed = np.array([10.0, np.nan, 150.0, 150.0, 50.0])
    hit = np.array([True, True, False, True, True])
    rows = bench.bin_rows(light, speed, {"hit": hit})
    assert [(r["light"], r["speed"], r["windows"], r["hit"]) for r in rows] == [
        ("0–0.1", "0–20", 1, 1),
        ("0–0.1", "unknown", 1, 1),
        ("0.1–0.3", "20–100", 1, 1),
        ("0.3–1", "100–inf", 2, 1),
    ]
    model, root = _tiny_run(tmp_path, n_train=0)
    assert main(["evaluate", str(model), str(root), "--json"]) == 0
    ident = json.loads(capsys.readouterr().out)["identification"]
    bench.main([str(model), str(root)])
    out = capsys.readouterr().out
    total = next(line for line in out.splitlines() if line.startswith("| all |"))
    windows, any_spike, at1, at5, _ = (int(c) for c in total.strip("| ").split(" | ")[2:])
    (tp, fn), _ = ident["any_spike"]["confusion"]
    assert (windows, any_spike) == (tp + fn, tp)
    for count, point in zip((at1, at5), ident["at_false_alarm"], strict=True):
        assert count == round(point["detection_rate"] * windows)
    assert windows > 0 and any_spike > 0 and "UAV-free recordings alarming" in out


def test_the_recordings_are_made_through_the_lens_they_are_given() -> None:
    """A lens focused at 5 cm blurs every object of the UAV-free scenes: a scene with an object
    gives other events than through a pinhole, an empty scene the same; the pinhole is the
    default."""
    from uavsnn.false_alarms import scene_reports
    from uavsnn.scenes import Lens

    net = Network(seed=0)
    scenes = uav_free_scenes(3, 3)
    pinhole = list(scene_reports(net, scenes))
    lensed = list(scene_reports(net, scenes, lens=Lens(0.5, 0.05)))
    assert [lr.recording.events.tobytes() for lr, _ in scene_reports(net, scenes, lens=None)] == [
        lr.recording.events.tobytes() for lr, _ in pinhole
    ]
    with_object = 0
    for (a, _), (b, _) in zip(pinhole, lensed, strict=True):
        assert a.info["objects"] == b.info["objects"], "the same scenes"
        same = np.array_equal(a.recording.events, b.recording.events)
        assert same == (not a.info["objects"]), a.info["objects"]
        with_object += bool(a.info["objects"])
    assert with_object >= 1
