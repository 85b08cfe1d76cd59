"""Track-level evaluation (uavsnn.track_eval): recordings found, time to first alarm, false
tracks per minute of UAV-free recording, on hand-made windows where the answer is known, and
on a tiny built dataset through `uavsnn evaluate --tracks`."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from uavsnn import Network
from uavsnn.dataset import LabelledWindows
from uavsnn.errors import ParameterError, ShapeError
from uavsnn.grouping import _NO_DETECTIONS, WindowObject, WindowReport
from uavsnn.identify import FEATURES, WindowFeatures, window_steps
from uavsnn.track_eval import (
    Confirm,
    confirm_flags,
    first_uav_starts,
    ms_text,
    poisson_upper,
    recording_names,
    track_figures,
    track_table,
)
from uavsnn.tracks import Tracker
from uavsnn.windows import Windows

STEP, L = 25_000, 50_000  # µs: 50 ms windows every 25 ms, as the datasets cut them
SIZE = (240, 180)
UAV_BOX = (100.0, 80.0, 110.0, 90.0)


def labelled(rows: list[tuple[int, int, bool, str]], manifest: bool = True) -> LabelledWindows:
    """Windows from ``(recording, k, uav, cls)`` rows: window ``k`` of a recording starts at
    ``1 s + k * STEP``; a UAV window's labelled box is :data:`UAV_BOX`. The manifest gives the
    step, as a built dataset's does (``manifest=False``: none)."""
    n = len(rows)
    rec = np.array([r[0] for r in rows], dtype=np.int64)
    t0 = np.array([1_000_000 + r[1] * STEP for r in rows], dtype=np.uint64)
    label = np.array([r[2] for r in rows], dtype=bool)
    cls = np.array([r[3] for r in rows])
    box = np.where(label[:, None], np.array(UAV_BOX), np.nan).astype(np.float32)
    windows = Windows(SIZE, L, t0, np.zeros(n + 1, np.int64), [], [], [], np.zeros(n, np.int64))
    info = {"parameters": {"step_us": STEP}} if manifest else {}
    return LabelledWindows(windows, label, cls, rec, box, info)


def tracked(data: LabelledWindows, objects: dict[int, list[tuple[int, int, int, int]]]):
    """The objects (boxes per window index of ``data``) linked by a default :class:`Tracker`,
    recording by recording in time order, as ``identify.window_features`` links them."""
    order, step = window_steps(data)
    tracker, current = Tracker(), None
    out: dict[int, list] = {}
    t0s = np.asarray(data.windows.t0, dtype=np.int64)
    for i in order.tolist():
        if data.recording[i] != current:
            current, first = data.recording[i], int(t0s[i])
            tracker.reset()
        boxes = objects.get(i, [])
        rep = tracker.update(
            WindowReport(
                window=(int(t0s[i]) - first) // step,
                t0=int(t0s[i]),
                t1=int(t0s[i]) + L,
                detected=bool(boxes),
                detections=_NO_DETECTIONS,
                objects=tuple(WindowObject(box=b, spikes=1) for b in boxes),
            )
        )
        out[i] = [(o.box, o.track_id or 0, bool(o.track_confirmed)) for o in rep.objects]
    rows = [(i, *o) for i in sorted(out) for o in out[i]]
    m = len(rows)
    return WindowFeatures(
        x=np.zeros((m, len(FEATURES))),
        window=np.array([r[0] for r in rows], dtype=np.int64),
        boxes=np.array([r[1] for r in rows], dtype=np.int64).reshape(-1, 4),
        windows=len(data),
        track=np.array([r[2] for r in rows], dtype=np.int64),
        confirmed=np.array([r[3] for r in rows], dtype=bool),
    )


def on_uav(k: int) -> tuple[int, int, int, int]:
    return (100 + k % 2, 80, 108 + k % 2, 88)


def bird(k: int) -> tuple[int, int, int, int]:
    return (20 + 3 * k, 40, 26 + 3 * k, 46)


def scene() -> tuple[LabelledWindows, dict[int, list]]:
    """Recording 0: 20 windows, the UAV labelled from window 4 on and detected in each of them.
    Recording 1: 20 UAV-free windows, a bird detected in windows 2..10. Recording 2: a UAV
    labelled in 10 windows, never detected."""
    rows = [(0, k, k >= 4, "drone" if k >= 4 else "none") for k in range(20)]
    rows += [(1, k, False, "bird" if 2 <= k <= 10 else "none") for k in range(20)]
    rows += [(2, k, True, "drone") for k in range(10)]
    objects = {k: [on_uav(k)] for k in range(4, 20)}
    objects |= {20 + k: [bird(k)] for k in range(2, 11)}
    return labelled(rows), objects


def test_a_found_uav_a_false_bird_track_and_a_missed_uav() -> None:
    data, objects = scene()
    f = track_figures(data, tracked(data, objects))
    assert (f["recordings"], f["uav_recordings"], f["windows"]) == (3, 2, 50)
    assert f["step_us"] == STEP and f["window_coverage"] == 1.0
    rule = f["rules"]["any_spike"]
    assert "identified" not in f["rules"]
    # Confirmed at its third hit, window 6: it ends at 6 * 25 + 50 = 200 ms, 100 ms after the
    # first UAV window starts (window 4, 100 ms).
    assert rule["found"] == 1 and rule["missed"] == [2] and rule["found_rate"] == 0.5
    assert rule["time_to_alarm_ms"] == {"n": 1, "median": 100.0, "p90": 100.0, "max": 100.0}
    # The bird's track is confirmed in window 4 of recording 1: one false track.
    assert rule["false_tracks"] == 1 and rule["false_tracks_per_class"] == {"bird": 1}
    assert rule["stray_tracks"] == 0 and rule["alarming_tracks"] == 2
    # UAV-free: windows 0-3 of recording 0 (0 to 125 ms) and all of recording 1 (525 ms).
    minutes = (125 + 525) / 60_000
    assert f["uav_free_minutes"] == pytest.approx(minutes)
    assert rule["false_tracks_per_minute"] == pytest.approx(1 / minutes)
    assert rule["false_tracks_per_minute_upper95"] == pytest.approx(4.7439 / minutes, rel=1e-4)
    per = {r["recording"]: r for r in f["per_recording"]}
    assert per[0]["any_spike"] == {"found": True, "time_to_alarm_ms": 100.0, "false_tracks": 0}
    assert per[1]["any_spike"] == {"found": None, "time_to_alarm_ms": None, "false_tracks": 1}
    assert per[2]["any_spike"]["found"] is False
    assert per[1]["uav_free_ms"] == 525.0 and per[0]["uav_windows"] == 16
    assert (per[0]["uav_windows_met"], per[2]["uav_windows_met"]) == (16, 0)
    assert per[0]["uav_size_px"] is None  # no sizes labelled here
    # Decided UAV: recording 0 (right) and 1, the bird's (wrong); recording 2 not (wrong).
    assert rule["decided"] == {
        "right": 1, "accuracy": 1 / 3, "uav_alarmed": 1, "other_quiet": 0,
        "balanced_accuracy": 0.25,
        "per_class": {
            "bird": {"recordings": 1, "decided_uav": 1},
            "drone": {"recordings": 2, "decided_uav": 1},
        },
    }  # fmt: skip
    table = track_table(f)
    assert "| any-spike | 1 of 2 | 100 / 100 | 1 |" in table and "identification" not in table
    # "N of M (x %)" is N/M; the balanced accuracy has a column of its own.
    assert "| 1 of 3 (33.3 %) | 25.0 % |" in table and "| balanced accuracy |" in table
    # The clock of the time to first alarm is named: from the first UAV window, where the UAV
    # is labelled visible for half the window, not from its first event.
    assert "time to first alarm from the first UAV window" in table
    assert "does not start at the UAV's first event" in table
    # A manifest without recordings[] names none.
    assert [r["name"] for r in f["per_recording"]] == [None, None, None]


def test_each_recording_is_named_as_the_manifest_names_it() -> None:
    """Each recording's row carries its name in the manifest's recordings[] (None where the
    manifest does not name it), so that a missed recording can be named as `evaluate --clips`
    names it, not by its id."""
    data, objects = scene()
    entries = [
        {"id": 0, "name": "V_DRONE_001"},
        {"id": 1, "name": "V_BIRD_002"},
        {"id": 2, "name": "V_DRONE_026"},
        {"id": 3, "name": "V_AIRPLANE_005"},  # a recording of another split
        {"id": "4", "name": "odd"},  # not an id
    ]
    named = replace(data, manifest=data.manifest | {"recordings": entries})
    assert recording_names(named) == {
        0: "V_DRONE_001",
        1: "V_BIRD_002",
        2: "V_DRONE_026",
        3: "V_AIRPLANE_005",
    }
    f = track_figures(named, tracked(named, objects))
    rows = {r["recording"]: r for r in f["per_recording"]}
    assert f["rules"]["any_spike"]["missed"] == [2] and rows[2]["name"] == "V_DRONE_026"
    assert [r["name"] for r in f["per_recording"]] == ["V_DRONE_001", "V_BIRD_002", "V_DRONE_026"]
    partial = replace(data, manifest=data.manifest | {"recordings": entries[:1]})
    rows = track_figures(partial, tracked(partial, objects))["per_recording"]
    assert [r["name"] for r in rows] == ["V_DRONE_001", None, None]


def test_ms_text_keeps_a_half_step_and_drops_a_whole_one() -> None:
    # a median between two 25 ms steps is a half: printed as it is, never rounded to even
    assert ms_text(137.5) == "137.5" and ms_text(612.5) == "612.5"
    assert ms_text(100.0) == "100" and ms_text(555.0000000000001) == "555"
    assert ms_text(6530.0) == "6,530" and ms_text(None) == "–"


def test_identification_alarms_on_the_running_mean_of_the_track_scores() -> None:
    data, objects = scene()
    feats = tracked(data, objects)
    on = np.isin(feats.window, np.arange(20))  # recording 0's objects: the UAV
    # The UAV's first three objects score low, then high: the running mean reaches 0.5 at its
    # sixth object (0.3 + 3 * 0.9 = 3.0 over 6), window 9, which ends at 275 ms.
    uav_scores = np.where(np.arange(on.sum()) < 3, 0.1, 0.9)
    # The bird's first object scores high and the others low: the largest score would pass,
    # the mean at confirmation (0.9 + 0.1 + 0.1) / 3 does not, nor ever after.
    bird_scores = np.where(np.arange((~on).sum()) < 1, 0.9, 0.1)
    scores = np.empty(len(feats.window))
    scores[on], scores[~on] = uav_scores, bird_scores
    f = track_figures(data, feats, scores, 0.5)
    ident, spike = f["rules"]["identified"], f["rules"]["any_spike"]
    assert ident["found"] == 1 and ident["time_to_alarm_ms"]["median"] == 175.0
    assert ident["false_tracks"] == 0 and ident["false_tracks_per_minute"] == 0.0
    assert ident["false_tracks_per_minute_upper95"] == pytest.approx(
        poisson_upper(0) / f["uav_free_minutes"]
    )
    assert spike["false_tracks"] == 1 and spike["time_to_alarm_ms"]["median"] == 100.0
    assert "| any-spike + identification | 1 of 2 | 175 / 175 | 0 |" in track_table(f)
    # The running max instead: the UAV alarms at confirmation (its first score 0.1 < 0.5, its
    # fourth 0.9), window 7, 175 -> 125 ms; the bird's first 0.9 makes its track a false one.
    g = track_figures(data, feats, scores, 0.5, track_score="max")
    assert g["rules"]["identified"]["time_to_alarm_ms"]["median"] == 125.0
    assert g["rules"]["identified"]["false_tracks"] == 1
    with pytest.raises(ParameterError, match="track_score"):
        track_figures(data, feats, scores, 0.5, track_score="median")


def test_tracks_at_the_operating_points_set_beforehand() -> None:
    """identified_track_figures adds the identified rule at each of the identifier's
    operating points, each as track_figures gives it at that threshold, named in the table."""
    from uavsnn.identify import Identifier
    from uavsnn.track_eval import identified_track_figures, rule_name

    data, objects = scene()
    feats = tracked(data, objects)
    on = np.isin(feats.window, np.arange(20))
    # One feature carries the scores: logit 2 (0.88) on the UAV, -1 (0.27) on the bird.
    x = np.zeros((len(feats.window), len(FEATURES)))
    x[:, 0] = np.where(on, 2.0, -1.0)
    feats = replace(feats, x=x)
    ident = Identifier(
        (FEATURES[0],), np.array([1.0, 0.0]), np.zeros(1), np.ones(1), 0.5, 1.0,
        alarm_thresholds=((0.01, 0.95), (0.05, 0.2)),
    )  # fmt: skip
    f = identified_track_figures(data, feats, ident)
    assert list(f["rules"]) == [
        "any_spike",
        "identified",
        "identified_at_0.01",
        "identified_at_0.05",
    ]
    scores = ident.scores(feats.x)
    for rule, threshold in (("identified_at_0.01", 0.95), ("identified_at_0.05", 0.2)):
        alone = track_figures(data, feats, scores, threshold)["rules"]["identified"]
        assert f["rules"][rule] == alone
    # 0.95: no track alarms; 0.2: the bird's track alarms as the any-spike rule's does.
    assert f["rules"]["identified_at_0.01"]["found"] == 0
    assert f["rules"]["identified_at_0.05"] == f["rules"]["any_spike"]
    assert rule_name("identified_at_0.01") == "+ identification, set for 1 % false alarms"
    assert "| + identification, set for 5 % false alarms | 1 of 2 |" in track_table(f)
    # Track points: reported where they were set with the rule in force (3 of 5 here).
    tracks = replace(ident, track_alarm_thresholds=((0.1, 0.95),), track_alarm_minutes=10.0)
    f = identified_track_figures(data, feats, tracks)
    assert f["rules"]["identified_tracks_at_0.1"] == f["rules"]["identified_at_0.01"]
    assert rule_name("identified_tracks_at_0.1") == (
        "+ identification, set for 0.1 false tracks per minute"
    )
    assert rule_name("identified_tracks_at_1").endswith("set for 1 false track per minute")
    other = replace(tracks, track_alarm_confirm=(2, 5))
    assert "identified_tracks_at_0.1" not in identified_track_figures(data, feats, other)["rules"]
    with_rule = identified_track_figures(data, feats, other, confirm=Confirm(2, 5))
    assert "identified_tracks_at_0.1" in with_rule["rules"]


def test_left_out_windows_count_as_misses() -> None:
    """Every third window of a UAV recording in the dataset: the UAV is detected in each, but
    3 hits in 5 windows never happen, so no track is confirmed and the UAV is missed; every
    other window: confirmed at window 4 (hits at 0, 2, 4), alarm at 150 ms."""
    for keep, found, delay in ((3, 0, None), (2, 1, 150.0)):
        ks = list(range(0, 20, keep))
        data = labelled([(0, k, True, "drone") for k in ks])
        f = track_figures(data, tracked(data, {i: [on_uav(k)] for i, k in enumerate(ks)}))
        assert f["window_coverage"] == pytest.approx(len(ks) / (ks[-1] + 1))
        assert f["rules"]["any_spike"]["found"] == found
        assert f["rules"]["any_spike"]["time_to_alarm_ms"]["median"] == delay
        # Without the manifest's step, the step is the gaps' greatest common divisor.
        bare = labelled([(0, k, True, "drone") for k in ks], manifest=False)
        assert window_steps(bare)[1] == keep * STEP


def test_the_first_alarm_runs_from_the_recordings_first_uav_window() -> None:
    """The split left out windows 4 and 5 of a recording whose UAV is labelled from window 4
    on, and detected in every window kept: confirmed at window 8 (hits at 6, 7, 8), the alarm
    at 250 ms. Where the manifest gives the recording's first UAV window (window 4, 100 ms),
    the clock runs from it: 150 ms; where it does not, from the first kept (window 6): 100 ms,
    and the figures and the table say so."""
    ks = [k for k in range(20) if k not in (4, 5)]
    bare = labelled([(0, k, k >= 4, "drone" if k >= 4 else "none") for k in ks])
    objects = {i: [on_uav(k)] for i, k in enumerate(ks) if k >= 6}
    f = track_figures(bare, tracked(bare, objects))
    assert f["alarm_clock"] == "kept windows"
    assert f["rules"]["any_spike"]["time_to_alarm_ms"]["median"] == 100.0
    assert "the first UAV window the split kept" in track_table(f)
    entry = {"id": 0, "first_uav_us": 1_000_000 + 4 * STEP}
    built = replace(bare, manifest=bare.manifest | {"recordings": [entry]})
    f = track_figures(built, tracked(built, objects))
    assert f["alarm_clock"] == "recording"
    assert f["rules"]["any_spike"]["time_to_alarm_ms"]["median"] == 150.0
    assert "from each recording's first UAV window" in track_table(f)
    # A manifest that says a later start than a kept UAV window cannot push the clock past it.
    late = replace(bare, manifest=bare.manifest | {"recordings": [entry | {"first_uav_us": 2**40}]})
    assert first_uav_starts(late) == ({0: 1_000_000 + 6 * STEP}, True)
    # A manifest whose entries are not what a build writes is not read: the kept windows' clock.
    for bad in (5, [3, {"id": "0", "first_uav_us": 0}], [{"id": True, "first_uav_us": 0}]):
        odd = replace(bare, manifest=bare.manifest | {"recordings": bad})
        assert first_uav_starts(odd) == ({0: 1_000_000 + 6 * STEP}, False)


def test_a_track_beside_the_uav_is_stray_not_found() -> None:
    data = labelled([(0, k, True, "drone") for k in range(10)])
    f = track_figures(data, tracked(data, {k: [bird(k)] for k in range(10)}))
    rule = f["rules"]["any_spike"]
    assert rule["found"] == 0 and rule["stray_tracks"] == 1 and rule["false_tracks"] == 0
    assert f["uav_free_minutes"] == 0 and rule["false_tracks_per_minute"] is None


def test_the_earliest_of_two_tracks_on_the_uav_counts() -> None:
    """Two tracks on the UAV in recording 0, the second confirmed later: the first alarm
    counts; a recording's windows given in any order give the same figures."""
    data = labelled([(0, k, True, "drone") for k in range(12)])
    # Two still boxes 14 px apart, each meeting the UAV's box: one from window 2, one from 0.
    objects = {k: [(96, 76, 104, 84)] for k in range(2, 12)}
    for k in range(0, 12):
        objects.setdefault(k, []).append((106, 86, 114, 94))
    f = track_figures(data, tracked(data, objects))
    rule = f["rules"]["any_spike"]
    assert rule["alarming_tracks"] == 2 and rule["stray_tracks"] == 0
    assert rule["time_to_alarm_ms"]["median"] == 100.0  # the second box's window 2 ends
    perm = np.random.default_rng(0).permutation(len(data))
    shuffled = data.select(perm)
    back = {int(p): i for i, p in enumerate(perm)}
    g = track_figures(shuffled, tracked(shuffled, {back[k]: boxes for k, boxes in objects.items()}))
    assert g["rules"] == f["rules"]


def test_the_tracker_rule_applied_again_gives_the_trackers_flags() -> None:
    """Confirmation is a function of a track's hit windows: a Tracker with a rule and
    confirm_flags on the same track's hits agree, hit by hit, for random hit patterns (a
    still object, so that every hit joins the one track)."""
    rng = np.random.default_rng(7)
    for hits, windows in ((3, 5), (2, 3), (2, 2), (4, 5), (1, 1), (5, 8)):
        for _ in range(20):
            seen = np.flatnonzero(rng.random(40) < rng.uniform(0.2, 0.8))
            tracker = Tracker(confirm_hits=hits, confirm_windows=windows, max_misses=64)
            flags = []
            for k in seen.tolist():
                (obj,) = tracker.update(
                    WindowReport(
                        k,
                        k * STEP,
                        k * STEP + L,
                        True,
                        _NO_DETECTIONS,
                        (WindowObject(box=on_uav(0), spikes=1),),
                    )
                ).objects
                assert obj.track_id == 1
                flags.append(bool(obj.track_confirmed))
            assert confirm_flags(seen, Confirm(hits, windows)).tolist() == flags


def test_the_figures_under_other_confirmation_rules() -> None:
    """The scene's UAV is detected in every window from window 4 (100 ms): confirmed at its
    k-th hit, its alarm is at the end of window 3 + k, (k - 1) * 25 + 50 ms after 100 ms."""
    data, objects = scene()
    feats = tracked(data, objects)
    default = track_figures(data, feats)
    again = track_figures(data, feats, confirm=Confirm(3, 5))
    assert again["rules"] == default["rules"] and again["confirm"] == "3/5"
    # The tracker's own flags are recorded as its default rule, not as None.
    assert default["confirm"] == "3/5"
    for text, delay in (("2/3", 75.0), ("2/2", 75.0), ("4/5", 125.0), ("1/1", 50.0)):
        f = track_figures(data, feats, confirm=Confirm.parse(text))
        assert f["rules"]["any_spike"]["time_to_alarm_ms"]["median"] == delay, text
        assert f["confirm"] == text
    with pytest.raises(ParameterError, match="Confirm"):
        track_figures(data, feats, confirm=(2, 3))  # type: ignore[arg-type]


def test_the_score_aware_rule_confirms_a_confident_track_early() -> None:
    """Recording 0: the UAV in every window from window 4, scoring 0.9; recording 1: a bird in
    windows 2 and 3 only, scoring 0.1 (threshold 0.5). 2 of 3 alarms on the UAV 25 ms earlier
    than 3 of 5 and confirms the bird (a false track); 2/3+3/5 confirms the UAV at 2 of 3 (its
    running mean is 0.9) and holds the bird to 3 of 5, which it never reaches."""
    rows = [(0, k, k >= 4, "drone" if k >= 4 else "none") for k in range(20)]
    rows += [(1, k, False, "bird" if k in (2, 3) else "none") for k in range(20)]
    data = labelled(rows)
    feats = tracked(data, {k: [on_uav(k)] for k in range(4, 20)} | {22: [bird(2)], 23: [bird(3)]})
    scores = np.where(feats.window < 20, 0.9, 0.1)
    want = {"3/5": (100.0, 0), "2/3": (75.0, 1), "2/3+3/5": (75.0, 0)}
    for text, (delay, false) in want.items():
        f = track_figures(data, feats, scores, 0.5, confirm=Confirm.parse(text))
        rule = f["rules"]["any_spike"]
        assert (rule["time_to_alarm_ms"]["median"], rule["false_tracks"]) == (delay, false), text
        ident = f["rules"]["identified"]
        assert (ident["time_to_alarm_ms"]["median"], ident["false_tracks"]) == (delay, 0), text
    # A confident bird: the score-aware rule confirms it at 2 of 3 as well.
    bold = track_figures(data, feats, np.full(len(scores), 0.9), 0.5, confirm=Confirm.parse(
        "2/3+3/5"))  # fmt: skip
    assert bold["rules"]["any_spike"]["false_tracks"] == 1
    # Without scores the score-aware part never fires: 3 of 5.
    plain = track_figures(data, feats, confirm=Confirm.parse("2/3+3/5"))
    assert plain["rules"] == track_figures(data, feats, confirm=Confirm(3, 5))["rules"]


@pytest.mark.parametrize(
    "text", ["3", "3/", "0/5", "6/5", "3/65", "a/b", "-1/3", "2/3+3/5+1/1", "2/3+", ""]
)
def test_bad_confirmation_rules_are_parameter_errors(text: str) -> None:
    with pytest.raises(ParameterError, match="confirmation rule"):
        Confirm.parse(text)


def test_confirmation_rules_read_and_print() -> None:
    assert Confirm.parse(" 2/3 ") == Confirm(2, 3) and str(Confirm(2, 3)) == "2/3"
    rule = Confirm.parse("2/2+3/5")
    assert rule == Confirm(3, 5, fast=(2, 2)) and str(rule) == "2/2+3/5"
    for bad in ((True, 5), (2.0, 3), (3, 5, (4, 3))):
        with pytest.raises(ParameterError, match=r"confirmation rule|integers"):
            Confirm(*bad)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="increase"):
        confirm_flags([0, 2, 2], Confirm(2, 3))
    with pytest.raises(ParameterError, match="both"):
        confirm_flags([0, 1], Confirm(2, 3, fast=(1, 1)), np.ones(2))


def test_poisson_upper_bounds() -> None:
    # The one-sided 95 % bounds: chi-square(0.95, 2k + 2) / 2.
    for k, bound in ((0, 2.9957), (1, 4.7439), (2, 6.2958), (5, 10.5130), (20, 29.0620)):
        assert poisson_upper(k) == pytest.approx(bound, abs=1e-3)
    assert poisson_upper(0, 0.9) == pytest.approx(2.3026, abs=1e-3)
    # Many events: the bound lies above the count (once, from ~700 events, the sum's first
    # term underflowed and the bound fell to ~745 whatever the count). Wilson-Hilferty's
    # chi-square gives the reference within 0.1.
    for k in (700, 1902, 5000):
        z, dof = 1.6448536, 2 * k + 2
        reference = dof * (1 - 2 / (9 * dof) + z * math.sqrt(2 / (9 * dof))) ** 3 / 2
        assert poisson_upper(k) == pytest.approx(reference, abs=0.1)
    for bad in (-1, 1.5, True):
        with pytest.raises(ParameterError):
            poisson_upper(bad)  # type: ignore[arg-type]
    with pytest.raises(ParameterError):
        poisson_upper(1, 1.0)


def test_bad_inputs_are_typed_errors() -> None:
    data, objects = scene()
    feats = tracked(data, objects)
    with pytest.raises(ParameterError, match="both scores and threshold"):
        track_figures(data, feats, np.zeros(len(feats.window)))
    with pytest.raises(ShapeError):
        track_figures(data, feats, np.zeros(3), 0.5)
    with pytest.raises(ShapeError, match="windows"):
        track_figures(data.select(np.arange(10)), feats)
    bare = WindowFeatures(feats.x, feats.window, feats.boxes, feats.windows)
    with pytest.raises(ShapeError, match="no tracks"):
        track_figures(data, bare)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A tiny dvs dataset (24 test windows) and an untrained 240x180 model."""
    from uavsnn.dataset import SceneSource, build

    tmp = tmp_path_factory.mktemp("tiny")
    root = build(
        tmp / "set", "dvs", n_test=24, n_train=0, seed=5,
        dvs=SceneSource("dvs", (240, 180), 200.0, 0.4),
    ).root  # fmt: skip
    model = tmp / "m.npz"
    Network({"width": 240, "height": 180, "conv2": {"threshold": 10.0}}, seed=0).save(model)
    return root, model


def test_evaluate_tracks_on_a_tiny_built_dataset(
    tiny: tuple[Path, Path], capsys: pytest.CaptureFixture[str], bench_script
) -> None:
    from uavsnn.cli import main
    from uavsnn.dataset import load

    root, model = tiny
    assert main(["evaluate", str(model), str(root), "--tracks", "--json"]) == 0
    tracks = json.loads(capsys.readouterr().out)["tracks"]
    test = load(root, "test")
    recordings = np.unique(test.recording)
    assert tracks["windows"] == 24 and tracks["recordings"] == len(recordings)
    uav_recs = {int(r) for r in recordings if test.label[test.recording == r].any()}
    assert tracks["uav_recordings"] == len(uav_recs)
    assert sum(r["windows"] for r in tracks["per_recording"]) == 24
    assert list(tracks["rules"]) == ["any_spike"]  # no identification in this model
    rule = tracks["rules"]["any_spike"]
    assert rule["found"] + len(rule["missed"]) == len(uav_recs)
    assert set(rule["missed"]) <= uav_recs
    # A UAV-free recording is decided right when none of its tracks alarmed.
    quiet = [r for r in tracks["per_recording"] if r["any_spike"]["found"] is None]
    assert rule["decided"]["other_quiet"] == sum(r["any_spike"]["false_tracks"] == 0 for r in quiet)
    assert rule["decided"]["uav_alarmed"] >= rule["found"]
    # The UAV-free time lies between the UAV-free windows' steps and their lengths.
    free = int((~test.label).sum())
    assert free * STEP <= 60e6 * tracks["uav_free_minutes"] <= free * L
    # The text output says the same.
    assert main(["evaluate", str(model), str(root), "--tracks"]) == 0
    text = capsys.readouterr().out
    assert (
        f"tracks (confirmed at 3/5): {len(recordings)} recordings ({len(uav_recs)} with a UAV)"
        in text
    )
    assert f"UAV recordings found {rule['found']}/{len(uav_recs)}" in text
    # The default tracker's row of the bench's sweep is what evaluate reported.
    sweep = bench_script("track_noise")
    sweep.dataset_sweep(str(model), str(root), "test")
    rows = capsys.readouterr().out.splitlines()
    (row,) = [r for r in rows if r.startswith("| 24 | 3 of 5 |")]
    assert f"| {rule['found']} of {len(uav_recs)} | " in row
    assert f"| {rule['false_tracks']} | " in row
    # Following half of the windows: fewer windows, a smaller share of the steps.
    sweep.dataset_sweep(str(model), str(root), "test", keep=0.5, keep_seed=1)
    head = capsys.readouterr().out.splitlines()[0]
    kept = int(head.split(": ")[1].split(" windows")[0])
    share = float(head.split("(")[1].split(" %")[0])
    assert kept < 24 and share < 100 * tracks["window_coverage"]


def test_evaluate_takes_a_confirmation_rule(
    tiny: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    """--confirm reaches the tracks and the JSON; bad rules are one line and exit 2."""
    from uavsnn.cli import main

    root, model = tiny
    runs = {}
    for rule in ("3/5", "1/1", None):
        extra = [] if rule is None else ["--confirm", rule]
        assert main(["evaluate", str(model), str(root), "--tracks", "--json", *extra]) == 0
        runs[rule] = json.loads(capsys.readouterr().out)["tracks"]
    assert runs[None]["confirm"] == runs["3/5"]["confirm"] == "3/5"
    assert runs[None]["rules"] == runs["3/5"]["rules"] and runs["1/1"]["confirm"] == "1/1"
    # Confirmed at the first hit, every track alarms: at least as many as at 3 of 5.
    one, three = runs["1/1"]["rules"]["any_spike"], runs["3/5"]["rules"]["any_spike"]
    assert one["alarming_tracks"] >= three["alarming_tracks"] and one["found"] >= three["found"]
    assert main(["evaluate", str(model), str(root), "--tracks", "--confirm", "2/3"]) == 0
    assert "tracks (confirmed at 2/3):" in capsys.readouterr().out
    for args in (["--tracks", "--confirm", "6/5"], ["--tracks", "--confirm", "x"],
                 ["--confirm", "2/3"], ["--tracks", "--confirm", "2/3+3/5"]):  # fmt: skip
        assert main(["evaluate", str(model), str(root), *args]) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "confirm" in err, args


def test_the_confirm_rules_bench_prints_what_evaluate_reports(
    tiny: tuple[Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    bench_script,
) -> None:
    from uavsnn.cli import main

    root, model = tiny
    assert main(["evaluate", str(model), str(root), "--tracks", "--json", "--confirm", "2/3"]) == 0
    want = json.loads(capsys.readouterr().out)["tracks"]
    bench = bench_script("confirm_rules")
    out = tmp_path / "rules.json"
    argv = ["confirm_rules.py", str(model), str(root), "--split", "test", "--rules", "3/5,2/3"]
    monkeypatch.setattr("sys.argv", [*argv, "--json", str(out)])
    bench.main()
    text = capsys.readouterr().out
    got = json.loads(out.read_text())
    assert list(got) == ["3/5", "2/3"] and got["2/3"]["rules"] == want["rules"]
    rule = want["rules"]["any_spike"]
    assert f"| 2/3 | any_spike | {rule['found']} of {want['uav_recordings']} |" in text


def test_a_dataset_without_raw_events_is_one_line_and_exit_2(
    tiny: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--tracks needs each window's raw events: a dataset saved without them is refused."""
    import shutil

    from uavsnn.cli import main
    from uavsnn.dataset import load
    from uavsnn.dataset.format import read_manifest, save_split, write_manifest

    root, model = tiny
    bare = tmp_path / "bare"
    shutil.copytree(root, bare)
    save_split(bare / "test.npz", replace(load(root, "test"), raw=None))
    write_manifest(bare, read_manifest(bare))  # the split's new hash
    code = main(["evaluate", str(model), str(bare), "--tracks"])
    err = capsys.readouterr().err
    assert code == 2 and "raw events" in err and len(err.strip().splitlines()) == 1


def test_the_rule_recorded_is_the_rule_used(tiny: tuple[Path, Path]) -> None:
    """Without a rule, the figures record the tracker's (uavsnn reproduce's results.json had
    None where `uavsnn evaluate --tracks` said 3/5 for the same figures)."""
    from uavsnn.dataset import load
    from uavsnn.track_eval import evaluate_tracks
    from uavsnn.tracks import tracker_for

    root, model = tiny
    network, data = Network.load(model), load(root, "test")
    assert evaluate_tracks(network, data)["confirm"] == "3/5"
    tracker = tracker_for(network, confirm_hits=2, confirm_windows=4)
    assert evaluate_tracks(network, data, tracker=tracker)["confirm"] == "2/4"
    # A rule given is the rule applied, whatever tracker made the features.
    ruled = evaluate_tracks(network, data, tracker=tracker, confirm=Confirm(1, 1))
    assert ruled["confirm"] == "1/1"


def test_the_track_lines_of_evaluate_read_as_counts_and_rates(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """`uavsnn evaluate --tracks` says the false tracks and their rate apart ("35 68.68/min"
    read as one number), the balanced accuracy beside the recordings decided right, and where
    the time to first alarm starts."""
    from uavsnn.cli.evaluate import _print_tracks

    rule = {
        "time_to_alarm_ms": {"median": 125.0, "p90": 580.0},
        "found": 25,
        "missed": [],
        "false_tracks": 35,
        "false_tracks_per_minute": 68.68,
        "false_tracks_per_minute_upper95": 91.06,
        "stray_tracks": 3,
        "decided": {"right": 41, "balanced_accuracy": 0.61},
    }
    tracks: dict[str, Any] = {
        "confirm": "3/5", "recordings": 67, "uav_recordings": 34, "windows": 2000,
        "window_coverage": 0.796, "uav_free_minutes": 0.5097, "alarm_clock": "recording",
        "rules": {"any_spike": rule}, "per_recording": [],
    }  # fmt: skip
    _print_tracks(tracks)
    out = capsys.readouterr().out
    assert "35 false tracks (68.68 per minute, 95 % upper bound 91.06)" in out
    assert "false tracks 35 68.68/min" not in out
    assert "recordings decided right 41/67 (61.2 %; balanced accuracy 61.0 %)" in out
    assert "does not start at the UAV's first event" in out
