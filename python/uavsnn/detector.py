"""Streaming detection: :class:`Detector` turns chunks of live events into UAV detections.

The detector runs the network over windows of ``window_us`` that start every
``window_us * (1 - overlap)`` µs (docs/model.md §1), as staggered states that overlap in time,
and returns each conv3 spike as a detection as soon as it is decided, without waiting for its
window to close. PENT's threshold for a window is set when the window opens, from the number of
distinct pixels active in the ``window_us`` before it (the "preceding" estimate, docs/model.md
§4), so the streaming detections equal those of the batch path
(``Network.infer(make_windows(recording, window_us, overlap))`` with the "preceding" estimate).

Spikes that share a timestamp are decided together, so a detection at time ``t`` is returned by
the first :meth:`Detector.push` that carries an event later than ``t`` (or by
:meth:`Detector.flush` at the end of the stream). Memory stays bounded however long the stream.

:meth:`Detector.push_windows` returns one :class:`~uavsnn.grouping.WindowReport` per window
instead (the decision and the merged boxes, grouped by :class:`~uavsnn.grouping.WindowGrouper`,
with each object's rotor signature, track and identification), which is what ``uavsnn detect``
prints. The names of :mod:`uavsnn.grouping` can also be imported from here.

Example::

    det = uavsnn.Detector(network, window_us=50_000, overlap=0.5)
    for chunk in source:               # arrays of uavsnn.EVENT_DTYPE, in time order
        for d in det.push(chunk):
            print(d["t"], d["x"], d["y"])
    for d in det.flush():              # the stream's end: the detections still pending
        print(d["t"], d["x"], d["y"])
"""

from __future__ import annotations

import bisect
import json
import os
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from uavsnn import _core
from uavsnn._state import EngineState
from uavsnn._validate import MAX_TIME_US, check_int, check_sensor_size
from uavsnn.boxes import xywh
from uavsnn.errors import ParameterError, ShapeError, StreamError, UavsnnError
from uavsnn.events import EVENT_DTYPE, SensorSizeLike, packed_bytes
from uavsnn.features import MAX_MEASURED_WINDOW_US, MAX_RATE_BINS, RATE_BIN_US, rate_bins
from uavsnn.grouping import WindowGrouper, WindowObject, WindowReport, merge_boxes
from uavsnn.network import WINDOW_DETECTION_DTYPE
from uavsnn.provenance import DEFAULT_OVERLAP, DEFAULT_WINDOW_US, model_windows
from uavsnn.signature import BoxMeasure, measure_box
from uavsnn.tracks import Tracker, tracker_for

if TYPE_CHECKING:
    from uavsnn.network import Network

__all__ = [
    "DEFAULT_OVERLAP",
    "DEFAULT_WINDOW_US",
    "MAX_LIVE_WINDOWS",
    "MAX_ROTOR_BOXES",
    "MAX_ROTOR_EVENTS",
    "WINDOW_DETECTION_DTYPE",
    "Detector",
    "WindowGrouper",
    "WindowObject",
    "WindowReport",
    "live_windows",
    "merge_boxes",
]

#: The most windows a :class:`Detector` keeps live at once, ``ceil(1 / (1 - overlap))`` (the
#: engine's limit): each holds a network state (:attr:`Network.state_bytes`: 1.7 MiB on a
#: 240×180 sensor, 35 MiB on 1280×720), so an overlap of 0.9999 would need 10,000 of them.
#: Overlaps up to ``1 - 1/64 ≈ 0.984`` are accepted.
MAX_LIVE_WINDOWS = 64


def live_windows(window_us: int, overlap: float) -> int:
    """The windows a :class:`Detector` keeps live at once at windows of ``window_us`` and
    ``overlap``: ``ceil(window_us / step)``, the engine's step (:data:`MAX_LIVE_WINDOWS` at most
    are accepted)."""
    return -(-window_us // _core.window_step(window_us, overlap))


# Bytes the engine's stream keeps per pixel beside the window states: its counter of preceding
# events (8) and up to two 16-byte queue entries.
_STREAM_PIXEL_BYTES = 8 + 2 * 16

#: The most objects of one window whose rotor signature :meth:`Detector.push_windows` measures
#: (the first ones: most conv3 spikes first); the others get ``rotor=None``.
MAX_ROTOR_BOXES = 8

#: The most raw events :meth:`Detector.push_windows` keeps for the rotor signature of the
#: windows still open (13 bytes each: 26 MiB). When a stream is denser than that over one
#: window, the oldest are dropped and the windows that lost events get ``rotor=None``.
MAX_ROTOR_EVENTS = 1 << 21

#: Events of a chunk :meth:`Detector.push_windows` keeps and closes windows for at a time, so
#: that a chunk of millions of events keeps the events of the windows it closes, as small
#: chunks do: the reports do not depend on the chunking unless the windows still open hold
#: more than :data:`MAX_ROTOR_EVENTS` less one slice.
_ROTOR_SLICE = 1 << 16


if TYPE_CHECKING:
    #: Deprecated: :data:`WINDOW_DETECTION_DTYPE` (read with a ``DeprecationWarning``).
    DETECTION_DTYPE: np.dtype[np.void]
else:  # hidden from type checkers, which would take any name of this module as an object

    def __getattr__(name: str) -> object:
        # ``DETECTION_DTYPE`` was this module's name for what uavsnn.network calls
        # ``WINDOW_DETECTION_DTYPE``; uavsnn.network.DETECTION_DTYPE has no window field.
        if name == "DETECTION_DTYPE":
            import warnings

            warnings.warn(
                "uavsnn.detector.DETECTION_DTYPE is deprecated: use WINDOW_DETECTION_DTYPE "
                "(uavsnn.network.DETECTION_DTYPE is one window's detection, without a window "
                "field)",
                DeprecationWarning,
                stacklevel=2,
            )
            return WINDOW_DETECTION_DTYPE
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


_NO_DETECTIONS = np.empty(0, dtype=WINDOW_DETECTION_DTYPE)
_NO_DETECTIONS.flags.writeable = False
# The events the engine pushes between two looks at Python's signals.
_PUSH_SLICE = _core.PUSH_SLICE


def _detections(packed: np.ndarray) -> np.ndarray:
    """View packed detection records; most pushes find none, and share one empty array."""
    return packed.view(WINDOW_DETECTION_DTYPE) if len(packed) else _NO_DETECTIONS


class _Changing:
    """:meth:`Detector._changing`'s guard: a plain context manager, since a generator's
    (``contextlib.contextmanager``) cost 2.2 µs a call, a third of a one-event push."""

    __slots__ = ("call", "detector")

    def __init__(self, detector: Detector, call: str) -> None:
        self.detector, self.call = detector, call

    def __enter__(self) -> None:
        # One call that changes the stream at a time, its Python part (grouping, tracks) with
        # its engine part: another is refused before it touches anything.
        if not self.detector._lock.acquire(False):
            raise StreamError(
                f"{self.call}(): the detector is in use by another call (another thread's, or "
                "one a signal handler interrupted): one call at a time changes its stream"
            )
        self.detector._taken = False

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: Any
    ) -> None:
        detector = self.detector
        if exc is not None and (detector._taken or not isinstance(exc, UavsnnError)):
            detector._interrupted = self.call
        detector._lock.release()


class Detector(EngineState):
    """Low-latency UAV detection on a live event stream.

    A detector cannot be copied (``copy.copy``, ``copy.deepcopy``) nor pickled: its stream
    lives in the engine, and a copy sharing it would advance the original. Make another with
    ``Detector(...)`` for a second stream.

    A call that changes the stream (:meth:`push`, :meth:`push_windows`, :meth:`flush`,
    :meth:`flush_windows`, :meth:`reset`) and is stopped part way by anything but the
    package's own errors (``KeyboardInterrupt`` from Ctrl-C, a ``MemoryError``, an error
    inside the tracker) leaves the stream unknown: the engine may have taken events whose
    detections never reached the caller. The detector notes it (:attr:`interrupted`), and
    every later call of those but :meth:`reset` raises :class:`~uavsnn.StreamError` saying so,
    rather than number windows wrongly or refuse the chunk again as "time goes backwards".

    Args:
        model: a :class:`uavsnn.network.Network` (the detector copies its weights; later
            changes to the network do not reach it), or the path of a model file.
        window_us: window length ``L`` in microseconds, from 1 to ``2**62`` (the engine's
            longest window). Default: the window the model was trained on
            (:attr:`Network.trained_on <uavsnn.network.Network.trained_on>`, which ``uavsnn
            train`` records), else 50,000.
        overlap: overlap ``o`` of consecutive windows, in ``[0, 1)``; at most
            ``ceil(1 / (1 - o))`` windows are live at once, and that may not exceed
            :data:`MAX_LIVE_WINDOWS`. Default: the model's training overlap, else 0.5.
        sensor_size: ``(width, height)`` of the camera; it must equal the network's input size
            (a check that the right camera feeds the right model). Default: the network's.
        start_us: start of window 0; default: the first event's time.
        tracker: the :class:`uavsnn.tracks.Tracker` :meth:`push_windows` links objects with
            (default: :func:`uavsnn.tracks.tracker_for` the network: the default parameters,
            the gate its identification was fitted with when the model records one, else a
            share of the width).
        rotor: whether :meth:`push_windows` measures each object's rotor signature.

    Raises:
        ParameterError: for a ``window_us`` outside ``[1, 2**62]`` (or, with ``rotor``, over
            :data:`uavsnn.features.MAX_RATE_BINS` bins of ``RATE_BIN_US``: 20.48 s), an overlap
            outside ``[0, 1)`` or one that keeps more than :data:`MAX_LIVE_WINDOWS` windows
            live, or a ``model`` that is neither a network nor a path; or when the network
            states of the live windows would not fit in ``uavsnn.windows.MEMORY_LIMIT`` (the
            bytes and the limit named), instead of aborting the process later.
        ShapeError: when ``sensor_size`` differs from the network's input size.
    """

    def __init__(
        self,
        model: Network | str | os.PathLike[str],
        *,
        window_us: int | None = None,
        overlap: float | None = None,
        sensor_size: SensorSizeLike | None = None,
        start_us: int | None = None,
        tracker: Tracker | None = None,
        rotor: bool = True,
    ) -> None:
        if tracker is not None and not isinstance(tracker, Tracker):
            raise ParameterError(f"tracker must be a uavsnn.tracks.Tracker, got {tracker!r}")
        if isinstance(model, (str, os.PathLike)):
            from uavsnn.network import Network

            network = Network.load(model)
        else:
            from uavsnn.network import Network

            if not isinstance(model, Network):
                raise ParameterError(
                    f"model must be a uavsnn.Network or the path of a model file, got "
                    f"{type(model).__name__}"
                )
            network = model
        trained_window, trained_overlap = model_windows(network.trained_on)
        window_us = trained_window if window_us is None else window_us
        overlap = trained_overlap if overlap is None else overlap
        width, height = int(network.config["width"]), int(network.config["height"])
        if sensor_size is not None and check_sensor_size(sensor_size) != (width, height):
            raise ShapeError(
                f"sensor_size {tuple(sensor_size)} differs from the network's input size "
                f"{(width, height)}; downsample the events first (uavsnn.filters.downsample)"
            )
        # The engine takes both times as u64: a larger one is refused here, not an
        # OverflowError; the window beyond the engine's longest (2^62 µs) too, under its
        # Python name. The overlap's range is the engine's check.
        window_us = check_int("window_us", window_us, 1, MAX_TIME_US)
        if rotor and window_us > MAX_MEASURED_WINDOW_US:
            # Refused later, in push_windows, once the events were taken.
            raise ParameterError(
                f"window_us {window_us} is longer than {MAX_MEASURED_WINDOW_US} µs, the "
                f"longest window whose objects are measured (their event rate is counted in at "
                f"most {MAX_RATE_BINS} bins of {RATE_BIN_US} µs); pass rotor=False to detect "
                "without measuring them"
            )
        if start_us is not None:
            start_us = check_int("start_us", start_us, 0, MAX_TIME_US)
        if isinstance(overlap, bool) or not isinstance(
            overlap, (int, float, np.integer, np.floating)
        ):
            raise ParameterError(f"overlap must be a number in [0, 1), got {overlap!r}")
        # Each live window holds a network state, and the stream keeps 40 bytes a pixel: refused
        # here when they would not fit in the memory this process may have (the engine checks
        # its fixed 4 GiB only; more than MAX_LIVE_WINDOWS live windows is its to refuse).
        live = live_windows(window_us, float(overlap))
        if live <= MAX_LIVE_WINDOWS:
            network._check_memory(
                live,
                more=width * height * _STREAM_PIXEL_BYTES,
                hint=", or a smaller overlap" if live > 1 else "",
            )
        w1, w2, w3 = (
            np.ascontiguousarray(network.weights(layer), dtype=np.float32).ravel()
            for layer in ("conv1", "conv2", "conv3")
        )
        # The detector keeps its own copy of the weights, taken now.
        self._inner = _core.StreamDetector(
            json.dumps(network.config), w1, w2, w3, int(window_us), float(overlap), start_us
        )
        self._network = network
        self._start_us = start_us
        # What never changes, read here: the properties and the repr answer while another
        # thread's call holds the engine (which then refuses reads).
        inner = self._inner
        self._window_us, self._overlap, self._step_us = (
            inner.window_us,
            inner.overlap,
            inner.step_us,
        )
        self._sensor_size: tuple[int, int] = inner.sensor_size
        self._busy_ns = 0
        self._run = 0  # resets so far: the stream's number (WindowReport.run)
        self._tracker = tracker_for(network) if tracker is None else tracker
        self._rotor = bool(rotor)
        self._grouper: WindowGrouper | None = None  # made by push_windows
        self._plain = False  # events went through push
        self._recent: list[np.ndarray] = []  # raw events of the open windows, in order
        self._recent_n = 0
        # Every event dropped from _recent is earlier than this: a window that starts at or
        # after it lost none.
        self._lost_until = 0
        # The first window the tracker has not been fed, reported or skipped (see _skip_to).
        self._unfed = 0
        # Per live track: scored objects, the sum of their UAV scores and class probabilities.
        self._identity: dict[int, tuple[int, float, np.ndarray]] = {}
        # The call that changes the stream and was stopped part way (see _changing), or None.
        self._interrupted: str | None = None
        # Whether the current call's engine part took its input (see _changing).
        self._taken = False
        # Held by the call that changes the stream (see _changing).
        self._lock = threading.Lock()

    _remake = "make another with Detector(...) for a second stream"

    # ------------------------------------------------------------------ the stream

    def push(self, events: np.ndarray) -> np.ndarray:
        """Feed a chunk of events and return the detections it decided.

        Args:
            events: a 1-D array of :data:`uavsnn.EVENT_DTYPE` (any length, one or none
                included), sorted by time, not earlier than the previous chunk.

        Returns:
            A structured array of :data:`~uavsnn.network.WINDOW_DETECTION_DTYPE`, in time order.

        Raises:
            EventError: a wrong dtype, an event outside the sensor, or times out of order
                inside the chunk.
            StreamError: the chunk starts before the previous one ended, or the stream was
                flushed, or an earlier call was interrupted part way (:attr:`interrupted`;
                :meth:`reset` starts a new stream). After any of these errors the detector is
                as it was before the call; a call stopped by anything else (Ctrl-C) leaves it
                :attr:`interrupted`.
        """
        with self._changing("push"):
            self._check_whole("push")
            if self._grouper is not None:
                raise self._mixed("push", "push_windows")
            found = self._push(events)
            self._plain = self._plain or len(events) > 0
            return found

    def _push(self, events: np.ndarray) -> np.ndarray:
        # Cheap checks first: a one-event push should cost microseconds, not a dtype walk.
        if not (
            isinstance(events, np.ndarray)
            and (events.dtype is EVENT_DTYPE or events.dtype == EVENT_DTYPE)
            and events.ndim == 1
        ):
            packed_bytes(events)  # raises the EventError that says what is wrong
        raw = events.tobytes()  # the packed records, copied (cheaper than a dtype view)
        if len(events) <= _PUSH_SLICE:
            return self._engine(self._inner.push, raw)
        # Between slices the engine runs Python's signal handlers: one that raises (even one of
        # the package's errors) stops the push part way, which no refusal does.
        before = self._inner.events_seen
        try:
            return self._engine(self._inner.push, raw)
        except UavsnnError:
            self._taken = self._taken or self._inner.events_seen != before
            raise

    def _engine(self, call: Callable[..., np.ndarray], *args: Any) -> np.ndarray:
        """An engine call that changes the stream (push, advance, flush): timed into
        :attr:`rate`, noted as having taken its input (see :meth:`_changing`), its packed
        detections viewed."""
        start = time.perf_counter_ns()
        out = call(*args)
        self._taken = True
        self._busy_ns += time.perf_counter_ns() - start
        return _detections(out)

    def advance(self, t_us: int) -> np.ndarray:
        """The stream has reached ``t_us`` without more events: a promise (a watermark) that
        every event still to come is at or after ``t_us``. Returns the detections that decides
        — those a later event would return, only sooner — so that a quiet stream's last
        detections need not wait for its next event (``uavsnn detect --idle-flush`` calls it
        when a live source falls silent). A chunk that starts before ``t_us`` is refused
        afterwards.

        Raises:
            ParameterError: ``t_us`` not an integer in ``[0, 2**62]``.
            StreamError: the stream is already past ``t_us``, was flushed, or an earlier call
                was interrupted part way; the detector is then as it was.
        """
        with self._changing("advance"):
            self._check_whole("advance")
            if self._grouper is not None:
                raise self._mixed("advance", "push_windows")
            return self._advance(t_us)

    def _advance(self, t_us: int) -> np.ndarray:
        return self._engine(self._inner.advance, check_int("t_us", t_us, 0, MAX_TIME_US))

    def _changing(self, call: str) -> _Changing:
        """The body of ``call``, which changes the stream: stopped by an exception, the
        detector notes it (:attr:`interrupted`), unless it is one of the package's errors
        raised before the engine took the call's input (the engine calls set ``_taken``):
        those are refusals that leave the detector as it was."""
        return _Changing(self, call)

    def flush(self) -> np.ndarray:
        """End the stream: return the detections still pending (the last timestamp's) and
        close every window. Further pushes raise :class:`~uavsnn.StreamError` until
        :meth:`reset`.

        Raises:
            StreamError: an earlier call was interrupted part way (:attr:`interrupted`):
                the detections pending would not be those of the stream pushed.
        """
        with self._changing("flush"):
            self._check_whole("flush")
            if self._grouper is not None:
                raise self._mixed("flush", "push_windows")
            return self._flush()

    def _flush(self) -> np.ndarray:
        return self._engine(self._inner.flush)

    def reset(self) -> None:
        """Forget the stream (counters and tracks included); the next event starts a new one.
        This is how a stream left :attr:`interrupted` is ended; a reset that is itself
        interrupted part way leaves the detector :attr:`interrupted`."""
        with self._changing("reset"):
            self._inner.reset()
            self._taken = True
            self._run += 1
            self._busy_ns = 0
            self._tracker.reset()
            self._grouper = None
            self._plain = False
            self._recent, self._recent_n, self._lost_until = [], 0, 0
            self._unfed = 0
            self._identity = {}
            self._interrupted = None

    @property
    def run(self) -> int:
        """The stream's number: 0 for the first, one more after each :meth:`reset` (a sensor
        restart, :class:`~uavsnn.driver.StreamDriver`). :meth:`push_windows`' reports carry
        it (:attr:`WindowReport.run <uavsnn.grouping.WindowReport.run>`): window numbers and
        track ids start again at each reset."""
        return self._run

    @property
    def interrupted(self) -> bool:
        """Whether a call that changes the stream was stopped part way (by Ctrl-C, or by any
        error but a refusal of its input, which changes nothing): the stream is then unknown,
        and every call but :meth:`reset` that depends on it raises
        :class:`~uavsnn.StreamError`."""
        return self._interrupted is not None

    def _check_whole(self, call: str) -> None:
        if self._interrupted is not None:
            raise StreamError(
                f"{call}() after an earlier {self._interrupted}() was interrupted part way: "
                "the engine may have taken events whose detections never came back, so this "
                "stream cannot go on; reset() starts a new one"
            )

    def _mixed(self, call: str, used: str) -> StreamError:
        return StreamError(
            f"{call}() on a stream read with {used}(): push and push_windows cannot be mixed on "
            f"one stream (the windows would be numbered and filled wrongly); reset() starts a "
            f"new one"
        )

    # ------------------------------------------------------------------ one report per window

    def push_windows(self, events: np.ndarray) -> list[WindowReport]:
        """Feed a chunk of events (as :meth:`push`) and return the windows it closed, each
        object with its track (:attr:`tracker`) and rotor signature filled in.

        Use either this (with :meth:`flush_windows`) or :meth:`push` on one stream, not both:
        mixing them raises :class:`~uavsnn.StreamError`.
        The reports are :class:`WindowGrouper`'s whatever the chunking, so the tracks are those
        of :func:`uavsnn.tracks.track_windows` over them. The windows of a silent gap, which
        hold no event and get no report, are fed to the tracker as windows without objects
        while a track is live (at most ``max_misses + 1`` of them): a track that ends in a gap
        is deleted (:meth:`~uavsnn.tracks.Tracker.drain_ended`) at the window, and with the
        record, that ``track_windows`` over every window gives it.

        Raises:
            EventError, StreamError: as :meth:`push`; the detector, its tracks included, is
                then as it was before the call. A call stopped by anything else once the
                engine has the chunk (Ctrl-C, an error while the windows are grouped, tracked
                or scored) leaves it :attr:`interrupted`.
        """
        with self._changing("push_windows"):
            self._check_whole("push_windows")
            if self._plain:
                raise self._mixed("push_windows", "push")
            found = self._push(events)
            grouper = self._windows()
            grouper.add(events[:0], found)  # the whole chunk's spikes, noted at once
            # The windows closed a slice at a time, each slice's events kept for the rotor
            # just before: a large chunk keeps as many events for its windows as small ones.
            out: list[WindowReport] = []
            for s in range(0, len(events), _ROTOR_SLICE):
                part = events[s : s + _ROTOR_SLICE]
                if self._rotor:
                    self._keep(part)
                closed = grouper.add(part, _NO_DETECTIONS)
                out += self._finish_reports(closed, reached=int(part["t"][-1]))
            return out

    def advance_windows(self, t_us: int) -> list[WindowReport]:
        """:meth:`advance` for a stream read with :meth:`push_windows`: the windows that end by
        ``t_us``, tracked, as the next chunk would return them. The windows without events that
        end by ``t_us`` count as missed for the tracks, as in a gap (:meth:`push_windows`), so
        a track whose object left as the stream fell quiet is deleted once
        ``tracker.max_misses`` windows have passed, not at the next event.

        Raises:
            ParameterError, StreamError: as :meth:`advance`.
        """
        with self._changing("advance_windows"):
            self._check_whole("advance_windows")
            if self._plain:
                raise self._mixed("advance_windows", "push")
            found = self._advance(t_us)
            closed = self._windows().advance(t_us, found)
            return self._finish_reports(closed, reached=int(t_us))

    def flush_windows(self) -> list[WindowReport]:
        """End the stream (as :meth:`flush`) and return every window still open, tracked.
        The live tracks stay in :attr:`tracker` (``tracker.finish()`` ends them).

        Raises:
            StreamError: as :meth:`flush`.
        """
        with self._changing("flush_windows"):
            self._check_whole("flush_windows")
            if self._plain:
                raise self._mixed("flush_windows", "push")
            return self._finish_reports(self._windows().finish(self._flush()))

    @property
    def tracker(self) -> Tracker:
        """The tracker :meth:`push_windows` feeds (its live and ended tracks)."""
        return self._tracker

    def _windows(self) -> WindowGrouper:
        if self._grouper is None:
            self._grouper = WindowGrouper.of(self)
        return self._grouper

    def _keep(self, events: np.ndarray) -> None:
        """Keep a copy of a chunk for the rotor signature, within :data:`MAX_ROTOR_EVENTS`."""
        chunk = events[-MAX_ROTOR_EVENTS:].copy()
        if len(chunk) < len(events):
            # After the last event dropped: the first one kept may share its time.
            dropped = int(events["t"][len(events) - len(chunk) - 1])
            self._lost_until = max(self._lost_until, dropped + 1)
            self._recent, self._recent_n = [], 0
        self._recent.append(chunk)
        self._recent_n += len(chunk)
        while self._recent_n > MAX_ROTOR_EVENTS:
            extra = self._recent_n - MAX_ROTOR_EVENTS
            head = self._recent[0]
            if extra >= len(head):
                self._recent.pop(0)
                self._recent_n -= len(head)
                self._lost_until = max(self._lost_until, int(head["t"][-1]) + 1)
            else:
                self._recent[0] = head[extra:]
                self._recent_n -= extra
                self._lost_until = max(self._lost_until, int(head["t"][extra - 1]) + 1)

    def _finish_reports(
        self, closed: list[WindowReport], reached: int | None = None
    ) -> list[WindowReport]:
        """The windows ``closed``, measured, tracked and scored; ``reached``: the time the
        stream has reached (the windows ending by then are all closed or skipped)."""
        out = []
        ident = self._network.identification
        for report in closed:
            self._skip_to(report.window)
            measured = None
            if report.objects and report.t0 >= self._lost_until and self._recent:
                report, measured = _with_rotor(report, self._recent)
            # The track first (its statistics so far include this window), then the score.
            report = self._tracker.update(report)
            self._unfed = report.window + 1
            if measured is not None and ident is not None:
                report = self._with_track_identity(_with_scores(report, measured, ident), ident)
            out.append(replace(report, run=self._run) if self._run else report)
        if reached is not None:
            self._skip_to(self._windows().ended_by(reached))
        if self._recent and self._grouper is not None:
            keep_from = self._grouper.open_since()
            while self._recent and (keep_from is None or self._recent[0]["t"][-1] < keep_from):
                self._recent_n -= len(self._recent.pop(0))
        return out

    def _skip_to(self, k: int) -> None:
        """Feed the tracker the windows before ``k`` it has not seen: windows the stream
        skipped (they held no event, a silent gap), as windows without objects, so that its
        tracks miss them as they miss them in :func:`uavsnn.tracks.track_windows` over every
        window: a track ends at the same window, with the same record (misses, age). Only
        while a track is live, so at most ``max_misses + 1`` of them: a long gap costs no
        more. The windows reported are tracked as before (these only delete a track that
        would be deleted at the next window reported, sooner)."""
        j, tracker = self._unfed, self._tracker
        if j >= k:
            return
        grouper = self._windows()
        while j < k and tracker.live_count:
            tracker.update(grouper.empty(j))
            j += 1
        self._unfed = k

    def _with_track_identity(self, report: WindowReport, ident: Any) -> WindowReport:
        """``report`` with each scored, tracked object's track score and class guess, from
        the running sums of its track's scored objects. Track ids are never reused in a
        stream, so the sums of ended tracks are only dropped, all at once, when they outnumber
        the live tracks the tracker can hold (the live set is a snapshot of every track: too
        dear to take each window)."""
        if len(self._identity) > self._tracker.max_tracks:
            live = {t.id for t in self._tracker.live}
            self._identity = {k: v for k, v in self._identity.items() if k in live}
        objects = list(report.objects)
        for i, obj in enumerate(objects):
            if obj.uav_score is None or obj.track_id is None or obj.class_probabilities is None:
                continue
            n, total, probs = self._identity.get(obj.track_id, (0, 0.0, 0.0))
            n, total = n + 1, total + obj.uav_score
            probs = probs + np.asarray(obj.class_probabilities, dtype=np.float64)
            self._identity[obj.track_id] = (n, total, probs)
            score = total / n
            guess = ident.guess_from(np.array([score]), (probs / n)[None, :])[0]
            objects[i] = replace(obj, track_score=score, track_class=guess)
        return replace(report, objects=tuple(objects))

    # ------------------------------------------------------------------ properties

    @property
    def network(self) -> Network:
        """The network the detector runs."""
        return self._network

    @property
    def sensor_size(self) -> tuple[int, int]:
        """``(width, height)`` events are checked against."""
        return self._sensor_size

    @property
    def start_us(self) -> int | None:
        """Start of window 0 as given, or ``None``: the first event's time."""
        return self._start_us

    @property
    def window_us(self) -> int:
        """Window length in microseconds."""
        return self._window_us

    @property
    def overlap(self) -> float:
        """Overlap of consecutive windows."""
        return self._overlap

    @property
    def step_us(self) -> int:
        """Microseconds between consecutive window starts."""
        return self._step_us

    @property
    def events_seen(self) -> int:
        """Events accepted so far."""
        return self._inner.events_seen

    @property
    def windows_opened(self) -> int:
        """Windows that received a network state (windows lying wholly in a silent gap of
        the stream are skipped: they could not detect anything)."""
        return self._inner.windows_opened

    @property
    def detections_emitted(self) -> int:
        """Detections returned so far."""
        return self._inner.detections_emitted

    @property
    def live_windows(self) -> int:
        """Windows holding a network state now (at most ``ceil(1 / (1 - overlap))``)."""
        return self._inner.live_windows

    @property
    def last_t(self) -> int | None:
        """Time of the last event accepted, or ``None``."""
        return self._inner.last_t

    @property
    def busy_seconds(self) -> float:
        """Wall time spent inside :meth:`push` and :meth:`flush`."""
        return self._busy_ns / 1e9

    @property
    def rate(self) -> float:
        """Processing rate: events accepted per second of :attr:`busy_seconds` (0 before any)."""
        return self.events_seen / self.busy_seconds if self._busy_ns else 0.0

    def __repr__(self) -> str:
        # Never raises: while a call holds the detector (another thread's push lets the GIL go
        # holding the engine, which refuses reads with a StreamError), what Python knows.
        fixed = (
            f"window_us={self._window_us}, overlap={self._overlap}, sensor_size={self._sensor_size}"
        )
        if not self._lock.locked():
            try:
                return (
                    f"Detector({fixed}, events_seen={self.events_seen}, "
                    f"windows_opened={self.windows_opened}, detections={self.detections_emitted})"
                )
            except StreamError:  # a call took it meanwhile
                pass
        return f"Detector({fixed}, in use)"


def _with_rotor(
    report: WindowReport, chunks: Sequence[np.ndarray]
) -> tuple[WindowReport, list[BoxMeasure]]:
    """``report`` with the rotor signature of its first :data:`MAX_ROTOR_BOXES` objects, from
    the raw events of ``chunks`` (time order, each chunk and across them) that fall in the
    window and the object's box; and for each of those objects, its rotor and the window's
    events in its box and ON ones among them (:func:`uavsnn.signature.measure_box`).

    The chunks are read in place: each one's slice in the window, nothing concatenated, and
    each object's box in one pass over them."""
    parts = []
    for chunk in chunks:
        t = chunk["t"]
        if len(t) and t[-1] >= report.t0 and t[0] < report.t1:
            # Binary searches on the times in place, only where the window cuts the chunk.
            lo = 0 if t[0] >= report.t0 else bisect.bisect_left(t, report.t0)
            hi = len(t) if t[-1] < report.t1 else bisect.bisect_left(t, report.t1)
            parts.append(chunk[lo:hi])
    rate = rate_bins(report.t0, report.t1 - report.t0)
    measured = [
        measure_box(parts, xywh(o.box), rate=rate) for o in report.objects[:MAX_ROTOR_BOXES]
    ]
    objects = list(report.objects)
    for i, m in enumerate(measured):
        objects[i] = replace(objects[i], rotor=m.rotor, counts=m.counts)
    return replace(report, objects=tuple(objects)), measured


def _with_scores(
    report: WindowReport, measured: list[BoxMeasure], identification: Any
) -> WindowReport:
    """``report`` with the UAV score and class guess of each object whose rotor was measured,
    from an ``identification`` model (:class:`uavsnn.identify.Identifier`): its features
    (:func:`uavsnn.features.object_features`) from its box, its rotor signature and event
    counts in the window (``measured``, :func:`uavsnn.signature.measure_box`, one per object
    from the first) and its track as they stand after this window."""
    from uavsnn.features import object_features

    objects = list(report.objects)
    for i, (obj, m) in enumerate(zip(objects, measured, strict=False)):
        if obj.rotor is None:
            continue
        feats = object_features(obj.box, obj.spikes, None, obj.rotor, obj.track, counts=m.counts)
        score = identification.scores(feats[None, :])
        probs = identification.class_probabilities(feats[None, :])
        guess = identification.guess_from(score, probs)[0]
        objects[i] = replace(
            obj,
            uav_score=float(score[0]),
            class_guess=guess,
            class_probabilities=tuple(float(v) for v in probs[0]),
        )
    return replace(report, objects=tuple(objects))
