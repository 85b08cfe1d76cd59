"""What every event source of :mod:`uavsnn.sources` shares: the chunks' container of counts
(:class:`SourceStats`), the base class (:class:`EventSource`), the clock of a quiet live stream
(:class:`IdleClock`) and the check of a wait in seconds. :mod:`uavsnn.sources` exports them; this
module exists so that each kind of source can live in a module of its own."""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from uavsnn import _core
from uavsnn._validate import MAX_TIME_US
from uavsnn.errors import ParameterError
from uavsnn.events import EVENT_DTYPE, packed_bytes

#: The longest ``idle_timeout`` (seconds, about 31 years): a socket's timeout holds no more.
MAX_IDLE_TIMEOUT = 1e9
# The chunk a live source yields when it has been silent (a heartbeat).
EMPTY = np.empty(0, dtype=EVENT_DTYPE)


@dataclass
class SourceStats:
    """What a source has received so far."""

    #: Events delivered.
    events: int = 0
    #: Packets (UDP datagrams, stdin reads or file chunks) received.
    packets: int = 0
    #: What was malformed and skipped: UDP packets; events (or CSV lines) on standard input.
    dropped: int = 0
    #: UDP datagrams the kernel dropped before they were read (its receive buffer full), as far
    #: as known; ``None`` where the source cannot tell (other sources; UDP off Linux).
    lost: int | None = None
    #: Times the sensor restarted: its clock went back and stayed back (UDP: for
    #: ``_core.RESTART_AFTER`` packets in a row; standard input: for
    #: :data:`STDIN_RESTART_EVENTS` events), so the
    #: events that follow are of a new stream, in time order from there. A consumer ends its
    #: windows of the old stream when this changes (``uavsnn detect`` flushes and resets its
    #: detector); the chunks never span a restart.
    restarts: int = 0


class IdleClock:
    """The time a quiet live stream is taken to have reached, for a consumer that advances its
    detector while the source is silent (``uavsnn detect --idle-flush``,
    :func:`uavsnn.distributed.detect_streams`' ``idle_flush_s``): the stream's last event time,
    moved on with the wall clock since that event arrived, less ``lag_s`` seconds (which must
    cover the sender's batching); and the events that arrive stamped before it, which the
    consumer drops. ``lag_s=None``: never moves on.

    Feed it each chunk pushed (:meth:`heard`); at each heartbeat (an empty chunk from a source
    opened with ``heartbeat_s=IdleClock.heartbeat_for(lag_s)``) advance the detector to
    :meth:`mark`; before pushing a chunk, drop its first :meth:`late` events.
    """

    def __init__(self, lag_s: float | None) -> None:
        self.lag_s = check_seconds("lag_s", lag_s)
        self.last_t: int | None = None
        self.heard_at = 0.0
        self.reached = 0  # the latest time the stream was advanced to

    @staticmethod
    def heartbeat_for(lag_s: float | None) -> float | None:
        """The heartbeat a source needs for the stream's time to move on smoothly while it is
        quiet: a quarter of ``lag_s`` (at least 10 ms); ``None`` for ``None``."""
        return None if lag_s is None else max(0.01, lag_s / 4)

    def heard(self, chunk: np.ndarray) -> None:
        """``chunk`` (not empty) was pushed."""
        self.last_t = int(chunk["t"][-1])
        self.heard_at = time.monotonic()

    def mark(self) -> int | None:
        """The time to advance the stream to, when it has moved on since the last one."""
        if self.lag_s is None or self.last_t is None:
            return None
        moved = time.monotonic() - self.heard_at - self.lag_s
        mark = min(self.last_t + int(moved * 1e6), MAX_TIME_US) if moved > 0 else 0
        if mark <= max(self.reached, self.last_t):
            return None
        self.reached = mark
        return mark

    def late(self, chunk: np.ndarray) -> int:
        """How many of ``chunk``'s first events are stamped before the time reached."""
        if not self.reached or int(chunk["t"][0]) >= self.reached:
            return 0
        return int(np.searchsorted(chunk["t"], np.uint64(self.reached), "left"))


# A source's own type, which ``with`` gives back (``with FileSource(p) as f: f.recording``).
_Source = TypeVar("_Source", bound="EventSource")


class EventSource:
    """Base of the sources: iterate to receive chunks of events in time order."""

    #: Sensor size ``(width, height)`` of the events yielded; ``None`` when the source cannot
    #: tell.
    sensor_size: tuple[int, int] | None = None
    #: The sensor the events arrive from, where a live source crops and scales them onto
    #: :attr:`sensor_size` (its ``downsample_to``, as :func:`uavsnn.filters.downsample`
    #: does a file); ``None`` where it does not.
    camera_size: tuple[int, int] | None = None
    _scale: tuple[int, int, int, int] | None = None
    #: Seconds of silence after which a live source yields an empty chunk, a heartbeat, and
    #: again after as many more (for a consumer that advances its stream's time when it falls
    #: silent: ``uavsnn detect --idle-flush``); ``None``: never. Files never do.
    heartbeat_s: float | None = None

    def __init__(self) -> None:
        self.stats = SourceStats()

    def __iter__(self) -> Iterator[np.ndarray]:
        raise NotImplementedError

    def _downsample_to(self, target: tuple[int, int] | None) -> None:
        """Crop and scale the events of every later chunk from :attr:`sensor_size` onto
        ``target`` (``None``, or the sensor's own size: as they are).

        Raises:
            ParameterError: ``target`` wider or taller than the sensor (it only reduces).
        """
        if target is None or self.sensor_size is None:
            return
        from uavsnn.filters import check_target

        tw, th = check_target(self.sensor_size, target)
        if (tw, th) != self.sensor_size:
            self.camera_size = self.sensor_size
            self._scale = (*self.sensor_size, tw, th)
            self.sensor_size = (tw, th)

    @property
    def _arriving(self) -> tuple[int, int] | None:
        """The sensor size the events arrive in (before any downsampling), which they are
        checked against."""
        return self.camera_size if self.camera_size is not None else self.sensor_size

    def _scaled(self, chunk: np.ndarray) -> np.ndarray:
        """``chunk`` on :attr:`sensor_size`: cropped and scaled where the source downsamples
        (events outside the crop removed; a chunk may come out empty)."""
        if self._scale is None or not len(chunk):
            return chunk
        packed = _core.downsample_events(packed_bytes(chunk), *self._scale)
        return packed.view(EVENT_DTYPE)

    def close(self) -> None:
        """Release what the source holds (sockets); iterating afterwards is an error."""

    def __enter__(self: _Source) -> _Source:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def check_seconds(name: str, value: float | None) -> float | None:
    """A wait in seconds (``idle_timeout``, ``heartbeat_s``, an idle flush's lag; ``name`` as the
    caller spells it): ``None``, or more than 0 and at most :data:`MAX_IDLE_TIMEOUT` (a
    socket's timeout holds no more)."""
    if value is not None and not 0 < value <= MAX_IDLE_TIMEOUT:
        raise ParameterError(
            f"{name} must be > 0 and at most {MAX_IDLE_TIMEOUT:g} seconds, got {value}"
        )
    return value
