"""Tracks: objects linked from window to window (uavsnn.tracks), and their faces."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uavsnn import EVENT_DTYPE, Detector, Network, ParameterError
from uavsnn.detector import _with_rotor
from uavsnn.grouping import _NO_DETECTIONS, WindowGrouper, WindowObject, WindowReport
from uavsnn.tracks import GATE_SHARE, Tracker, track_windows, tracker_for

STEP = 25_000  # µs between window starts (50 ms windows, overlap 0.5)


def report(k: int, boxes: list[tuple[int, int, int, int]]) -> WindowReport:
    objects = tuple(WindowObject(box=b, spikes=1) for b in boxes)
    return WindowReport(
        window=k,
        t0=k * STEP,
        t1=k * STEP + 2 * STEP,
        detected=bool(boxes),
        detections=_NO_DETECTIONS,
        objects=objects,
    )


def box_at(x: float, y: float, half: int = 3) -> tuple[int, int, int, int]:
    return (round(x) - half, round(y) - half, round(x) + half, round(y) + half)


def ids(rep: WindowReport) -> list[int | None]:
    return [o.track_id for o in rep.objects]


def test_constant_velocity_keeps_one_id_and_measures_the_motion() -> None:
    # 8 px per window = 320 px/s to the right, 2 px per window = 80 px/s down.
    reps = [report(k, [box_at(20 + 8 * k, 30 + 2 * k)]) for k in range(20)]
    result = track_windows(reps)
    assert {i for r in result.reports for i in ids(r)} == {1}
    (track,) = result.tracks
    assert track.hits == 20 and track.confirmed
    assert track.first_alarm_window == 2  # 3 of 5: the third hit
    assert track.first_alarm_us == reps[2].t1
    assert track.birth_us == reps[0].t0 and track.last_update_us == reps[-1].t1
    assert track.age_windows == 20 and track.age_us == reps[-1].t1 - reps[0].t0
    assert track.velocity == pytest.approx((320.0, 80.0), rel=1e-6)
    assert track.horizontal_speed == pytest.approx(320.0)
    assert track.vertical_speed == pytest.approx(80.0)
    assert track.straightness == pytest.approx(1.0)
    assert track.turn_rate == pytest.approx(0.0, abs=1e-9)
    assert track.speed_std == pytest.approx(0.0, abs=1e-6)
    assert track.path_length == pytest.approx(19 * math.hypot(8, 2))
    # Tentative until confirmed, in what the reports say.
    assert [r.objects[0].track_confirmed for r in result.reports[:4]] == [
        False,
        False,
        True,
        True,
    ]


def test_the_gate_scales_with_the_sensor() -> None:
    """An object crossing the same share of a 1280-px-wide sensor as a 240-px one does in a
    window moves 5.3 times as many pixels: 30 px per window there is 5.6 px at 240. The 240
    gate (24 px) never links it, so no track is confirmed; the 1280 sensor's links it."""
    assert Tracker.for_sensor(240).gate_px == pytest.approx(24.0) == Tracker().gate_px
    assert Tracker.for_sensor(1280).gate_px == pytest.approx(GATE_SHARE * 1280)
    reps = [report(k, [box_at(100 + 30 * k, 300 + 4 * k, half=12)]) for k in range(12)]
    split = track_windows(reps, Tracker())
    assert len(split.tracks) == 12 and not any(t.confirmed for t in split.tracks)
    whole = track_windows(reps, Tracker.for_sensor(1280, confirm_hits=2, confirm_windows=3))
    (track,) = whole.tracks
    assert track.hits == 12 and track.first_alarm_window == 1
    assert track.velocity == pytest.approx((1200.0, 160.0), rel=1e-6)


@pytest.mark.parametrize(
    ("width", "kwargs"),
    [
        (0, {}),
        (True, {}),
        (240.0, {}),
        (240, {"gate_px": 10.0}),
        (240, {"alpha": 2.0}),
        (np.float64(240), {}),
        (np.bool_(True), {}),
        pytest.param(2**2000, {}, id="2**2000"),
        (65536, {}),
        (240, {"alfa": 0.5}),  # misspelt: a ParameterError, not Python's TypeError
    ],
)
def test_for_sensor_refuses_bad_arguments(width: object, kwargs: dict) -> None:
    with pytest.raises(ParameterError):
        Tracker.for_sensor(width, **kwargs)  # type: ignore[arg-type]


def test_each_object_carries_its_track_so_far_and_the_rotor_mean() -> None:
    """An object's ``track`` is its track after that window (causal: later windows do not
    change it), and the track's rotor mean counts the objects whose rotor was measured."""
    from uavsnn.signature import RotorEstimate

    strengths = [0.2, None, 0.6, 0.1, None]
    reps = []
    for k, s in enumerate(strengths):
        rotor = None if s is None else RotorEstimate(400.0, s, 9, 5, 6, 10, s >= 0.1)
        obj = WindowObject(box=box_at(20 + 4 * k, 30), spikes=1, rotor=rotor)
        reps.append(replace(report(k, []), objects=(obj,)))
    result = track_windows(reps)
    seen = [o.track for r in result.reports for o in r.objects]
    assert [t.hits for t in seen] == [1, 2, 3, 4, 5]
    assert [t.rotor_measured for t in seen] == [1, 1, 2, 3, 3]
    assert [t.rotor_strength_mean for t in seen] == pytest.approx([0.2, 0.2, 0.4, 0.3, 0.3])
    assert [t.confirmed for t in seen] == [False, False, True, True, True]
    assert [t.speed for t in seen][:2] == [0.0, pytest.approx(160.0)]
    assert result.tracks[0] == seen[-1]
    # Without a track (the cap reached), no snapshot.
    capped = Tracker(max_tracks=1).update(report(0, [box_at(10, 10), box_at(100, 100)]))
    assert capped.objects[0].track is not None and capped.objects[1].track is None


def test_a_track_keeps_the_history_of_its_objects_activity() -> None:
    """The track's activity history: the mean and population standard deviation of its
    measured objects' log events per pixel, the mean ON/OFF balance and log rate swing, each as
    ``features.activity`` gives one object; objects without counts do not count."""
    from uavsnn.features import activity

    # (events, on, swing) per window; None: not measured. Boxes of 8 x 8 pixels.
    counts = [(64, 48, 1.0), None, (128, 32, 3.0), (0, 0, 0.0)]
    reps = []
    for k, c in enumerate(counts):
        obj = WindowObject(box=box_at(20 + 4 * k, 30, half=4), spikes=1, counts=c)
        reps.append(replace(report(k, []), objects=(obj,)))
    seen = [o.track for r in track_windows(reps).reports for o in r.objects]
    assert seen[0].box[2] - seen[0].box[0] == 8 and seen[0].box[3] - seen[0].box[1] == 8
    assert [t.activity_measured for t in seen] == [1, 1, 2, 3]
    measured = [activity(seen[0].box, c) for c in counts if c is not None]
    assert measured[0] == pytest.approx((math.log1p(1.0), 0.5, math.log1p(1.0)))
    assert measured[2] == (0.0, 0.0, 0.0)  # no event: no balance
    density = [m[0] for m in measured]
    last = seen[-1]
    assert last.events_per_px_mean == pytest.approx(np.mean(density))
    assert last.events_per_px_std == pytest.approx(np.std(density))
    assert last.on_balance_mean == pytest.approx(np.mean([m[1] for m in measured]))
    assert last.rate_swing_mean == pytest.approx(np.mean([m[2] for m in measured]))
    assert seen[1].events_per_px_mean == seen[0].events_per_px_mean == density[0]
    assert seen[0].events_per_px_std == 0.0
    # Counts no box gives, or an empty box: a typed error, from the tracker too.
    fine = (1, 1, 0.0)
    for box, bad in (
        (box_at(9, 9), (3, 4, 0.0)),
        (box_at(9, 9), (3, 1, -1.0)),
        (box_at(9, 9), (3, 1, float("nan"))),
        (box_at(9, 9), (3, "one", 0.0)),
        (box_at(9, 9), (3,)),
        ((5, 5, 5, 9), fine),
    ):
        with pytest.raises(ParameterError):
            activity(box, bad)
    tracker = Tracker()
    tracker.update(replace(report(0, []), objects=(WindowObject(box_at(9, 9), 1, counts=fine),)))
    before = tracker.live
    bad_obj = WindowObject(box_at(9, 9), 1, counts=(3, 4, 0.0))
    with pytest.raises(ParameterError):
        tracker.update(replace(report(1, []), objects=(bad_obj,)))
    assert tracker.live == before  # nothing of the refused window was kept
    tracker.update(replace(report(1, []), objects=(WindowObject(box_at(9, 9), 1, counts=fine),)))
    assert tracker.live[0].hits == 2
    # A track whose objects were never measured: zeros.
    bare = track_windows([report(k, [box_at(20 + 4 * k, 30)]) for k in range(3)]).tracks[0]
    assert bare.activity_measured == 0
    assert (bare.events_per_px_mean, bare.events_per_px_std) == (0.0, 0.0)
    assert (bare.on_balance_mean, bare.rate_swing_mean) == (0.0, 0.0)


def test_hovering_and_zigzag_tracks_differ_in_their_statistics() -> None:
    hover = [report(k, [box_at(60 + (k % 2), 60)]) for k in range(12)]
    zig = [report(k, [box_at(20 + 6 * k, 40 + (5 if k % 2 else -5))]) for k in range(12)]
    (h,) = track_windows(hover, Tracker(gate_px=30)).tracks
    (z,) = track_windows(zig, Tracker(gate_px=30)).tracks
    assert h.straightness < 0.2 and abs(h.horizontal_speed) < 5
    assert z.turn_rate > 10 and z.speed_std < 1e-6 * z.mean_speed + 1


def test_darting_falling_and_crossing_paths() -> None:
    """An insect-like dart (steps of 2 and 14 px), a falling ball (speed growing downwards)
    and an aircraft (constant speed): the statistics that tell them apart."""
    xs = [20.0]
    for k in range(1, 14):
        xs.append(xs[-1] + (14 if k % 2 else 2))
    dart = [report(k, [box_at(x, 60)]) for k, x in enumerate(xs)]
    fall = [report(k, [box_at(100, 10 + 0.5 * k * k)]) for k in range(12)]
    plane = [report(k, [box_at(10 + 8 * k, 40)]) for k in range(14)]
    (d,) = track_windows(dart).tracks
    (f,) = track_windows(fall).tracks
    (p,) = track_windows(plane).tracks
    steps = np.diff(xs) / 0.025  # px/s; the population standard deviation
    assert d.speed_std == pytest.approx(float(np.std(steps)), rel=1e-9)
    assert d.mean_speed == pytest.approx(float(np.mean(steps)), rel=1e-9) and d.speed_std > 200
    assert p.speed_std == pytest.approx(0.0, abs=1e-6) and p.straightness == pytest.approx(1)
    assert f.vertical_speed > 0 and abs(f.horizontal_speed) < 1e-9
    assert f.velocity[1] > f.vertical_speed  # it is speeding up: now faster than on average


def test_two_crossing_objects_keep_their_ids() -> None:
    reps = []
    for k in range(24):
        a = box_at(10 + 6 * k, 40 + 2 * k)  # right and down
        b = box_at(150 - 6 * k, 88 - 2 * k)  # left and up: they cross near k = 11.7
        reps.append(report(k, [a, b] if k % 2 else [b, a]))
    result = track_windows(reps)
    for r in result.reports:
        by_x_move = {}
        for o in r.objects:
            by_x_move[o.track_id] = o.centre
        assert set(by_x_move) == {1, 2}
    first, last = result.reports[0], result.reports[-1]
    start = {o.track_id: o.centre for o in first.objects}
    end = {o.track_id: o.centre for o in last.objects}
    for tid in (1, 2):  # each id ends where its own straight line goes
        moved_right = end[tid][0] > start[tid][0]
        assert moved_right == (start[tid][0] < 80)
    assert len(result.tracks) == 2


def test_a_vanished_object_is_deleted_after_max_misses_windows() -> None:
    tracker = Tracker(max_misses=3)
    for k in range(5):
        tracker.update(report(k, [box_at(50, 50)]))
    assert len(tracker.live) == 1
    for k in range(5, 8):  # three windows without it: still live, coasting
        tracker.update(report(k, []))
        assert len(tracker.live) == 1 and tracker.drain_ended() == []
    tracker.update(report(8, []))
    assert tracker.live == ()
    (gone,) = tracker.drain_ended()
    assert gone.id == 1 and gone.hits == 5 and gone.last_window == 4
    # Reappearing there later starts a new track.
    out = tracker.update(report(9, [box_at(50, 50)]))
    assert ids(out) == [2]


def test_skipped_windows_count_as_misses() -> None:
    tracker = Tracker(max_misses=3)
    tracker.update(report(0, [box_at(50, 50)]))
    out = tracker.update(report(10, [box_at(50, 50)]))  # a silent gap of 9 windows
    assert ids(out) == [2] and [t.id for t in tracker.drain_ended()] == [1]


def noise_reports(seed: int, windows: int, rate: float) -> list[WindowReport]:
    """Detections at uniform positions of a 240x180 sensor, Poisson(rate) per window."""
    rng = np.random.default_rng(seed)
    return [
        report(k, [box_at(rng.uniform(10, 230), rng.uniform(10, 170)) for _ in range(n)])
        for k, n in enumerate(rng.poisson(rate, windows).tolist())
    ]


def test_noise_does_not_make_confirmed_tracks() -> None:
    # 0.25 noise detections per window (docs/identification.md, "Tracks": the measured rate
    # of false confirmations against the noise density).
    result = track_windows(noise_reports(2000, 1000, 0.25))
    assert len(result.tracks) > 150  # the noise did start tentative tracks ...
    assert not any(t.confirmed for t in result.tracks)  # ... none confirmed


def test_noise_beside_a_real_object() -> None:
    rng = np.random.default_rng(2001)
    reps = []
    for k in range(40):
        boxes = [box_at(30 + 4 * k, 90)]
        if rng.random() < 0.5:
            boxes.append(box_at(rng.uniform(10, 230), rng.uniform(150, 175)))
        reps.append(report(k, boxes))
    result = track_windows(reps)
    assert [t.id for t in result.tracks if t.confirmed] == [1]
    assert all(r.objects[0].track_id == 1 for r in result.reports)


def test_the_live_track_cap() -> None:
    tracker = Tracker(max_tracks=2)
    out = tracker.update(report(0, [box_at(20, 20), box_at(100, 20), box_at(180, 20)]))
    assert sorted(i for i in ids(out) if i is not None) == [1, 2] and None in ids(out)
    assert tracker.births_refused == 1 and len(tracker.live) == 2


@pytest.mark.parametrize(
    "kwargs",
    [
        {"gate_px": 0},
        {"gate_px": float("nan")},
        {"gate_px": "5"},
        {"alpha": 0.0},
        {"beta": 1.5},
        {"confirm_hits": 0},
        {"confirm_hits": 6, "confirm_windows": 5},
        {"confirm_windows": 65},
        {"max_misses": 0},
        {"max_misses": 2.5},
        {"max_tracks": 0},
        {"max_tracks": 10**6},
        {"max_tracks": True},
        {"gate_px": 2**2000},
        {"alpha": 2**2000},
        {"beta": -(2**2000)},
        {"gate_px": np.float32("nan")},
        {"alpha": np.float64(0.0)},
        {"confirm_hits": np.float64(3)},
        {"confirm_windows": np.int64(65)},
        {"max_tracks": np.bool_(True)},
        {"max_misses": np.int8(0)},
    ],
)
def test_bad_parameters_are_typed_errors(kwargs: dict) -> None:
    with pytest.raises(ParameterError, match="|".join(kwargs)):  # the parameter named
        Tracker(**kwargs)


def test_numpy_numbers_are_taken_as_python_ones() -> None:
    """Parameters of NumPy numbers (as arrays and configurations hand them out) give the
    tracker Python ones give; they were refused as not numbers, or not integers."""
    numpy = Tracker(
        gate_px=np.float32(12),
        alpha=np.float64(0.5),
        beta=np.float32(0.25),
        confirm_hits=np.int64(2),
        confirm_windows=np.uint8(4),
        max_misses=np.int32(3),
        max_tracks=np.int16(8),
    )
    plain = Tracker(
        gate_px=12.0,
        alpha=0.5,
        beta=0.25,
        confirm_hits=2,
        confirm_windows=4,
        max_misses=3,
        max_tracks=8,
    )
    for name in ("gate_px", "alpha", "beta", "confirm_hits", "confirm_windows", "max_misses"):
        assert getattr(numpy, name) == getattr(plain, name)
        assert type(getattr(numpy, name)) is type(getattr(plain, name))
    assert numpy.max_tracks == 8 and type(numpy.max_tracks) is int
    reps = [report(k, [box_at(20 + 4 * k, 30)]) for k in range(8)]
    assert track_windows(reps, numpy) == track_windows(reps, plain)
    assert Tracker.for_sensor(np.int64(640)).gate_px == Tracker.for_sensor(640).gate_px == 64.0
    assert Tracker.for_sensor(np.uint16(240), max_tracks=np.int64(2)).max_tracks == 2


def test_a_given_tracker_is_unchanged_when_track_windows_refuses_a_report() -> None:
    # It had taken the reports before the bad one.
    reps = [report(k, [box_at(20 + 4 * k, 30)]) for k in range(8)]
    tracker = Tracker()
    with pytest.raises(ParameterError):
        track_windows([*reps[:5], reps[2], *reps[5:]], tracker)  # window 2 again: backwards
    assert tracker.live == () and tracker.finish() == []
    fresh = Tracker()
    assert track_windows(reps, tracker) == track_windows(reps, fresh)
    assert tracker.finish() == fresh.finish() == []  # the run ended both the same way


def test_track_windows_refuses_what_is_not_a_report_or_a_tracker() -> None:
    with pytest.raises(ParameterError, match="WindowReports, got 3"):
        track_windows([3])  # type: ignore[list-item]
    with pytest.raises(ParameterError, match="iterable"):
        track_windows(3)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="Tracker"):
        track_windows([], tracker="x")  # type: ignore[arg-type]
    tracker = Tracker()
    with pytest.raises(ParameterError, match="WindowReports"):
        tracker.update(None)  # type: ignore[arg-type]
    assert tracker.live == ()


def test_windows_out_of_order_are_refused() -> None:
    tracker = Tracker()
    tracker.update(report(3, []))
    with pytest.raises(ParameterError):
        tracker.update(report(3, []))
    with pytest.raises(ParameterError):
        Detector(Network(seed=0), tracker="no")  # type: ignore[arg-type]


def timed(k: object, t0: object, t1: object, x: float = 20.0) -> WindowReport:
    """Window ``k`` over ``[t0, t1)`` with one object centred at ``(x, 30)``."""
    return replace(report(0, [box_at(x, 30)]), window=k, t0=t0, t1=t1)


def stream_result(tracker: Tracker, reports: list[WindowReport]) -> list:
    """What ``tracker`` says of each of ``reports`` fed in turn, and at the end."""
    out = [[o.track for o in tracker.update(r).objects] for r in reports]
    return [out, tracker.finish()]


@pytest.mark.parametrize(
    "bad",
    [
        timed(2, 500, 1500),  # the previous window's times again
        timed(2, 400, 1600),  # another window, the same centre
        timed(2, 0, 1000),  # back in time
        timed(2, 1500, 1500),  # empty
        timed(2, 2000, 1900),  # ends before it starts
        timed(2, -1000, 4000),
        timed(2, float("nan"), 2500),
        timed(2, 1000, float("inf")),
        timed(2, 1000.0, 2000),
        timed(2, "1000", 2000),
        timed(2.0, 1000, 2000),
        timed(float("nan"), 1000, 2000),
    ],
)
def test_windows_with_bad_times_are_refused_and_change_nothing(bad: WindowReport) -> None:
    """The speeds are displacements over the time between window centres: a window must end
    after it starts, at whole µs, and its centre be later than the previous window's. Two
    windows with one centre once divided by zero after the tracker had moved on, and a window
    back in time gave negative speeds."""
    start = [timed(0, 0, 1000, 20.0), timed(1, 500, 1500, 21.0)]
    rest = [timed(2, 1000, 2000, 22.0), timed(3, 1500, 2500, 23.0)]
    tracker = Tracker()
    for r in start:
        tracker.update(r)
    before = tracker.live
    with pytest.raises(ParameterError, match="window"):
        tracker.update(bad)
    assert tracker.live == before and tracker.drain_ended() == []
    # the stream goes on as if the window had not come
    fresh = Tracker()
    for r in start:
        fresh.update(r)
    assert stream_result(tracker, rest) == stream_result(fresh, rest)


@pytest.mark.parametrize(
    "bad",
    [
        timed(0, 1000, 1000),
        timed(0, 1000, 900),
        timed(0, -1, 1000),
        timed(0, float("nan"), 1000),
        timed(0, 0.0, 1000),
        timed(-1, 0, 1000),
        timed(np.nan, 0, 1000),
    ],
)
def test_a_first_window_with_bad_times_is_refused(bad: WindowReport) -> None:
    tracker = Tracker()
    with pytest.raises(ParameterError, match="window"):
        tracker.update(bad)
    assert tracker.live == () and tracker.finish() == []
    assert ids(tracker.update(timed(0, 0, 1000))) == [1]


def test_window_times_may_be_numpy_integers_and_late_in_a_stream() -> None:
    """NumPy integer times give the tracks Python integers give; windows a µs apart late in a
    stream (where their centres as floats are one number) are measured exactly."""
    reps = [timed(k, 1000 * k, 1000 * k + 2000, 20.0 + 3 * k) for k in range(6)]
    typed = [
        replace(r, window=np.int64(r.window), t0=np.uint64(r.t0), t1=np.int64(r.t1)) for r in reps
    ]
    assert stream_result(Tracker(), typed) == stream_result(Tracker(), reps)
    late = 1 << 61  # float64 steps of 512 µs there
    assert float(late + 0.5) == float(late + 1.5)
    reps = [timed(k, late + k, late + k + 1, 20.0 + k) for k in range(4)]
    (track,) = track_windows(reps).tracks
    assert track.hits == 4 and track.velocity == pytest.approx((1e6, 0.0))  # 1 px per µs
    assert track.horizontal_speed == pytest.approx(1e6) and track.mean_speed == 1e6


def test_a_long_gap_in_a_stream_that_keeps_its_tracks() -> None:
    """With a max_misses of any size, a track outlives a gap of as many windows: the window
    mask moved on by the whole gap, a number of bits that ran out of memory."""
    tracker = Tracker(max_misses=10**15, confirm_hits=2, confirm_windows=3)
    tracker.update(timed(0, 0, 1000, 20.0))
    tracker.update(timed(1, 500, 1500, 20.0))
    gap = 10**13
    out = tracker.update(timed(gap, gap * 500, gap * 500 + 1000, 20.0))
    (track,) = tracker.live
    assert ids(out) == [1] and track.hits == 3 and track.misses == 0 and track.confirmed
    # after the gap the mask holds the latest hit alone, as after any gap of 3 windows or more
    short = Tracker(confirm_hits=3, confirm_windows=3)
    long = Tracker(max_misses=10**15, confirm_hits=3, confirm_windows=3)
    for t in (short, long):
        t.update(timed(0, 0, 1000, 20.0))
        t.update(timed(1, 500, 1500, 20.0))
    short.update(timed(4, 2000, 3000, 20.0))
    long.update(timed(gap, gap * 500, gap * 500 + 1000, 20.0))
    for t, k in ((short, 5), (long, gap + 1)):
        (track,) = t.live
        assert not track.confirmed
        t.update(timed(k, 500 * k, 500 * k + 1000, 20.0))
        assert not t.live[0].confirmed  # 2 hits of the last 3 windows
        t.update(timed(k + 1, 500 * k + 500, 500 * k + 1500, 20.0))
        assert t.live[0].confirmed


# ---------------------------------------------------------------- through the Detector

SIZE = (40, 30)


def small_net() -> Network:
    config = {
        "width": SIZE[0],
        "height": SIZE[1],
        "pent": {"mode": "pent", "beta": 2.0, "theta_min": 1.5},
        "conv2": {"threshold": 3.0},
        "conv3": {"threshold": 1.5},
    }
    return Network(config, seed=3)


@pytest.fixture(scope="module")
def net() -> Network:
    return small_net()


def blob_events(seed: int, n: int) -> np.ndarray:
    """A blob drifting right over sparse noise on the 40x30 sensor."""
    rng = np.random.default_rng(seed)
    ev = np.zeros(n, dtype=EVENT_DTYPE)
    ev["t"] = 5_000 + np.cumsum(rng.integers(0, 40, n) * (rng.random(n) < 0.7))
    noise = rng.random(n) < 0.25
    cx = 5 + np.arange(n) * 30 // n
    ev["x"] = np.where(noise, rng.integers(0, SIZE[0], n), cx + rng.integers(0, 5, n))
    ev["y"] = np.where(noise, rng.integers(0, SIZE[1], n), 12 + rng.integers(0, 5, n))
    ev["p"] = rng.random(n) < 0.5
    return ev


def streamed(det: Detector, events: np.ndarray, cuts: list[int]) -> list[WindowReport]:
    bounds = [0, *sorted(min(c, len(events)) for c in cuts), len(events)]
    reps = []
    for a, b in itertools.pairwise(bounds):
        reps += det.push_windows(events[a:b])
    return reps + det.flush_windows()


def key(reps: list[WindowReport]) -> list:
    return [(r.window, [(o.box, o.track_id, o.track_confirmed) for o in r.objects]) for r in reps]


@settings(max_examples=15, deadline=None)
@given(cuts=st.lists(st.integers(0, 3000), max_size=10), seed=st.integers(0, 2))
def test_streaming_in_any_chunks_equals_batch(net: Network, cuts: list[int], seed: int) -> None:
    events = blob_events(seed, 3000)
    det = Detector(net, window_us=3_000, overlap=0.5, tracker=Tracker(gate_px=8))
    reps = streamed(det, events, cuts)
    # Batch: the plain windows of one whole push, tracked afterwards by the same code.
    plain = Detector(net, window_us=3_000, overlap=0.5)
    grouper = WindowGrouper.of(plain)
    untracked = grouper.add(events, plain.push(events)) + grouper.finish(plain.flush())
    # The rotor signature the streaming detector measures, so that the tracks' rotor means agree.
    untracked = [_with_rotor(r, [events])[0] for r in untracked]
    result = track_windows(untracked, Tracker(gate_px=8))
    assert key(reps) == key(list(result.reports))
    assert sorted(det.tracker.finish(), key=lambda t: t.id) == list(result.tracks)
    assert any(o.track_id is not None for r in reps for o in r.objects)


@pytest.mark.parametrize("whole_chunk", [3000, 700])
def test_a_large_chunk_keeps_the_events_of_the_windows_it_closes(
    net: Network, monkeypatch: pytest.MonkeyPatch, whole_chunk: int
) -> None:
    """The rotor is measured on the same events whether the stream comes in one chunk larger
    than MAX_ROTOR_EVENTS or in small ones (the limits shrunk: the windows still open hold
    about 450 events, a chunk of 3000 or 700 more than the 600 kept)."""
    import uavsnn.detector

    monkeypatch.setattr(uavsnn.detector, "MAX_ROTOR_EVENTS", 600)
    monkeypatch.setattr(uavsnn.detector, "_ROTOR_SLICE", 64)
    events = blob_events(0, 3000)

    def rotors(cut: int) -> list:
        det = Detector(net, window_us=3_000, overlap=0.5, tracker=Tracker(gate_px=8))
        reps = streamed(det, events, list(range(cut, len(events), cut)))
        return [(r.window, [(o.box, repr(o.rotor), o.counts) for o in r.objects]) for r in reps]

    small = rotors(50)
    assert sum(o[1] != "None" for _, objs in small for o in objs) > 10
    assert rotors(whole_chunk) == small


def test_a_detector_tracks_with_its_sensors_gate(net: Network) -> None:
    assert Detector(net).tracker.gate_px == pytest.approx(GATE_SHARE * SIZE[0])
    mine = Tracker(gate_px=5.0)
    assert Detector(net, tracker=mine).tracker is mine


def test_a_network_runs_at_the_gate_its_identification_was_fitted_with(net: Network) -> None:
    """tracker_for: the gate the model records, else the sensor's; the Detector's default
    tracker and ``detect --confirm``'s come from it."""
    from uavsnn.cli.detect import _tracker
    from uavsnn.identify import FEATURES, Identifier

    assert tracker_for(net).gate_px == pytest.approx(GATE_SHARE * SIZE[0])
    k = len(FEATURES)
    fitted = net.copy()
    fitted.identification = Identifier(
        FEATURES, np.zeros(k + 1), np.zeros(k), np.ones(k), 0.5, 1.0
    )  # a model written before the gate was recorded: the sensor's
    assert tracker_for(fitted).gate_px == pytest.approx(GATE_SHARE * SIZE[0])
    fitted.identification = replace(fitted.identification, gate_px=24.0)
    mine = tracker_for(fitted, confirm_hits=2, confirm_windows=4)
    assert (mine.gate_px, mine.confirm_hits, mine.confirm_windows) == (24.0, 2, 4)
    assert Detector(fitted).tracker.gate_px == 24.0
    assert _tracker("2/4", fitted).gate_px == 24.0 and _tracker(None, fitted) is None
    with pytest.raises(ParameterError, match="gate_px"):
        tracker_for(fitted, gate_px=10.0)
    # A misspelt argument is a ParameterError naming it, as for_sensor's (a TypeError before).
    for make in (lambda: tracker_for(fitted, confirm_hit=2), lambda: Tracker.for_sensor(240, a=1)):
        with pytest.raises(ParameterError, match="unknown Tracker arguments"):
            make()


def test_the_drifting_blob_is_one_confirmed_track(net: Network) -> None:
    events = blob_events(0, 3000)
    det = Detector(net, window_us=3_000, overlap=0.5, tracker=Tracker(gate_px=8))
    reps = streamed(det, events, [])
    tracks = [t for t in det.tracker.finish() if t.confirmed]
    assert tracks
    best = max(tracks, key=lambda t: t.hits)
    assert best.horizontal_speed > 0  # it drifts right
    assert best.hits >= len([r for r in reps if r.objects]) // 2


def flicker_events(freq_hz: float, box: tuple[int, int, int, int], dur_us: int) -> np.ndarray:
    """Every pixel of ``box`` flickers at ``freq_hz``: an ON then an OFF run per period."""
    x0, y0, x1, y1 = box
    period = 1e6 / freq_hz
    rows = []
    for c in range(int(dur_us / period)):
        for half, p in ((0.0, 1), (0.5, 0)):
            for rep in range(2):
                t = int(c * period + half * period) + rep
                rows += [(t, x, y, p) for x in range(x0, x1) for y in range(y0, y1)]
    ev = np.array(rows, dtype=[("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("p", "u1")])
    ev = ev[np.argsort(ev["t"], kind="stable")]
    out = np.zeros(len(ev), dtype=EVENT_DTYPE)
    for f in ("t", "x", "y", "p"):
        out[f] = ev[f]
    return out


def test_rotor_frequency_of_a_flickering_object(net: Network) -> None:
    events = flicker_events(400.0, (14, 10, 22, 18), 60_000)
    det = Detector(net, window_us=20_000, overlap=0.5)
    reps = streamed(det, events, [len(events) // 3])
    rotors = [o.rotor for r in reps for o in r.objects if o.rotor is not None]
    assert rotors, "no object measured"
    found = [r for r in rotors if r.detected]
    assert found and all(abs(r.frequency_hz - 400.0) < 8.0 for r in found)
    det_off = Detector(net, window_us=20_000, overlap=0.5, rotor=False)
    assert all(o.rotor is None for r in streamed(det_off, events, []) for o in r.objects)


def test_cli_prints_track_and_rotor(net: Network, tmp_path: Path) -> None:
    import json
    import subprocess
    import sys

    model = tmp_path / "model.npz"
    net.save(model)
    events = blob_events(0, 3000)
    det = Detector(net, window_us=3_000, overlap=0.5)
    reps = streamed(det, events, [])
    cmd = [sys.executable, "-m", "uavsnn", "detect", "-", "--model", str(model), "--window-ms", "3"]
    done = subprocess.run([*cmd, "--json"], input=events.tobytes(), capture_output=True)
    assert done.returncode == 0, done.stderr.decode()
    rows = [json.loads(line) for line in done.stdout.decode().splitlines()]
    assert [[o["track"] for o in row["objects"]] for row in rows] == [
        [o.track_id for o in r.objects] for r in reps
    ]
    assert any(o["track_confirmed"] for row in rows for o in row["objects"])
    assert all("rotor" in o for row in rows for o in row["objects"])
    text = subprocess.run(cmd, input=events.tobytes(), capture_output=True).stdout.decode()
    assert " track=1" in text and " rotor=" in text


def test_detect_takes_a_confirmation_rule(net: Network, tmp_path: Path) -> None:
    """detect --confirm H/W: the printed tracks are those of a Detector whose Tracker (the
    network's, :func:`tracker_for`) confirms at H of W; a bad or score-aware rule is one line
    on stderr and exit 2."""
    import json
    import subprocess
    import sys

    from uavsnn.tracks import tracker_for

    model = tmp_path / "model.npz"
    net.save(model)
    events = blob_events(0, 3000)
    cmd = [sys.executable, "-m", "uavsnn", "detect", "-", "--model", str(model), "--window-ms", "3"]
    seen = {}
    for rule, (hits, windows) in (("1/1", (1, 1)), ("5/6", (5, 6))):
        det = Detector(net, window_us=3_000, overlap=0.5, tracker=tracker_for(
            net, confirm_hits=hits, confirm_windows=windows))  # fmt: skip
        reps = streamed(det, events, [])
        done = subprocess.run(
            [*cmd, "--json", "--confirm", rule], input=events.tobytes(), capture_output=True
        )
        assert done.returncode == 0, done.stderr.decode()
        rows = [json.loads(line) for line in done.stdout.decode().splitlines()]
        got = [[(o["track"], o["track_confirmed"]) for o in row["objects"]] for row in rows]
        assert got == [[(o.track_id, o.track_confirmed) for o in r.objects] for r in reps]
        seen[rule] = sum(c for row in got for _, c in row)
    # Every tracked object is confirmed at 1 of 1; fewer at 5 of 6.
    tracked_objects = sum(1 for r in reps for o in r.objects if o.track_id is not None)
    assert seen["1/1"] == tracked_objects > seen["5/6"]
    for bad in ("0/3", "4/3", "3", "2/3+3/5"):
        done = subprocess.run([*cmd, "--confirm", bad], input=b"", capture_output=True)
        err = done.stderr.decode().strip().splitlines()
        assert done.returncode == 2 and len(err) == 1 and "confirm" in err[0], (bad, err)
    done = subprocess.run([*cmd, "--confirm", "2/3", "--per-spike"], input=b"", capture_output=True)
    assert done.returncode == 2 and "--per-spike" in done.stderr.decode()


def test_tracks_carry_a_running_score_and_class_guess(net: Network, tmp_path: Path) -> None:
    """Each scored object's track score is the running mean of its track's object scores, its
    track class the guess from that mean and the mean class probabilities; detect --json
    prints them with the class probabilities by name and the track's statistics."""
    import json
    import subprocess
    import sys

    from uavsnn.identify import FEATURES, Identifier

    k = len(FEATURES)
    class_coef = np.zeros((3, k + 1))
    class_coef[1, FEATURES.index("log_width")] = 2.0  # wide: bird; narrow: clutter
    net = net.copy()
    net.identification = Identifier(
        FEATURES, np.linspace(-0.5, 0.5, k + 1), np.full(k, 1.0), np.ones(k), 0.5, 1.0,
        classes=("uav", "bird", "clutter"), class_coef=class_coef, class_l2=1.0,
    )  # fmt: skip
    events = blob_events(0, 3000)
    reps = streamed(Detector(net, window_us=3_000, overlap=0.5), events, [])
    seen: dict[int, list] = {}
    scored = 0
    for r in reps:
        for o in r.objects:
            if o.uav_score is None or o.track_id is None:
                assert o.track_score is None and o.track_class is None
                continue
            scored += 1
            seen.setdefault(o.track_id, []).append(o)
            mine = seen[o.track_id]
            mean = np.mean([m.uav_score for m in mine])
            probs = np.mean([m.class_probabilities for m in mine], axis=0)
            assert o.track_score == pytest.approx(mean, rel=1e-12)
            assert (
                o.track_class == net.identification.guess_from(np.array([mean]), probs[None, :])[0]
            )
            assert o.class_guess in ("uav", "bird", "clutter")
    assert scored >= 3 and any(len(v) >= 3 for v in seen.values())
    model = tmp_path / "model.npz"
    net.save(model)
    cmd = [sys.executable, "-m", "uavsnn", "detect", "-", "--model", str(model), "--window-ms", "3"]
    done = subprocess.run([*cmd, "--json"], input=events.tobytes(), capture_output=True)
    assert done.returncode == 0, done.stderr.decode()
    rows = [json.loads(line) for line in done.stdout.decode().splitlines()]
    objs = [o for row in rows for o in row["objects"] if o["uav_score"] is not None]
    assert len(objs) == scored
    for o in objs:
        assert set(o["class_probabilities"]) == {"uav", "bird", "clutter"}
        assert sum(o["class_probabilities"].values()) == pytest.approx(1.0)
        if o["track"] is not None:
            assert o["track_class"] in ("uav", "bird", "clutter")
            assert o["track_stats"]["hits"] >= 1 and o["track_stats"]["age_us"] > 0
            # A scored object was measured, so its track's activity history counts it.
            assert o["track_stats"]["activity_measured"] >= 1
            assert o["track_stats"]["events_per_px_mean"] > 0
            assert o["track_stats"]["events_per_px_std"] >= 0


def test_tracks_on_a_real_recording(shared_data: Path) -> None:
    """A real DVXplorer recording of a person (0.59 s), downsampled to 240x180, through the
    Detector with an untrained default network, in two chunks: tracks are produced, ids are
    never reused, and the person's box keeps its id from window to window."""
    from uavsnn.filters import downsample
    from uavsnn.io import read
    from uavsnn.tracks import _iou

    events = downsample(read(shared_data / "dvs" / "tonic_dvxplorer_person.aedat4"), (240, 180))
    det = Detector(Network(seed=0), window_us=50_000, overlap=0.5)
    reps = streamed(det, events.events, [len(events.events) // 2])
    tracks = det.tracker.finish()
    assert reps and tracks
    assert len({t.id for t in tracks}) == len(tracks)
    assert any(t.confirmed and t.first_alarm_us is not None for t in tracks)
    linked = 0
    for a, b in itertools.pairwise(reps):
        if a.objects and b.objects and _iou(a.objects[0].box, b.objects[0].box) > 0.3:
            assert a.objects[0].track_id == b.objects[0].track_id
            linked += 1
    assert linked >= 5
    # Streaming equals batch on real data too.
    plain = Detector(Network(seed=0), window_us=50_000, overlap=0.5)
    grouper = WindowGrouper.of(plain)
    ev = events.events
    untracked = grouper.add(ev, plain.push(ev)) + grouper.finish(plain.flush())
    assert key(reps) == key(list(track_windows(untracked).reports))


def test_a_rejected_chunk_changes_no_track(net: Network) -> None:
    from uavsnn import EventError, StreamError

    events = blob_events(1, 3000)
    det = Detector(net, window_us=3_000, overlap=0.5, tracker=Tracker(gate_px=8))
    first = det.push_windows(events[:1500])
    before = det.tracker.live
    bad = events[1500:1600].copy()
    bad["x"][5] = SIZE[0]  # outside the sensor
    with pytest.raises(EventError):
        det.push_windows(bad)
    with pytest.raises(StreamError):
        det.push_windows(events[:10])  # back in time
    assert det.tracker.live == before
    rest = det.push_windows(events[1500:]) + det.flush_windows()
    whole = Detector(net, window_us=3_000, overlap=0.5, tracker=Tracker(gate_px=8))
    assert key(first + rest) == key(streamed(whole, events, []))


def test_ended_tracks_undrained_stay_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    import uavsnn.tracks as tracks_mod

    monkeypatch.setattr(tracks_mod, "MAX_ENDED", 3)
    tracker = Tracker(max_misses=1)
    tracker._ended = tracks_mod.deque(maxlen=3)
    for k in range(0, 20, 2):  # a new object every other window, far from the last
        tracker.update(report(k, [box_at(20 + 20 * (k % 10), 50)]))
    assert len(tracker.drain_ended()) == 3 and tracker.ended_dropped == 6
