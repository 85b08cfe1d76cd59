"""Tracks: the merged objects of each window linked from window to window.

A :class:`Tracker` is fed one :class:`~uavsnn.grouping.WindowReport` at a time, in window order,
and returns it with each object's ``track_id`` filled in. :func:`track_windows` runs the same
tracker over a whole sequence of reports (the batch path): both give the same tracks, since the
batch path is the streaming one in a loop. The model, the assignment rule, confirmation,
deletion and the path statistics are described in docs/identification.md ("Tracks").

    >>> tracker = Tracker()
    >>> for report in reports:               # WindowReports, in window order
    ...     report = tracker.update(report)  # objects now carry track_id
    ...     ended = tracker.drain_ended()    # tracks deleted by this window
    >>> tracker.finish()                     # end the stream: every live track

State is bounded: at most ``max_tracks`` live tracks, each of a fixed size (running sums, no
history), and tracks are deleted after ``max_misses`` windows without a detection.
"""

from __future__ import annotations

import copy
import inspect
import math
import numbers
import threading
from collections import deque
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from uavsnn._validate import check_int, check_real
from uavsnn.errors import ParameterError
from uavsnn.features import activity

if TYPE_CHECKING:
    from uavsnn.grouping import WindowReport
    from uavsnn.network import Network

__all__ = [
    "DEFAULT_GATE_PX",
    "GATE_SHARE",
    "MAX_ENDED",
    "MAX_TRACKS_LIMIT",
    "Track",
    "TrackResult",
    "Tracker",
    "track_windows",
    "tracker_for",
]

#: The gate of :meth:`Tracker.for_sensor`, a share of the sensor's width: 24 px at 240×180,
#: 64 px at 640×480, 128 px at 1280×720. The scenes draw the field of view in degrees whatever
#: the sensor, so an object crosses the same share of the width per window at every size; a
#: gate fixed in pixels would split the tracks of a finer sensor (docs/identification.md,
#: "The gate scales with the sensor"). A network runs with the gate its identification was
#: fitted with when its model file records one (:func:`tracker_for`).
GATE_SHARE = 0.1
#: A :class:`Tracker`'s gate when none is given: :data:`GATE_SHARE` of a 240×180 sensor, the
#: gate every sensor size was fitted at before the gate scaled with the sensor.
DEFAULT_GATE_PX = 24.0

#: The cap ``max_tracks`` may not exceed (each live track is a few hundred bytes; the
#: assignment is greedy over at most ``max_tracks × objects`` pairs per window).
MAX_TRACKS_LIMIT = 4096
#: Deleted tracks a :class:`Tracker` holds until :meth:`Tracker.drain_ended` takes them; beyond
#: that the oldest are dropped (counted in :attr:`Tracker.ended_dropped`), so a stream nobody
#: drains stays bounded.
MAX_ENDED = 4096
#: Segments shorter than this (px) carry no heading: they do not count in the turn rate.
MIN_TURN_SEGMENT_PX = 1.0


@dataclass(frozen=True)
class Track:
    """A snapshot of one track. Times are µs of event time, positions sensor pixels; ``y``
    grows downwards, so a positive ``vy`` (or ``vertical_speed``) means moving down.

    Attributes:
        id: the track id, from 1 up, never reused in a stream.
        confirmed: it has reached ``confirm_hits`` hits within ``confirm_windows`` windows.
        birth_window, birth_us: the window of its first detection, and that window's start.
        last_window, last_update_us: the window of its latest detection, and that window's end.
        first_alarm_us: end of the window whose detection confirmed it (``None`` until then):
            the earliest event time at which a stream can announce it.
        first_alarm_window: that window's index.
        age_windows, age_us: windows from its birth window to the latest window fed
            (inclusive), and the time from ``birth_us`` to that window's end.
        hits: windows with a detection assigned to it; misses: consecutive windows without
            one since its latest hit.
        box: the latest detection's box ``(x0, y0, x1, y1)``.
        position: the filtered centre ``(x, y)`` at its latest update.
        velocity: the filtered velocity ``(vx, vy)`` in px/s (0 until a second hit).
        speed: the length of ``velocity`` (px/s).
        path_length: the sum of the distances between successive detection centres (px).
        straightness: the distance from first to latest centre over ``path_length``, in
            ``[0, 1]`` (1: a straight line; 0 with no path).
        horizontal_speed, vertical_speed: the displacement from first to latest centre over
            the time between them (px/s; signed).
        mean_speed, speed_std: the mean and (population) standard deviation of the segment
            speeds (px/s).
        turn_rate: the mean absolute change of heading between successive segments of at
            least :data:`MIN_TURN_SEGMENT_PX`, per second of the second segment (rad/s).
        rotor_measured: its detections whose rotor signature was measured (the object's
            ``rotor`` was not ``None``).
        rotor_strength_mean: the mean rotor strength of those detections (0 without one).
        activity_measured: its detections whose event counts were measured (the object's
            ``counts`` was not ``None``; measured with the rotor).
        events_per_px_mean, events_per_px_std: the mean and (population) standard deviation
            of those detections' raw events per pixel of their box, log-scaled as an object's
            feature (:func:`uavsnn.features.activity`; 0 without one).
        on_balance_mean, rate_swing_mean: the mean of their ON/OFF balance and of their rate
            swing (log), the same way (0 without one).
    """

    id: int
    confirmed: bool
    birth_window: int
    birth_us: int
    last_window: int
    last_update_us: int
    first_alarm_us: int | None
    first_alarm_window: int | None
    age_windows: int
    age_us: int
    hits: int
    misses: int
    box: tuple[int, int, int, int]
    position: tuple[float, float]
    velocity: tuple[float, float]
    speed: float
    path_length: float
    straightness: float
    horizontal_speed: float
    vertical_speed: float
    mean_speed: float
    speed_std: float
    turn_rate: float
    rotor_measured: int
    rotor_strength_mean: float
    activity_measured: int
    events_per_px_mean: float
    events_per_px_std: float
    on_balance_mean: float
    rate_swing_mean: float


class _Live:
    """A live track's state: fixed size (no history beyond the last hits' window mask)."""

    __slots__ = (
        "act_n",
        "alarm_us",
        "alarm_window",
        "balance_sum",
        "birth_sum",
        "birth_us",
        "birth_window",
        "box",
        "confirmed",
        "density_m2",
        "density_mean",
        "first_z",
        "heading",
        "hits",
        "id",
        "last_end",
        "last_sum",
        "last_window",
        "last_z",
        "n_seg",
        "n_turn",
        "now_end",
        "now_window",
        "path",
        "pos",
        "recent",
        "rotor_n",
        "rotor_sum",
        "sp_m2",
        "sp_mean",
        "swing_sum",
        "turn_sum",
        "vel",
    )

    def __init__(
        self, tid: int, window: int, t0: int, t1: int, obj: Any, z: tuple, act: tuple | None
    ) -> None:
        box = obj.box
        self.id = tid
        self.birth_window = window
        self.birth_us = t0
        self.birth_sum = t0 + t1  # twice the window's centre time, exact
        self.first_z = z
        self.last_window = window
        self.last_end = t1
        self.last_sum = self.birth_sum
        self.last_z = z
        self.box = box
        self.pos = z
        self.vel = (0.0, 0.0)
        self.hits = 1
        self.recent = 1  # bit i: a hit i windows before the latest window fed
        self.confirmed = False
        self.alarm_us: int | None = None
        self.alarm_window: int | None = None
        self.path = 0.0
        self.n_seg = 0
        self.sp_mean = 0.0
        self.sp_m2 = 0.0
        self.heading: float | None = None
        self.turn_sum = 0.0
        self.n_turn = 0
        self.now_window = window
        self.now_end = t1
        self.rotor_n = 0
        self.rotor_sum = 0.0
        self.act_n = 0
        self.density_mean = 0.0
        self.density_m2 = 0.0
        self.balance_sum = 0.0
        self.swing_sum = 0.0
        self.add_measured(obj.rotor, act)

    def add_measured(self, rotor: Any, act: tuple | None) -> None:
        """Count an object's rotor and its activity (:func:`uavsnn.features.activity` of its
        counts), where measured, in the running sums."""
        if rotor is not None:
            self.rotor_n += 1
            self.rotor_sum += float(rotor.strength)
        if act is not None:
            density, balance, swing = act
            self.act_n += 1
            delta = density - self.density_mean  # Welford's running mean and variance
            self.density_mean += delta / self.act_n
            self.density_m2 += delta * (density - self.density_mean)
            self.balance_sum += balance
            self.swing_sum += swing

    def predict(self, t_sum: int) -> tuple[float, float]:
        """The centre predicted at the window whose ``t0 + t1`` is ``t_sum``."""
        dt = _seconds(t_sum, self.last_sum)
        return self.pos[0] + self.vel[0] * dt, self.pos[1] + self.vel[1] * dt

    def snapshot(self) -> Track:
        dx = self.last_z[0] - self.first_z[0]
        dy = self.last_z[1] - self.first_z[1]
        span = _seconds(self.last_sum, self.birth_sum)
        net = math.hypot(dx, dy)
        return Track(
            id=self.id,
            confirmed=self.confirmed,
            birth_window=self.birth_window,
            birth_us=self.birth_us,
            last_window=self.last_window,
            last_update_us=self.last_end,
            first_alarm_us=self.alarm_us,
            first_alarm_window=self.alarm_window,
            age_windows=self.now_window - self.birth_window + 1,
            age_us=self.now_end - self.birth_us,
            hits=self.hits,
            misses=self.now_window - self.last_window,
            box=self.box,
            position=self.pos,
            velocity=self.vel,
            speed=math.hypot(*self.vel),
            path_length=self.path,
            straightness=min(net / self.path, 1.0) if self.path > 0 else 0.0,
            horizontal_speed=dx / span if span > 0 else 0.0,
            vertical_speed=dy / span if span > 0 else 0.0,
            mean_speed=self.sp_mean,
            speed_std=math.sqrt(self.sp_m2 / self.n_seg) if self.n_seg else 0.0,
            turn_rate=self.turn_sum / self.n_turn if self.n_turn else 0.0,
            rotor_measured=self.rotor_n,
            rotor_strength_mean=self.rotor_sum / self.rotor_n if self.rotor_n else 0.0,
            activity_measured=self.act_n,
            events_per_px_mean=self.density_mean,
            events_per_px_std=math.sqrt(max(self.density_m2, 0.0) / self.act_n)
            if self.act_n
            else 0.0,
            on_balance_mean=self.balance_sum / self.act_n if self.act_n else 0.0,
            rate_swing_mean=self.swing_sum / self.act_n if self.act_n else 0.0,
        )


def check_gate(value: Any, name: str = "gate_px") -> float:
    """A tracker's gate (px): a finite number > 0 (a NumPy number too), as ``float``.

    Raises:
        ParameterError: anything else, named ``name``.
    """
    return check_real(name, value, low=0.0, low_open=True)


def _seconds(later_sum: int, earlier_sum: int) -> float:
    """The time (s) between the centres of two windows, each given as ``t0 + t1`` (µs):
    from integers, so that two distinct centres are never one float (the centres of windows
    late in a stream, ``(t0 + t1) / 2`` as floats, could round to the same value)."""
    return (later_sum - earlier_sum) / 2 / 1e6


def _check_box(what: str, box: Any) -> None:
    """Refuse the box of an object (``what``: which, for the message) unless it is four finite
    numbers ``(x0, y0, x1, y1)`` with ``x0 <= x1`` and ``y0 <= y1`` (an empty box, ``x0 ==
    x1``, is kept: the tracker needs its centre only).

    Raises:
        ParameterError: anything else.
    """
    try:
        sides = tuple(box)
    except TypeError:
        sides = ()
    finite = len(sides) == 4 and all(
        isinstance(v, numbers.Real)
        and not isinstance(v, (bool, np.bool_))
        and (isinstance(v, numbers.Integral) or math.isfinite(v))
        for v in sides
    )
    if not (finite and sides[0] <= sides[2] and sides[1] <= sides[3]):
        raise ParameterError(
            f"{what}: a box must be four finite numbers (x0, y0, x1, y1) with x0 <= x1 and "
            f"y0 <= y1, got {box!r}"
        )


def _iou(a: tuple, b: tuple) -> float:
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    if w <= 0 or h <= 0:
        return 0.0
    inter = w * h
    return inter / ((a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter)


class Tracker:
    """Link the objects of successive windows into tracks (constant velocity, greedy gating).

    Args:
        gate_px: the largest distance (px) between a track's predicted centre and an object's
            centre for them to be linked (default :data:`DEFAULT_GATE_PX`, 24, the gate of a
            240×180 sensor; a network's tracker takes its gate from :func:`tracker_for`: the
            one its identification was fitted with, else its sensor's, :meth:`for_sensor`).
        alpha, beta: the position and velocity gains of the constant-velocity (alpha-beta)
            filter, in ``(0, 1]`` (defaults 0.6 and 0.3).
        confirm_hits, confirm_windows: a track is confirmed when it has hits in at least
            ``confirm_hits`` of the last ``confirm_windows`` windows, its birth window
            included (default 3 of 5; at most 64 windows).
        max_misses: a track is deleted after this many consecutive windows without a hit
            (default 5).
        max_tracks: the most live tracks (default 64, at most :data:`MAX_TRACKS_LIMIT`);
            an object that would start a track beyond it gets none (``track_id`` stays
            ``None``) and is counted in :attr:`births_refused`.

    One tracker may serve several threads (a :class:`~uavsnn.detector.Detector`'s
    ``push_windows`` feeding it while another thread drains it): :meth:`update`,
    :meth:`drain_ended`, :meth:`finish`, :meth:`reset` and :attr:`live` each run whole under the
    tracker's lock, so every deleted track is drained exactly once. The windows must still come
    in order, so one thread feeds it.

    Raises:
        ParameterError: a parameter out of range or of the wrong type.
    """

    def __init__(
        self,
        *,
        gate_px: float = DEFAULT_GATE_PX,
        alpha: float = 0.6,
        beta: float = 0.3,
        confirm_hits: int = 3,
        confirm_windows: int = 5,
        max_misses: int = 5,
        max_tracks: int = 64,
    ) -> None:
        gate = check_gate(gate_px)
        alpha = check_real("alpha", alpha, low=0.0, low_open=True, high=1.0)
        beta = check_real("beta", beta, low=0.0, low_open=True, high=1.0)
        confirm_hits = check_int("confirm_hits", confirm_hits, 1)
        confirm_windows = check_int("confirm_windows", confirm_windows, 1)
        max_misses = check_int("max_misses", max_misses, 1)
        max_tracks = check_int("max_tracks", max_tracks, 1)
        if confirm_windows > 64 or confirm_hits > confirm_windows:
            raise ParameterError(
                f"confirm_hits <= confirm_windows <= 64 needed, got {confirm_hits} of "
                f"{confirm_windows}"
            )
        if max_tracks > MAX_TRACKS_LIMIT:
            raise ParameterError(f"max_tracks must be at most {MAX_TRACKS_LIMIT}, got {max_tracks}")
        self.gate_px = gate
        self.alpha = alpha
        self.beta = beta
        self.confirm_hits = confirm_hits
        self.confirm_windows = confirm_windows
        self.max_misses = max_misses
        self.max_tracks = max_tracks
        # Held by each call that reads or changes the tracks (not by __repr__, which must
        # not wait); never while calling out of the tracker, so it cannot deadlock.
        self._lock = threading.Lock()
        self.reset()

    def __getstate__(self) -> dict[str, Any]:
        """A copy or a pickle (a process pool's, ``copy.deepcopy``): the state as it stands
        between two calls, without the lock, which cannot be copied."""
        with self._lock:
            state = self.__dict__.copy()
        del state["_lock"]
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()

    @classmethod
    def for_sensor(cls, width: int, **kwargs: Any) -> Tracker:
        """The tracker of a sensor ``width`` pixels wide: its gate is :data:`GATE_SHARE` of the
        width; ``kwargs`` are the other arguments of :class:`Tracker`.

        Raises:
            ParameterError: ``width`` is not an integer in ``[1, 65535]`` (a sensor's side; a
                NumPy integer too), ``kwargs`` names ``gate_px`` or no argument of
                :class:`Tracker`, or another argument is out of range.
        """
        width = check_int("width", width, 1, 65535)
        _check_others("for_sensor", "the width", kwargs)
        return cls(gate_px=GATE_SHARE * width, **kwargs)

    def reset(self) -> None:
        """Forget every track; ids start from 1 again."""
        with self._lock:
            self._reset()

    def _reset(self) -> None:
        self._live: list[_Live] = []
        self._ended: deque[Track] = deque(maxlen=MAX_ENDED)
        self._next_id = 1
        self._last_window: int | None = None
        self._last_sum: int | None = None  # the latest window's t0 + t1
        self.births_refused = 0
        self.ended_dropped = 0

    # ------------------------------------------------------------------ the stream

    def update(self, report: WindowReport) -> WindowReport:
        """Feed the next window (window indices must increase) and return it with each
        object's ``track_id``, ``track_confirmed`` and ``track`` (a snapshot of its track as
        it stands after this window: what is known of it so far) filled in. An object's
        ``rotor`` and ``counts`` (when measured) count in its track's ``rotor_strength_mean``
        and activity history.

        The times of a window must be integers ``0 <= t0 < t1``, and its centre
        ``(t0 + t1) / 2`` later than the previous window's: the speeds are displacements over
        the time between window centres.

        Raises:
            ParameterError: a window index that is not an integer >= 0 or not later than the
                previous one, times that are not integers ``0 <= t0 < t1``, a centre not
                later than the previous window's, an object that is not a
                :class:`~uavsnn.grouping.WindowObject`, a box that is not four finite numbers
                ``(x0, y0, x1, y1)`` with ``x0 <= x1`` and ``y0 <= y1``, or an object whose
                ``counts`` no box gives (:func:`uavsnn.features.activity`); the tracker is
                then as it was.
        """
        with self._lock:
            return self._update(report)

    def _update(self, report: WindowReport) -> WindowReport:
        from uavsnn.grouping import WindowObject, WindowReport

        if not isinstance(report, WindowReport):
            raise ParameterError(f"a tracker takes WindowReports, got {report!r}")
        k = check_int("a window's index", report.window)
        if self._last_window is not None and k <= self._last_window:
            raise ParameterError(
                f"windows must be fed in increasing order: {k} after {self._last_window}"
            )
        t0 = check_int(f"window {k}'s t0", report.t0)
        t1 = check_int(f"window {k}'s t1", report.t1)
        if t1 <= t0:
            raise ParameterError(f"window {k} must end after it starts, got [{t0}, {t1}) µs")
        t_sum = t0 + t1
        if self._last_sum is not None and t_sum <= self._last_sum:
            raise ParameterError(
                f"window {k}'s centre ({t_sum / 2} µs) must be later than the previous "
                f"window's ({self._last_sum / 2} µs): speeds are measured between centres"
            )
        objects = report.objects
        for i, o in enumerate(objects):
            if not isinstance(o, WindowObject):
                raise ParameterError(f"object {i} of window {k} must be a WindowObject, got {o!r}")
            _check_box(f"object {i} of window {k}", o.box)
        acts = [None if o.counts is None else activity(o.box, o.counts) for o in objects]
        self._last_window, self._last_sum = k, t_sum
        # Deletion first: a track missing max_misses windows by this one is gone.
        keep = []
        for tr in self._live:
            if k - tr.last_window > self.max_misses:
                if len(self._ended) == MAX_ENDED:
                    self.ended_dropped += 1
                self._ended.append(tr.snapshot())
            else:
                keep.append(tr)
        self._live = keep
        centres = [o.centre for o in objects]
        # Candidate pairs inside the gate, cheapest first; ties by track id, then object.
        pairs = []
        for ti, tr in enumerate(self._live):
            px, py = tr.predict(t_sum)
            for oi, (cx, cy) in enumerate(centres):
                d = math.hypot(cx - px, cy - py)
                if d <= self.gate_px:
                    pairs.append((d, -_iou(tr.box, objects[oi].box), tr.id, oi, ti))
        pairs.sort()
        track_of: list[_Live | None] = [None] * len(objects)
        taken: set[int] = set()
        for _d, _iou_neg, _tid, oi, ti in pairs:
            if track_of[oi] is None and ti not in taken:
                track_of[oi] = self._live[ti]
                taken.add(ti)
        for tr in self._live:  # the window mask moves on for every live track
            # by at most its width: a longer shift (max_misses allows any) is as many bits lost
            shift = min(k - tr.now_window, self.confirm_windows)
            tr.recent = (tr.recent << shift) & ((1 << self.confirm_windows) - 1)
            tr.now_window, tr.now_end = k, t1
        for oi, obj in enumerate(objects):
            old = track_of[oi]
            if old is not None:
                self._hit(old, k, t1, t_sum, obj.box, centres[oi])
                old.add_measured(obj.rotor, acts[oi])
            elif len(self._live) < self.max_tracks:
                new = _Live(self._next_id, k, t0, t1, obj, centres[oi], acts[oi])
                self._next_id += 1
                self._live.append(new)
                track_of[oi] = new
                self._confirm(new, k, t1)
            else:
                self.births_refused += 1
        new_objects = tuple(
            o
            if t is None
            else replace(o, track_id=t.id, track_confirmed=t.confirmed, track=t.snapshot())
            for o, t in zip(objects, track_of, strict=True)
        )
        return replace(report, objects=new_objects)

    def _hit(self, tr: _Live, k: int, t1: int, t_sum: int, box: tuple, z: tuple) -> None:
        dt = _seconds(t_sum, tr.last_sum)
        seg = math.hypot(z[0] - tr.last_z[0], z[1] - tr.last_z[1])
        if tr.hits == 1:  # the second hit: the first velocity is the displacement
            tr.vel = ((z[0] - tr.pos[0]) / dt, (z[1] - tr.pos[1]) / dt)
            tr.pos = z
        else:
            px, py = tr.predict(t_sum)
            rx, ry = z[0] - px, z[1] - py
            tr.pos = (px + self.alpha * rx, py + self.alpha * ry)
            tr.vel = (tr.vel[0] + self.beta * rx / dt, tr.vel[1] + self.beta * ry / dt)
        # Path statistics: running sums only.
        tr.path += seg
        speed = seg / dt
        tr.n_seg += 1
        delta = speed - tr.sp_mean
        tr.sp_mean += delta / tr.n_seg
        tr.sp_m2 += delta * (speed - tr.sp_mean)
        if seg >= MIN_TURN_SEGMENT_PX:
            heading = math.atan2(z[1] - tr.last_z[1], z[0] - tr.last_z[0])
            if tr.heading is not None:
                turn = abs((heading - tr.heading + math.pi) % (2 * math.pi) - math.pi)
                tr.turn_sum += turn / dt
                tr.n_turn += 1
            tr.heading = heading
        tr.hits += 1
        tr.last_window, tr.last_end, tr.last_sum, tr.last_z, tr.box = k, t1, t_sum, z, box
        tr.recent |= 1
        self._confirm(tr, k, t1)

    def _confirm(self, tr: _Live, k: int, t1: int) -> None:
        if not tr.confirmed and bin(tr.recent).count("1") >= self.confirm_hits:
            tr.confirmed = True
            tr.alarm_us, tr.alarm_window = t1, k

    def drain_ended(self) -> list[Track]:
        """The tracks deleted since the last call (in deletion order, at most
        :data:`MAX_ENDED`), forgotten here."""
        with self._lock:
            return self._drain()

    def _drain(self) -> list[Track]:
        out = list(self._ended)
        self._ended.clear()
        return out

    def finish(self) -> list[Track]:
        """End the stream: every track deleted and not yet drained, then every live track
        (by id); the tracker is empty afterwards, and ids go on from where they were."""
        with self._lock:
            out = self._drain() + [tr.snapshot() for tr in self._live]
            self._live = []
            self._last_window = self._last_sum = None
        return out

    @property
    def live(self) -> tuple[Track, ...]:
        """Snapshots of the live tracks, by id."""
        with self._lock:
            return tuple(tr.snapshot() for tr in self._live)

    @property
    def live_count(self) -> int:
        """How many tracks are live: ``len(live)``, without taking their snapshots."""
        return len(self._live)

    def __repr__(self) -> str:
        return (
            f"Tracker(gate_px={self.gate_px}, confirm={self.confirm_hits}/"
            f"{self.confirm_windows}, max_misses={self.max_misses}, "
            f"max_tracks={self.max_tracks}, live={len(self._live)})"
        )


@dataclass(frozen=True)
class TrackResult:
    """What :func:`track_windows` returns: the reports with track ids, and every track."""

    reports: tuple[WindowReport, ...]
    #: Every track of the sequence, by id (live ones as they stood after the last window).
    tracks: tuple[Track, ...]


def _check_others(call: str, source: str, kwargs: Mapping[str, Any]) -> None:
    """Refuse ``kwargs`` of ``call`` that name ``gate_px`` (set from ``source``) or no argument
    of :class:`Tracker` (a ``TypeError`` of its ``__init__`` otherwise)."""
    if "gate_px" in kwargs:
        raise ParameterError(f"{call} sets gate_px from {source}; use Tracker(gate_px=)")
    unknown = set(kwargs) - set(inspect.signature(Tracker).parameters)
    if unknown:
        raise ParameterError(f"unknown Tracker arguments {sorted(unknown)}")


def tracker_for(network: Network, **kwargs: Any) -> Tracker:
    """The tracker ``network`` runs with, the one place that says which: the gate its
    identification's track features were fitted with when its model records one
    (:attr:`uavsnn.identifier.Identifier.gate_px`), else :meth:`Tracker.for_sensor` of its
    width (a network without identification, or a model written before uavsnn recorded the
    gate); ``kwargs`` are the other arguments of :class:`Tracker`. The ``Detector``,
    ``window_features``, ``uavsnn evaluate``, ``uavsnn detect`` and the false-alarm streams
    build their tracker here.

    Raises:
        ParameterError: ``kwargs`` names ``gate_px`` or no argument of :class:`Tracker`, or
            another argument is out of range.
    """
    _check_others("tracker_for", "the network", kwargs)
    ident = network.identification
    gate = None if ident is None else ident.gate_px
    if gate is None:
        return Tracker.for_sensor(int(network.config["width"]), **kwargs)
    return Tracker(gate_px=gate, **kwargs)


def track_windows(reports: Iterable[WindowReport], tracker: Tracker | None = None) -> TrackResult:
    """The batch path: run a :class:`Tracker` (a fresh default one unless given) over window
    reports in window order; the same code as the streaming path, so the same tracks.

    Raises:
        ParameterError: ``reports`` is not an iterable of WindowReports, ``tracker`` not a
            :class:`Tracker`, or a report :meth:`Tracker.update` refuses; a given ``tracker``
            is then as it was before the call (the run works on a copy of it).
    """
    given = Tracker() if tracker is None else tracker
    if not isinstance(given, Tracker):
        raise ParameterError(f"tracker must be a Tracker, got {given!r}")
    try:
        each = iter(reports)
    except TypeError as err:
        raise ParameterError(
            f"reports must be an iterable of WindowReports, got {reports!r}"
        ) from err
    work = given if tracker is None else copy.deepcopy(given)
    out, tracks = [], []
    for r in each:
        out.append(work.update(r))
        tracks += work.drain_ended()
    tracks = sorted(tracks + work.finish(), key=lambda t: t.id)
    if work is not given:  # the given tracker takes the run once all of it went through
        state = work.__getstate__()  # its own lock stays its own
        with given._lock:
            given.__dict__.update(state)
    return TrackResult(reports=tuple(out), tracks=tuple(tracks))
