"""Run a :class:`~uavsnn.detector.Detector` over a live source (:mod:`uavsnn.sources`): the
loop ``uavsnn detect`` and :func:`uavsnn.distributed.detect_streams`' workers run, for a program
of its own as well (docs/streaming.md).

    >>> from uavsnn.driver import StreamDriver
    >>> for step in StreamDriver(source, detector, idle_flush_s=0.5, windows=True):
    ...     if step.kind == "found" and step.found:
    ...         ...
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

from uavsnn.errors import EventError, ParameterError, StreamError, UavsnnError
from uavsnn.sources import (
    EventSource,
    FileSource,
    IdleClock,
    StdinSource,
    UdpSource,
    check_seconds,
)

if TYPE_CHECKING:
    import numpy as np

    from uavsnn.detector import Detector
    from uavsnn.grouping import WindowReport
    from uavsnn.tracks import Track

__all__ = ["StreamDriver", "StreamStep"]


@dataclass(frozen=True)
class StreamStep:
    """What a :class:`StreamDriver` did with one chunk (or heartbeat) of its source.

    ``kind``: ``"found"`` (a chunk pushed, or the stream advanced or flushed: ``found`` holds
    what the detector returned, ``None`` at a heartbeat that moved nothing); ``"refused"``
    (the detector refused a chunk, ``error`` says why; its ``events`` are counted in
    :attr:`StreamDriver.rejected`, the stream goes on); ``"restarted"`` (the sensor restarted:
    the old stream's windows were flushed in the step before, and the detector is reset once
    the step has been taken; ``t`` is the new stream's first time, and ``tracks`` the old
    stream's tracks not yet drained: its tracker's ``finish()``, the tracks it deleted that
    ``drain_ended()`` has not taken, then those still live, as they stood at its last window;
    the new stream's track ids start from 1 again). ``tracks`` is empty at every other step,
    and at a restart without ``windows`` (nothing fed the tracker)."""

    kind: str
    found: np.ndarray | list[WindowReport] | None = None
    error: UavsnnError | None = None
    events: int = 0
    t: int = 0
    tracks: tuple[Track, ...] = ()


class StreamDriver:
    """Drive a :class:`~uavsnn.detector.Detector` over a live source's chunks, as ``uavsnn
    detect`` and :func:`uavsnn.distributed.detect_streams`' workers do: iterate to run it, one
    :class:`StreamStep` per chunk.

    - A chunk the detector refuses (an event outside the sensor, out of order) is skipped and
      its events counted in :attr:`rejected`; the stream goes on. A push stopped part way
      (the detector ``interrupted``) raises: the stream cannot go on.
    - With ``idle_flush_s`` (open the source with ``heartbeat_s=IdleClock.heartbeat_for(
      idle_flush_s)``) a quiet stream's time moves on with the wall clock
      (:class:`~uavsnn.sources.IdleClock`, :attr:`idle`): its windows close without waiting
      for the next event, and the events that arrive stamped before the time reached are
      dropped and counted in :attr:`rejected`.
    - At a sensor restart (:attr:`uavsnn.sources.SourceStats.restarts`) the old stream's
      windows are flushed, then the detector is reset for the new stream; the ``"restarted"``
      step carries the old stream's tracks that were not drained (:attr:`StreamStep.tracks`),
      which the reset would otherwise forget.
    - At the source's end the windows still open are flushed.

    ``windows``: push with ``push_windows`` (closed windows, each with its objects) instead of
    ``push`` (detections). After an interruption (Ctrl-C), :meth:`flush` reports what is still
    open unless the detector was stopped inside its own work.

    Raises:
        ParameterError: a ``source`` that is no :class:`~uavsnn.sources.EventSource`, a
            ``detector`` that is no :class:`~uavsnn.detector.Detector`, a bad
            ``idle_flush_s``, or one given for a file (:class:`~uavsnn.sources.FileSource`,
            which never goes quiet) or for a standard input or UDP source opened without
            ``heartbeat_s`` (it would never be woken to move the stream on)."""

    def __init__(
        self,
        source: EventSource,
        detector: Detector,
        *,
        idle_flush_s: float | None = None,
        windows: bool = False,
    ) -> None:
        from uavsnn.detector import Detector

        if not isinstance(source, EventSource):
            raise ParameterError(
                "source must be a uavsnn.sources.EventSource (a FileSource, StdinSource, "
                f"UdpSource, or what open_source returns), got {type(source).__name__}"
            )
        if not isinstance(detector, Detector):
            raise ParameterError(
                f"detector must be a uavsnn.detector.Detector, got {type(detector).__name__}"
            )
        if idle_flush_s is not None:
            check_seconds("idle_flush_s", idle_flush_s)
            if isinstance(source, FileSource):
                raise ParameterError(
                    "idle_flush_s applies to live sources (standard input, UDP): a file ends "
                    "by itself and never goes quiet; leave it out"
                )
            if isinstance(source, (StdinSource, UdpSource)) and source.heartbeat_s is None:
                raise ParameterError(
                    "idle_flush_s needs the source's heartbeats: open it with "
                    "heartbeat_s=IdleClock.heartbeat_for(idle_flush_s)"
                )
        self.source = source
        self.detector = detector
        self.windows = bool(windows)
        self.idle = IdleClock(idle_flush_s)
        #: Events the detector did not take: in chunks it refused, or stamped before the time
        #: a quiet stream was taken to have reached.
        self.rejected = 0
        self._restarts = source.stats.restarts
        # The detector's counts of the streams before a sensor restart (it starts again).
        self._before = (0, 0, 0)

    @property
    def events_seen(self) -> int:
        """Events the detector took, over every stream since the first (it counts again from
        zero after a sensor restart)."""
        return self._before[0] + self.detector.events_seen

    @property
    def windows_opened(self) -> int:
        """Windows the detector opened, over every stream since the first."""
        return self._before[1] + self.detector.windows_opened

    @property
    def detections_emitted(self) -> int:
        """Detections the detector emitted, over every stream since the first."""
        return self._before[2] + self.detector.detections_emitted

    def flush(self) -> np.ndarray | list[WindowReport]:
        """End the stream's windows: what the detector's ``flush`` (``flush_windows``) gives."""
        d = self.detector
        return d.flush_windows() if self.windows else d.flush()

    def __iter__(self) -> Iterator[StreamStep]:
        d = self.detector
        push = d.push_windows if self.windows else d.push
        advance = d.advance_windows if self.windows else d.advance
        for chunk in self.source:
            if not len(chunk):  # a heartbeat: the source is quiet
                mark = self.idle.mark()
                yield StreamStep("found", None if mark is None else advance(mark))
                continue
            if self.source.stats.restarts != self._restarts:
                # The sensor restarted (its clock went back and stayed back): end the old
                # stream's windows, and start the detector again on the new one.
                self._restarts = self.source.stats.restarts
                yield StreamStep("found", self.flush())
                # The old stream's tracks, ended: those the caller did not drain after the
                # flush, and those live at its last window (the reset would drop them).
                ended = tuple(d.tracker.finish()) if self.windows else ()
                yield StreamStep("restarted", t=int(chunk["t"][0]), tracks=ended)
                self._before = (self.events_seen, self.windows_opened, self.detections_emitted)
                d.reset()
                self.idle = IdleClock(self.idle.lag_s)
            late = self.idle.late(chunk)
            if late:  # stamped before a time the stream was taken to have reached
                self.rejected += late
                chunk = chunk[late:]
                if not len(chunk):
                    continue
            try:
                found = push(chunk)
            except (EventError, StreamError) as exc:
                if d.interrupted:
                    raise  # not a chunk refused: the stream cannot go on
                self.rejected += len(chunk)
                yield StreamStep("refused", error=exc, events=len(chunk))
                continue
            self.idle.heard(chunk)
            yield StreamStep("found", found)
        yield StreamStep("found", self.flush())
