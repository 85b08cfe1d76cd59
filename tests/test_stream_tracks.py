"""A streaming Detector's tracks against the batch path's: a track that ends in a silent gap or
in a quiet stream that was advanced ends as ``track_windows`` over every window ends it (same
window, same record), the reports stay those of the windows the stream opened, the old
stream's tracks come back at a sensor restart (``StreamStep.tracks``), and a window that lost
events at its first timestamp to ``MAX_ROTOR_EVENTS`` is not measured."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest
from conftest import SMALL_SENSOR, blob_events, small_config
from hypothesis import given, settings
from hypothesis import strategies as st
from test_live import ListSource

import uavsnn.detector
from uavsnn import EVENT_DTYPE, Network
from uavsnn import driver as driver_module
from uavsnn.detector import Detector, _with_rotor
from uavsnn.grouping import _NO_DETECTIONS, WindowGrouper, WindowReport
from uavsnn.tracks import Track, Tracker, track_windows

WINDOW_US = 3_000
HOUR_US = 3_600_000_000


@pytest.fixture(scope="module")
def net() -> Network:
    return Network(small_config(), seed=3)


def opened_windows(net: Network, events: np.ndarray, overlap: float) -> list[WindowReport]:
    """The windows a stream opens (those holding an event), untracked, with the rotor the
    streaming detector measures."""
    plain = Detector(net, window_us=WINDOW_US, overlap=overlap)
    grouper = WindowGrouper.of(plain)
    reports = grouper.add(events, plain.push(events)) + grouper.finish(plain.flush())
    return [_with_rotor(r, [events])[0] for r in reports]


def every_window(opened: list[WindowReport], step: int, last: int) -> list[WindowReport]:
    """``opened`` with the windows between them (and after, up to ``last``) that held no event,
    as the batch path has them: windows without objects."""
    by_index = {r.window: r for r in opened}
    start = opened[0].t0 - opened[0].window * step
    return [
        by_index.get(k)
        or WindowReport(
            k, start + k * step, start + k * step + WINDOW_US, False, _NO_DETECTIONS, ()
        )
        for k in range(last + 1)
    ]


def seen(reports: list[WindowReport]) -> list[tuple[Any, ...]]:
    return [(r.window, r.t0, r.t1, r.detected, r.objects) for r in reports]


def by_id(tracks: list[Track]) -> list[Track]:
    return sorted(tracks, key=lambda t: t.id)


def streamed(det: Detector, events: np.ndarray, cuts: list[int]) -> tuple[list, list[Track]]:
    """The reports of ``events`` pushed in the chunks ``cuts`` makes, and every track, drained
    after each push as a stream's reader drains them."""
    bounds = [0, *sorted(min(c, len(events)) for c in cuts), len(events)]
    reports, tracks = [], []
    for a, b in itertools.pairwise(bounds):
        reports += det.push_windows(events[a:b])
        tracks += det.tracker.drain_ended()
    reports += det.flush_windows()
    return reports, tracks + det.tracker.finish()


# -- a silent gap ----------------------------------------------------------------------------------


def test_a_track_ended_in_a_gap_has_the_batch_record(net: Network) -> None:
    """The stream skips the gap's windows; its record said misses=0, age_windows=5 where the
    batch path, fed every window, says misses=5, age_windows=10."""
    events = blob_events(0, 900)
    events["t"][450:] += np.uint64(40_000)
    det = Detector(net, window_us=WINDOW_US, overlap=0.5, tracker=Tracker(gate_px=8))
    reports, tracks = streamed(det, events, [])
    opened = opened_windows(net, events, 0.5)
    batch = track_windows(every_window(opened, 1_500, opened[-1].window), Tracker(gate_px=8))
    assert by_id(tracks) == list(batch.tracks)
    first = batch.tracks[0]
    assert first.misses == 5 and first.age_windows == first.last_window - first.birth_window + 6
    # The reports are the stream's as before: those of the opened windows tracked alone.
    alone = track_windows(opened, Tracker(gate_px=8))
    assert seen(reports) == seen(list(alone.reports))


@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 2),
    gaps=st.lists(st.tuples(st.integers(1, 2_999), st.integers(0, 40_000)), max_size=4),
    cuts=st.lists(st.integers(0, 3_000), max_size=6),
    overlap=st.sampled_from([0.0, 0.5]),
    max_misses=st.integers(1, 5),
)
def test_stream_tracks_equal_the_batch_tracks_of_every_window(
    net: Network,
    seed: int,
    gaps: list[tuple[int, int]],
    cuts: list[int],
    overlap: float,
    max_misses: int,
) -> None:
    """Random silent gaps, random chunks: every track the stream ends (drained, or at
    finish) is the one ``track_windows`` over every window gives, and every report is the one
    the stream gave before (``track_windows`` over the opened windows alone)."""
    events = blob_events(seed, 3_000)
    for at, length in gaps:
        events["t"][at:] += np.uint64(length)

    def tracker() -> Tracker:
        return Tracker(gate_px=8, max_misses=max_misses)

    det = Detector(net, window_us=WINDOW_US, overlap=overlap, tracker=tracker())
    reports, tracks = streamed(det, events, cuts)
    opened = opened_windows(net, events, overlap)
    every = every_window(opened, det.step_us, opened[-1].window)
    batch = track_windows(every, tracker())
    assert by_id(tracks) == list(batch.tracks)
    assert tracks  # something was tracked
    kept = [r for r in batch.reports if r.window in {o.window for o in opened}]
    assert seen(reports) == seen(kept) == seen(list(track_windows(opened, tracker()).reports))


class CountingTracker(Tracker):
    """A tracker that notes the windows it is fed."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.fed: list[int] = []

    def update(self, report: WindowReport) -> WindowReport:
        self.fed.append(report.window)
        return super().update(report)


def test_a_long_gap_feeds_the_tracker_max_misses_windows_and_one(net: Network) -> None:
    """An hour of silence is 2.4 million windows: the tracker sees the few that can change
    anything (while a track is live), no more."""
    events = blob_events(0, 900)
    events["t"][450:] += np.uint64(HOUR_US)
    tracker = CountingTracker(gate_px=8)
    det = Detector(net, window_us=WINDOW_US, overlap=0.5, tracker=tracker)
    reports, tracks = streamed(det, events, [300, 450, 600])
    skipped = set(tracker.fed) - {r.window for r in reports}
    assert 0 < len(skipped) <= tracker.max_misses + 1
    assert len(tracker.fed) == len(set(tracker.fed))
    ended_in_gap = [t for t in tracks if t.last_window < reports[0].window + 100]
    assert ended_in_gap and all(t.misses == tracker.max_misses for t in ended_in_gap)


# -- a quiet stream, advanced ----------------------------------------------------------------------


def test_advancing_a_quiet_stream_ends_its_tracks_as_the_batch_path(net: Network) -> None:
    """A track live when the stream falls quiet is deleted once max_misses windows have
    passed, as the batch path over those windows deletes it; it stayed live (misses=0) until
    the next event before."""
    events = blob_events(0, 900)
    det = Detector(net, window_us=WINDOW_US, overlap=0.5, tracker=Tracker(gate_px=8))
    got = det.push_windows(events)
    live = {t.id for t in det.tracker.live}
    assert live  # the blob is followed when the stream falls quiet
    quiet = int(events["t"][-1]) + 20 * WINDOW_US
    got += det.advance_windows(quiet)
    ended = det.tracker.drain_ended()
    assert det.tracker.live == () and live <= {t.id for t in ended}
    opened = opened_windows(net, events, 0.5)
    start = int(events["t"][0])
    last = (quiet - start - WINDOW_US) // det.step_us  # the last window ending by then
    batch = track_windows(every_window(opened, det.step_us, last), Tracker(gate_px=8))
    assert by_id(ended) == list(batch.tracks)
    # The reports are those the whole stream gives.
    assert seen(got) == seen(list(track_windows(opened, Tracker(gate_px=8)).reports))
    assert det.flush_windows() == [] and det.tracker.finish() == []


def test_an_hour_of_quiet_ends_the_tracks_at_once(net: Network) -> None:
    events = blob_events(0, 900)
    tracker = CountingTracker(gate_px=8)
    det = Detector(net, window_us=WINDOW_US, overlap=0.5, tracker=tracker)
    det.push_windows(events)
    live = {t.id for t in det.tracker.live}
    before = len(tracker.fed)
    det.advance_windows(int(events["t"][-1]) + HOUR_US)
    assert live and live <= {t.id for t in det.tracker.drain_ended()}
    assert det.tracker.live_count == 0
    assert len(tracker.fed) - before <= 2 + tracker.max_misses + 1  # the last windows, then misses


# -- a sensor restart ------------------------------------------------------------------------------


def test_a_restart_hands_back_the_old_streams_tracks(net: Network) -> None:
    """The reset at a restart forgot the tracks live then: the restarted step carries them
    (with those ended and not drained), as a detector run on the old stream alone ends them."""
    old = blob_events(0, 900)
    old["t"] += np.uint64(HOUR_US)
    new = blob_events(1, 900)
    parts = [*np.array_split(old, 2), *np.array_split(new, 2)]
    det = Detector(net, window_us=WINDOW_US, tracker=Tracker(gate_px=8))
    driver = driver_module.StreamDriver(ListSource(parts, restart_at=2), det, windows=True)
    drained: list[Track] = []
    restarted = None
    new_ids = set()
    for step in driver:
        if step.kind == "restarted":
            restarted = step
        else:
            assert step.tracks == ()
            if restarted is not None:
                new_ids |= {o.track_id for r in step.found for o in r.objects if o.track_id}
        if restarted is None:
            drained += det.tracker.drain_ended()
    assert restarted is not None and restarted.tracks
    alone = Detector(net, window_us=WINDOW_US, tracker=Tracker(gate_px=8))
    _, want = streamed(alone, old, [len(parts[0])])
    assert by_id(drained + list(restarted.tracks)) == by_id(want)
    assert min(new_ids) == 1  # the new stream's ids start again


def test_a_restart_without_windows_carries_no_tracks(net: Network) -> None:
    old = blob_events(0, 600)
    old["t"] += np.uint64(HOUR_US)
    parts = [old, blob_events(1, 600)]
    det = Detector(net, window_us=WINDOW_US)
    steps = list(driver_module.StreamDriver(ListSource(parts, restart_at=1), det))
    assert [s.tracks for s in steps if s.kind == "restarted"] == [()]


# -- events lost to MAX_ROTOR_EVENTS ---------------------------------------------------------------


def same_time_flood(n: int) -> np.ndarray:
    """An event at 0, ``n`` at 3000 (the start of window 1 of 3000 µs windows, overlap 0)
    over every pixel, then events at 3500, 4000 and 6000 (which closes window 1)."""
    width, height = SMALL_SENSOR
    ev = np.zeros(n + 4, EVENT_DTYPE)
    ev["t"] = [0, *[3000] * n, 3500, 4000, 6000]
    i = np.arange(n)
    ev["x"][1 : n + 1] = i % width
    ev["y"][1 : n + 1] = (i // width) % height
    ev["p"][1 : n + 1] = (i // (width * height)) % 2 == 0
    return ev


def window_one(net: Network, chunks: list[np.ndarray]) -> WindowReport:
    det = Detector(net, window_us=WINDOW_US, overlap=0.0)
    reports = [r for c in chunks for r in det.push_windows(c)] + det.flush_windows()
    (one,) = [r for r in reports if r.window == 1]
    assert one.objects  # the flood is detected
    return one


@pytest.mark.parametrize("cut", [None, 2_000, 64])
def test_a_window_that_lost_events_at_its_first_time_is_not_measured(
    net: Network, monkeypatch: pytest.MonkeyPatch, cut: int | None
) -> None:
    """The buffer's cap dropped some of the events at 3000, window 1's start; the window was
    measured on the rest (its rotor, counts and score from a part of it). The cap shrunk to
    3000 events: the chunk over it whole, or its head trimmed."""
    monkeypatch.setattr(uavsnn.detector, "MAX_ROTOR_EVENTS", 3_000)
    events = same_time_flood(3_500)
    chunks = [events] if cut is None else [events[:cut], events[cut:]]
    one = window_one(net, chunks)
    assert all(o.rotor is None and o.counts is None for o in one.objects)


def test_a_window_that_lost_events_to_the_full_cap_is_not_measured(net: Network) -> None:
    """The walk's construction at the real cap (about 2 million events)."""
    one = window_one(net, [same_time_flood(uavsnn.detector.MAX_ROTOR_EVENTS + 5_000)])
    assert all(o.rotor is None and o.counts is None for o in one.objects)


def test_a_window_that_kept_its_events_is_still_measured(
    net: Network, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(uavsnn.detector, "MAX_ROTOR_EVENTS", 3_000)
    one = window_one(net, [same_time_flood(2_900)])
    assert one.objects[0].counts is not None
