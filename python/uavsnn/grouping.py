"""Window reports: a :class:`~uavsnn.detector.Detector`'s spikes grouped by window.

:class:`WindowGrouper` turns the detector's conv3 spikes into one :class:`WindowReport` per
window (the paper's decision, and the spikes' causal boxes merged into :class:`WindowObject`
by :func:`merge_boxes`), which is what ``uavsnn detect`` prints (its JSON line is
:meth:`WindowReport.to_dict`); the detector's :meth:`~uavsnn.detector.Detector.push_windows`
fills each object's rotor signature, track and identification. :mod:`uavsnn.features` merges a
dataset's windows with the same rule, so batch and streaming see the same objects. Every name
here is also reachable from :mod:`uavsnn.detector`, where it lived before.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from uavsnn._jsonout import strict
from uavsnn._validate import MAX_TIME_US, check_int
from uavsnn.errors import ParameterError, ShapeError
from uavsnn.events import EVENT_DTYPE
from uavsnn.network import WINDOW_DETECTION_DTYPE

if TYPE_CHECKING:
    from uavsnn.detector import Detector
    from uavsnn.signature import RotorEstimate
    from uavsnn.tracks import Track

__all__ = ["WindowGrouper", "WindowObject", "WindowReport", "merge_boxes"]

_NO_DETECTIONS = np.empty(0, dtype=WINDOW_DETECTION_DTYPE)
_NO_DETECTIONS.flags.writeable = False


@dataclass(frozen=True)
class WindowObject:
    """One merged box of a window (see :func:`merge_boxes`), its track and rotor signature
    (filled by :meth:`Detector.push_windows <uavsnn.detector.Detector.push_windows>`; ``None``
    when not measured), and the identification's UAV score and class guess
    (:meth:`uavsnn.identify.Identifier.guess`: ``"uav"``, or the likeliest other class,
    ``"other"`` for a model without a class part), for the object and for its track so far
    (filled by ``push_windows`` when the model has identification and the rotor was measured,
    else ``None``; the score uses the track as it stands after this window)."""

    #: ``(x0, y0, x1, y1)``, half-open sensor pixels (``x0 <= x < x1``).
    box: tuple[int, int, int, int]
    #: conv3 spikes whose causal boxes were merged into this one.
    spikes: int
    uav_score: float | None = None
    class_guess: str | None = None
    track_id: int | None = None
    #: Whether the track (:class:`uavsnn.tracks.Tracker`) was confirmed by this window.
    track_confirmed: bool | None = None
    #: The rotor signature of the window's raw events inside :attr:`box`
    #: (:func:`uavsnn.signature.rotor_signature`), whether detected or not; ``None`` when not
    #: measured (see :data:`uavsnn.detector.MAX_ROTOR_BOXES` and ``MAX_ROTOR_EVENTS``).
    rotor: RotorEstimate | None = None
    #: The object's track as it stands after this window (:meth:`uavsnn.tracks.Tracker.update`:
    #: its age, hits, speed and path so far); ``None`` without a track.
    track: Track | None = None
    #: The mean UAV score of the track's scored objects so far, this one included (the
    #: track-level rule of :mod:`uavsnn.track_eval` compares it with the threshold).
    track_score: float | None = None
    #: The object's probability of each class of the model's class part
    #: (:attr:`uavsnn.identify.Identifier.classes`; empty without one).
    class_probabilities: tuple[float, ...] | None = None
    #: The track's class guess: :attr:`track_score` and the mean class probabilities of its
    #: scored objects so far, through :meth:`uavsnn.identify.Identifier.guess_from`.
    track_class: str | None = None
    #: Measured with :attr:`rotor`: ``(events, on, rate_swing)``, the window's raw events inside
    #: :attr:`box`, the ON ones among them and how strongly their rate swings
    #: (:func:`uavsnn.signature.measure_box`); they count in its track's activity history.
    counts: tuple[int, int, float] | None = None

    @property
    def centre(self) -> tuple[float, float]:
        """The middle of :attr:`box` (it always lies inside the box)."""
        x0, y0, x1, y1 = self.box
        return (x0 + x1) / 2, (y0 + y1) / 2

    def to_dict(self, classes: Iterable[str] = ()) -> dict[str, Any]:
        """The object as ``uavsnn detect --json`` prints it (docs/streaming.md, "What
        ``uavsnn detect`` prints"): ``box``, ``centre``, ``spikes``, ``uav_score``, ``class``
        (:attr:`class_guess`), ``class_probabilities`` (:attr:`class_probabilities` by class
        name, ``None`` when not scored or when ``classes`` does not name each of them),
        ``track`` (:attr:`track_id`), ``track_confirmed``, ``track_score``, ``track_class``,
        ``track_stats`` (:attr:`track`'s figures, ``None`` without a track) and ``rotor``
        (``frequency_hz``, ``strength``, ``pixels``; ``None`` unless detected). Plain Python
        values only (a figure that is not finite is ``None``), ready for :func:`json.dumps`.

        Args:
            classes: the names of the class probabilities, in order: the model's
                :attr:`uavsnn.identify.Identifier.classes` (``network.identification.classes``).

        Raises:
            ParameterError: ``classes`` that is not an iterable of class names (``str``).
        """
        return self._dict(_class_names(classes))

    def _dict(self, classes: tuple[str, ...]) -> dict[str, Any]:
        x0, y0, x1, y1 = (int(v) for v in self.box)
        probs = self.class_probabilities
        return strict(
            {
                "box": [x0, y0, x1, y1],
                "centre": [(x0 + x1) / 2, (y0 + y1) / 2],
                "spikes": int(self.spikes),
                "uav_score": _maybe(float, self.uav_score),
                "class": _maybe(str, self.class_guess),
                "class_probabilities": (
                    {c: float(v) for c, v in zip(classes, probs, strict=True)}
                    if probs and len(probs) == len(classes)
                    else None
                ),
                "track": _maybe(int, self.track_id),
                "track_confirmed": _maybe(bool, self.track_confirmed),
                "track_score": _maybe(float, self.track_score),
                "track_class": _maybe(str, self.track_class),
                "track_stats": None if self.track is None else _track_dict(self.track),
                "rotor": _rotor_dict(self.rotor),
            }
        )


@dataclass(frozen=True)
class WindowReport:
    """The decision of one window ``[t0, t1)``: its conv3 spikes, merged into objects."""

    window: int
    t0: int
    t1: int
    #: At least ``min_detections`` conv3 spikes (the paper's rule, docs/model.md §5).
    detected: bool
    #: The window's spikes, as :meth:`~uavsnn.detector.Detector.push` returned them, in time order.
    detections: np.ndarray
    objects: tuple[WindowObject, ...]
    #: The stream the window belongs to: 0 for the first, one more after each
    #: :meth:`Detector.reset() <uavsnn.detector.Detector.reset>` (a sensor restart, which
    #: :class:`~uavsnn.driver.StreamDriver` and ``uavsnn detect`` meet with one). Window
    #: numbers and track ids start again in each, so ``(run, window)`` and ``(run, track)``
    #: name a window and a track over a whole session.
    run: int = 0

    @property
    def spikes(self) -> int:
        """Number of conv3 spikes in the window."""
        return len(self.detections)

    def to_dict(self, classes: Iterable[str] = ()) -> dict[str, Any]:
        """The window as ``uavsnn detect --json`` prints it, one line of it
        (docs/streaming.md, "What ``uavsnn detect`` prints"): ``window``, ``run``, ``t0``,
        ``t1``, ``detected``, ``spikes`` and ``objects``, each object's :meth:`WindowObject.to_dict`
        (:attr:`detections` themselves are left out). Plain Python values only, ready for
        :func:`json.dumps`.

        Args:
            classes: the names of the objects' class probabilities, in order: the model's
                :attr:`uavsnn.identify.Identifier.classes` (``network.identification.classes``;
                ``()`` for a model without identification).

        Raises:
            ParameterError: ``classes`` that is not an iterable of class names (``str``).
        """
        names = _class_names(classes)
        return {
            "window": int(self.window),
            "run": int(self.run),
            "t0": int(self.t0),
            "t1": int(self.t1),
            "detected": bool(self.detected),
            "spikes": self.spikes,
            "objects": [o._dict(names) for o in self.objects],
        }


def _class_names(classes: Any) -> tuple[str, ...]:
    """``classes`` as a tuple of class names, or a :class:`ParameterError` (a single ``str`` is
    refused: it would name a class a letter)."""
    names = None
    if not isinstance(classes, (str, bytes)):
        try:
            names = tuple(classes)
        except TypeError:
            pass
    if names is None or not all(isinstance(c, str) for c in names):
        raise ParameterError(
            f"classes must be an iterable of class names (str), as "
            f"network.identification.classes, got {classes!r}"
        )
    return tuple(str(c) for c in names)


def _maybe(kind: Any, value: Any) -> Any:
    """``value`` as ``kind`` (``int``, ``float``, ``bool``, ``str``: a NumPy scalar as the plain
    value), ``None`` kept."""
    return None if value is None else kind(value)


def _track_dict(track: Track) -> dict[str, Any]:
    """A track's figures as ``uavsnn detect --json`` prints them (``track_stats``)."""
    return {
        "age_us": int(track.age_us),
        "hits": int(track.hits),
        "speed_px_s": float(track.speed),
        "velocity_px_s": [float(v) for v in track.velocity],
        "straightness": float(track.straightness),
        "turn_rate_rad_s": float(track.turn_rate),
        "first_alarm_us": _maybe(int, track.first_alarm_us),
        "rotor_strength_mean": float(track.rotor_strength_mean),
        "activity_measured": int(track.activity_measured),
        "events_per_px_mean": float(track.events_per_px_mean),
        "events_per_px_std": float(track.events_per_px_std),
        "on_balance_mean": float(track.on_balance_mean),
        "rate_swing_mean": float(track.rate_swing_mean),
    }


def _rotor_dict(rotor: RotorEstimate | None) -> dict[str, Any] | None:
    """A rotor signature as ``uavsnn detect`` prints it, when detected (docs/identification.md),
    else ``None``."""
    if rotor is None or not rotor.detected:
        return None
    return {
        "frequency_hz": round(float(rotor.frequency_hz), 2),
        "strength": round(float(rotor.strength), 4),
        "pixels": int(rotor.pixels),
    }


def merge_boxes(detections: np.ndarray) -> tuple[WindowObject, ...]:
    """Merge the causal boxes of some detections into objects.

    The rule: two boxes that overlap or share an edge (half-open boxes ``a`` and ``b`` with
    ``a.x0 <= b.x1``, ``b.x0 <= a.x1`` and the same in y) are replaced by their bounding box,
    repeatedly, until no two boxes overlap or touch. Each object counts the spikes whose boxes
    it absorbed. Objects come largest spike count first, then by ``x0, y0``. The result does
    not depend on the order of ``detections``.

    Raises:
        ParameterError: ``detections`` that are not a 1-D structured array with the fields
            ``x0``, ``y0``, ``x1`` and ``y1`` (as a detector returns them).
    """
    try:
        if len(detections) == 0:
            return ()
    except TypeError:  # no length: refused below
        pass
    names = getattr(getattr(detections, "dtype", None), "names", None) or ()
    missing = [f for f in _BOX_FIELDS if f not in names]
    if not isinstance(detections, np.ndarray) or detections.ndim != 1 or missing:
        got = (
            f"an array of {detections.dtype} {detections.shape}"
            if isinstance(detections, np.ndarray)
            else type(detections).__name__
        )
        raise ParameterError(
            f"detections must be a 1-D structured array with the fields {list(_BOX_FIELDS)} "
            f"(as a detector returns them), got {got}"
        )
    # The distinct boxes in ascending (x0, y0, x1, y1) order, each with its spike count.
    tally = Counter(zip(*(detections[f].tolist() for f in _BOX_FIELDS), strict=True))
    boxes = sorted(tally)
    counts = [tally[b] for b in boxes]
    if len(boxes) > _MERGE_IN_NUMPY_FROM:
        merged = _merge_passes_numpy(boxes, counts)
    else:
        merged = _merge_passes(boxes, counts)
    merged.sort(key=lambda bc: (-bc[1], bc[0][0], bc[0][1]))
    return tuple(WindowObject(box=box, spikes=n) for box, n in merged)


#: The fields of a detection's causal box, which :func:`merge_boxes` reads.
_BOX_FIELDS = ("x0", "y0", "x1", "y1")

#: :func:`merge_boxes` merges up to this many distinct boxes in plain Python (a window holds a
#: few, where NumPy's cost per call dominates) and more with NumPy (a pass makes
#: ``O(boxes²)`` comparisons; vectorised, thousands of boxes stay fast). Both give the same
#: objects.
_MERGE_IN_NUMPY_FROM = 64

#: Events :meth:`WindowGrouper.add` reads at a time (its working arrays stay near 3 MB).
_GROUP_SLICE = 1 << 16

_Box = tuple[int, int, int, int]


def _merge_passes(boxes: list[_Box], counts: list[int]) -> list[tuple[_Box, int]]:
    """:func:`merge_boxes`'s passes, in plain Python. A pass takes the first box left and
    absorbs every box left that overlaps or touches it (all of them at once, then again
    against the grown box) until none does, then moves on to the next box left. Passes repeat
    until one merges nothing. Returns ``(box, spikes)`` in the last pass's order."""
    while True:
        merged: list[tuple[_Box, int]] = []
        rest = list(zip(boxes, counts, strict=True))
        while rest:
            (x0, y0, x1, y1), n = rest.pop(0)
            while rest:
                hit, keep = [], []
                for r in rest:
                    b = r[0]
                    if b[0] <= x1 and x0 <= b[2] and b[1] <= y1 and y0 <= b[3]:
                        hit.append(r)
                    else:
                        keep.append(r)
                if not hit:
                    break
                x0 = min(x0, *(b[0] for b, _ in hit))
                y0 = min(y0, *(b[1] for b, _ in hit))
                x1 = max(x1, *(b[2] for b, _ in hit))
                y1 = max(y1, *(b[3] for b, _ in hit))
                n += sum(c for _, c in hit)
                rest = keep
            merged.append(((x0, y0, x1, y1), n))
        if len(merged) == len(boxes):  # a pass merged nothing: no two boxes touch
            return merged
        boxes, counts = [b for b, _ in merged], [c for _, c in merged]


def _merge_passes_numpy(boxes: list[_Box], counts: list[int]) -> list[tuple[_Box, int]]:
    """:func:`_merge_passes` with each comparison of a box against those left vectorised."""
    rows, n_of = np.array(boxes, dtype=np.int64), np.array(counts, dtype=np.int64)
    while True:
        merged_rows: list[np.ndarray] = []
        merged_counts: list[int] = []
        rest, rest_n = rows, n_of
        while len(rest):
            cur, n = rest[0].copy(), int(rest_n[0])
            rest, rest_n = rest[1:], rest_n[1:]
            while len(rest):
                hit = (
                    (rest[:, 0] <= cur[2])
                    & (cur[0] <= rest[:, 2])
                    & (rest[:, 1] <= cur[3])
                    & (cur[1] <= rest[:, 3])
                )
                if not hit.any():
                    break
                cur[:2] = np.minimum(cur[:2], rest[hit, :2].min(axis=0))
                cur[2:] = np.maximum(cur[2:], rest[hit, 2:].max(axis=0))
                n += int(rest_n[hit].sum())
                rest, rest_n = rest[~hit], rest_n[~hit]
            merged_rows.append(cur)
            merged_counts.append(n)
        stable = len(merged_rows) == len(rows)
        rows, n_of = np.array(merged_rows), np.array(merged_counts, dtype=np.int64)
        if stable:  # a pass merged nothing: no two boxes touch
            return [
                ((int(r[0]), int(r[1]), int(r[2]), int(r[3])), int(c))
                for r, c in zip(rows, n_of, strict=True)
            ]


class WindowGrouper:
    """Group a :class:`Detector`'s spikes by window: one :class:`WindowReport` per window,
    returned as soon as the window is closed (an event at or after its end has been pushed,
    so every spike of it has been returned), or at the end of the stream.

    A report is made for every window the detector opens, i.e. every window holding at least
    one event (windows wholly inside a silent gap are skipped, as the detector skips them);
    windows without a spike are reported with ``detected=False``.

    Feed it every chunk the detector accepted, with what the detector returned::

        det = Detector(network)
        windows = WindowGrouper.of(det)
        for chunk in source:
            for w in windows.add(chunk, det.push(chunk)):
                print(w.window, w.detected, [o.box for o in w.objects])
        for w in windows.finish(det.flush()):
            ...

    Args:
        window_us, step_us: the detector's window length and step.
        start_us: start of window 0, or ``None`` for the first event's time.
        min_detections: conv3 spikes that make a window a detection.

    Raises:
        ParameterError: an argument that is not an integer, ``window_us``, ``step_us`` or
            ``min_detections`` below 1, a negative ``start_us``.
    """

    def __init__(
        self, window_us: int, step_us: int, *, start_us: int | None = None, min_detections: int = 1
    ) -> None:
        self.window_us = check_int("window_us", window_us, 1)
        self.step_us = check_int("step_us", step_us, 1)
        self.min_detections = check_int("min_detections", min_detections, 1)
        self._start = None if start_us is None else check_int("start_us", start_us, 0)
        self._next = 0  # the first window not opened yet
        self._open: list[int] = []  # opened, not yet reported, in order
        self._found: dict[int, list[np.ndarray]] = {}

    @classmethod
    def of(cls, detector: Detector) -> WindowGrouper:
        """A grouper for ``detector``'s windows, to be fed from its first push on.

        Raises:
            ParameterError: ``detector`` is no :class:`~uavsnn.detector.Detector`.
        """
        from uavsnn.detector import Detector

        if not isinstance(detector, Detector):
            raise ParameterError(
                f"WindowGrouper.of takes a uavsnn.detector.Detector, got {type(detector).__name__}"
            )
        return cls(
            detector.window_us,
            detector.step_us,
            start_us=detector.start_us,
            min_detections=int(detector.network.config["detection"]["min_detections"]),
        )

    def add(self, events: np.ndarray, detections: np.ndarray) -> list[WindowReport]:
        """Note a chunk the detector accepted and the detections it returned for it; return
        the windows that chunk closed.

        Raises:
            ParameterError, ShapeError: ``events`` that are not a 1-D array of
                :data:`uavsnn.EVENT_DTYPE`, ``detections`` not as the detector returns them (a
                1-D array of :data:`~uavsnn.network.WINDOW_DETECTION_DTYPE`).
        """
        _check_array(
            "events", events, EVENT_DTYPE, "the chunk pushed to the detector (uavsnn.EVENT_DTYPE)"
        )
        self._note(detections)
        if len(events) == 0:
            return []
        times = events["t"]
        if self._start is None:
            self._start = int(times[0])
        if int(times[-1]) < self._start:
            return []
        # A slice at a time: the arrays below take about 40 bytes an event.
        for s in range(0, len(times), _GROUP_SLICE):
            self._open_windows(times[s : s + _GROUP_SLICE].astype(np.int64) - self._start)
        # Window k is closed once an event at or after its end has been pushed.
        return self._close_by(int(times[-1]) - self._start)

    def advance(self, t_us: int, detections: np.ndarray) -> list[WindowReport]:
        """Note the detections :meth:`Detector.advance <uavsnn.detector.Detector.advance>`
        returned for ``t_us``, and return the windows that ends: every event still to come is
        at or after ``t_us``, so a window ending by then is closed.

        Raises:
            ParameterError, ShapeError: ``t_us`` not an integer in ``[0, 2**62]``, or
                ``detections`` not as the detector returns them.
        """
        t_us = check_int("t_us", t_us, 0, MAX_TIME_US)
        self._note(detections)
        if self._start is None:
            return []
        return self._close_by(t_us - self._start)

    def _close_by(self, last: int) -> list[WindowReport]:
        """Report the open windows that end by ``last`` µs from the start (the stream has
        reached it)."""
        closed = 0
        while closed < len(self._open) and self._end(self._open[closed]) <= last:
            closed += 1
        return self._report(closed)

    def _open_windows(self, t: np.ndarray) -> None:
        """Open the windows that events at ``t`` (from the start, in order) are the first of."""
        t = t[t >= 0]
        if len(t) == 0:
            return
        # The windows holding each event: lo..=hi (hi and lo never decrease along the chunk).
        hi = t // self.step_us
        lo = np.where(t >= self.window_us, (t - self.window_us) // self.step_us + 1, 0)
        prev = np.concatenate([[self._next - 1], np.maximum.accumulate(hi)[:-1]])
        first = np.maximum(lo, prev + 1)
        for i in np.flatnonzero(first <= hi):
            self._open.extend(range(int(first[i]), int(hi[i]) + 1))
        self._next = max(self._next, int(hi[-1]) + 1)

    def finish(self, detections: np.ndarray) -> list[WindowReport]:
        """The end of the stream: note the detections :meth:`Detector.flush` returned and
        report every window still open.

        Raises:
            ParameterError, ShapeError: ``detections`` not as the detector returns them.
        """
        self._note(detections)
        return self._report(len(self._open))

    def ended_by(self, t: int) -> int:
        """How many windows, from window 0, end by event time ``t``: no event still to come (at
        ``t`` or later) falls in them. 0 before the first event."""
        if self._start is None or t - self._start < self.window_us:
            return 0
        return (t - self._start - self.window_us) // self.step_us + 1

    def empty(self, k: int) -> WindowReport:
        """Window ``k`` as a window without events: not detected, no object (a window of a
        silent gap, which no event opens and no report gives)."""
        t0, t1 = self._bounds(k)
        return WindowReport(k, t0, t1, False, _NO_DETECTIONS, ())

    def open_since(self) -> int | None:
        """Start of the earliest window not yet reported, or of the next one to open; events
        before it belong to no window still to come. ``None`` before the first event."""
        if self._start is None:
            return None
        return self._start + (self._open[0] if self._open else self._next) * self.step_us

    def _end(self, k: int) -> int:
        return k * self.step_us + self.window_us

    def _bounds(self, k: int) -> tuple[int, int]:
        """Window ``k``'s start and end in event time."""
        start = self._start or 0
        return start + k * self.step_us, start + self._end(k)

    def _note(self, detections: np.ndarray) -> None:
        _check_array(
            "detections",
            detections,
            WINDOW_DETECTION_DTYPE,
            "what the detector's push, advance or flush returned "
            "(uavsnn.network.WINDOW_DETECTION_DTYPE)",
        )
        if len(detections) == 0:
            return
        windows = detections["window"]
        for k in np.unique(windows).tolist():
            self._found.setdefault(int(k), []).append(detections[windows == k])

    def _report(self, n: int) -> list[WindowReport]:
        out = []
        for k in self._open[:n]:
            parts: Sequence[np.ndarray] = self._found.pop(k, [])
            spikes = np.concatenate(parts) if parts else _NO_DETECTIONS
            t0, t1 = self._bounds(k)
            out.append(
                WindowReport(
                    window=k,
                    t0=t0,
                    t1=t1,
                    detected=len(spikes) >= self.min_detections,
                    detections=spikes,
                    objects=merge_boxes(spikes),
                )
            )
        del self._open[:n]
        return out


def _check_array(name: str, value: object, dtype: np.dtype[Any], what: str) -> None:
    """Refuse ``value`` unless it is a 1-D array of ``dtype`` (``what``: where it comes from,
    and the dtype's name)."""
    if not isinstance(value, np.ndarray) or value.dtype != dtype:
        got = f"dtype {value.dtype}" if isinstance(value, np.ndarray) else type(value).__name__
        raise ParameterError(f"{name} must be {what}, got {got}")
    if value.ndim != 1:
        raise ShapeError(f"{name} must be a 1-D array ({what}), got shape {value.shape}")
