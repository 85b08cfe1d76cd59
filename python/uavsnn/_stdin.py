"""Events from standard input (or any binary stream): :class:`StdinSource`, exported by
:mod:`uavsnn.sources`, whose module documentation describes the formats read and how a
restarted sensor is taken."""

from __future__ import annotations

import os
import select
import sys
from collections.abc import Iterator
from io import TextIOBase
from typing import IO, Any

import numpy as np

from uavsnn import _csv
from uavsnn._source_base import EMPTY, EventSource, check_seconds
from uavsnn._validate import MAX_TIME_US, check_sensor_size
from uavsnn.errors import ParameterError, RecordingFileError, StreamError
from uavsnn.events import EVENT_DTYPE, SensorSizeLike
from uavsnn.io import CSV_MAX_LINE

#: Formats of standard input understood by :class:`StdinSource`.
STDIN_FORMATS: tuple[str, ...] = ("packed", "csv")
#: Usable events in a row going back in time after which standard input's events are taken
#: for a restarted sensor's, a new stream from the first of them (UDP counts packets instead:
#: ``_core.RESTART_AFTER``).
STDIN_RESTART_EVENTS = 1024
#: The first events of standard input whose share off the sensor decides
#: :attr:`StdinSource.size_note` (more than half off: most likely the wrong sensor size).
SIZE_CHECK_EVENTS = 10_000

_RECORD = EVENT_DTYPE.itemsize
# The latest event time the engine takes, as the events' dtype.
_MAX_TIME_US = np.uint64(MAX_TIME_US)


class StdinSource(EventSource):
    """Events from a binary stream (standard input by default).

    Args:
        stream: a binary file object (``read1`` or ``read`` returning ``bytes``: a file opened
            ``"rb"``, ``sys.stdin.buffer``, ``io.BytesIO``); ``sys.stdin.buffer`` when ``None``.
            A text stream is refused (:class:`~uavsnn.ParameterError`).
        fmt: ``"packed"`` (13-byte records) or ``"csv"`` (``t,x,y,p`` lines).
        sensor_size: ``(width, height)``; events outside it or going back in time are dropped
            one by one (``None``: only times are checked).
        read_size: most bytes read at once; a read returns what is available, so a slow
            producer's events are not held back waiting for a full buffer.
        downsample_to: ``(width, height)`` to crop and scale each chunk onto, from
            ``sensor_size`` (:func:`uavsnn.filters.downsample`'s rule, which it needs: a
            larger target is refused), e.g. a model's input; :attr:`sensor_size` is then the
            target and :attr:`camera_size` the sensor's. ``None`` keeps them.
    """

    def __init__(
        self,
        stream: IO[bytes] | None = None,
        *,
        fmt: str = "packed",
        sensor_size: SensorSizeLike | None = None,
        read_size: int = 1 << 16,
        heartbeat_s: float | None = None,
        downsample_to: tuple[int, int] | None = None,
    ) -> None:
        super().__init__()
        self.heartbeat_s = check_seconds("heartbeat_s", heartbeat_s)
        if downsample_to is not None and sensor_size is None:
            raise ParameterError("downsample_to needs the sensor_size the events arrive in")
        if fmt not in STDIN_FORMATS:
            raise ParameterError(f"stdin format must be one of {STDIN_FORMATS}, got {fmt!r}")
        if read_size < _RECORD:
            raise ParameterError(f"read_size must be >= {_RECORD}, got {read_size}")
        if stream is not None and (
            isinstance(stream, TextIOBase)
            or not (hasattr(stream, "read1") or hasattr(stream, "read"))
        ):
            raise ParameterError(_not_binary(stream))
        self.stream = stream if stream is not None else sys.stdin.buffer
        self.fmt = fmt
        self.sensor_size = None if sensor_size is None else check_sensor_size(sensor_size)
        self._downsample_to(downsample_to)
        self.read_size = read_size
        self._lines = 0
        # The columns of t, x, y, p, and how many a line has (as a header names them).
        self._columns = dict(_csv.DEFAULT_COLUMNS)
        self._width = 4
        self._last_t = 0
        self._back_run = 0  # usable events in a row that went back, up to now
        self._held: list[np.ndarray] = []  # those events, while their run is short
        #: Set once, when more than half of the first :data:`SIZE_CHECK_EVENTS` events (or of
        #: a shorter stream's) lie off the sensor: what they reach, and that the size given is
        #: most likely wrong (each is otherwise one quiet drop). ``None`` until then.
        self.size_note: str | None = None
        self._checked = self._off = 0  # of those first events: counted, off the sensor
        self._reach = (0, 0)  # the largest x and y among them
        # With heartbeats the descriptor is read directly, once select says it holds bytes (a
        # buffered reader may hold bytes select cannot see); a stream without one has none.
        self._fd: int | None = None
        if self.heartbeat_s is not None and sys.platform == "win32":
            raise ParameterError(
                "heartbeats on standard input (--idle-flush) wait on it with select(), which "
                "Windows has only for sockets: send the events over UDP instead"
            )
        if self.heartbeat_s is not None:
            try:
                self._fd = self.stream.fileno()
            except (AttributeError, OSError, ValueError):
                self._fd = None

    def _read(self) -> bytes | None:
        """The next bytes (empty at the end), or ``None`` after :attr:`heartbeat_s` of
        silence."""
        if self._fd is not None:
            ready, _, _ = select.select([self._fd], [], [], self.heartbeat_s)
            return os.read(self._fd, self.read_size) if ready else None
        read1 = getattr(self.stream, "read1", None)
        data = read1(self.read_size) if read1 is not None else self.stream.read(self.read_size)
        if isinstance(data, str):
            raise ParameterError(_not_binary(self.stream))
        return data

    def __iter__(self) -> Iterator[np.ndarray]:
        rest = b""
        skipping = False  # inside a CSV line too long to keep, until its line end
        at_start = self.fmt == "csv"  # a CSV stream's UTF-8 byte-order mark is yet to be seen
        while True:
            data = self._read()
            if data is None:
                yield EMPTY  # silence: a heartbeat
                continue
            if not data:
                break
            self.stats.packets += 1
            data = rest + data
            if self.fmt == "packed":
                whole = len(data) - len(data) % _RECORD
                rest = data[whole:]
                chunk = np.frombuffer(data[:whole], dtype=EVENT_DTYPE)
            else:
                if at_start:
                    # A byte-order mark is dropped, as a file's is (one cut across reads too).
                    if len(data) < len(_csv.BOM) and _csv.BOM.startswith(data):
                        rest = data
                        continue
                    at_start = False
                    data = data.removeprefix(_csv.BOM)
                # A line ends at "\n", "\r\n" or a lone "\r" (old Mac line ends); the "\n" of a
                # "\r\n" cut across reads starts a blank line.
                if skipping:
                    ends = [end for end in (data.find(b"\n"), data.find(b"\r")) if end >= 0]
                    data = data[min(ends) + 1 :] if ends else b""
                    skipping = not ends
                cut = max(data.rfind(b"\n"), data.rfind(b"\r")) + 1
                rest = data[cut:]
                if len(rest) > CSV_MAX_LINE:
                    # Not an event line: dropped, not held (its end is skipped as it comes).
                    rest, skipping = b"", True
                    self.stats.dropped += 1
                    self._lines += 1
                chunk = self._parse_csv(data[:cut])
            self._check_size(chunk)
            for part in self._usable(chunk):
                self.stats.events += len(part)
                yield from self._kept(part)
        if rest:
            if self.fmt == "csv":
                for part in self._usable(self._parse_csv(rest + b"\n")):
                    self.stats.events += len(part)
                    yield from self._kept(part)
            else:
                # A truncated last record: its bytes never made an event.
                self.stats.dropped += 1
        self._drop_held()  # a run going back too short to be a restart
        self._size_verdict()  # a stream shorter than SIZE_CHECK_EVENTS
        # Nothing usable, whether or not anything was dropped (an empty stream, a header
        # alone, one line taken as a header): most likely the wrong format.
        if self.stats.events == 0:
            raise StreamError(
                f"standard input held no usable {self.fmt} event ({self.stats.dropped} dropped): "
                "is --stdin-format right, and the sensor size?"
            )

    def _kept(self, part: np.ndarray) -> Iterator[np.ndarray]:
        """``part`` on :attr:`sensor_size` (downsampled where asked), unless the crop left none
        of it: an empty chunk stands for silence (a heartbeat)."""
        scaled = self._scaled(part)
        if len(scaled):
            yield scaled

    def _check_size(self, chunk: np.ndarray) -> None:
        """Count the events of ``chunk`` among the first :data:`SIZE_CHECK_EVENTS` that lie off
        the sensor, and set :attr:`size_note` once they are all seen."""
        if self._arriving is None or self._checked >= SIZE_CHECK_EVENTS or not len(chunk):
            return
        head = chunk[: SIZE_CHECK_EVENTS - self._checked]
        width, height = self._arriving
        self._off += int(np.count_nonzero((head["x"] >= width) | (head["y"] >= height)))
        self._reach = (
            max(self._reach[0], int(head["x"].max())),
            max(self._reach[1], int(head["y"].max())),
        )
        self._checked += len(head)
        if self._checked >= SIZE_CHECK_EVENTS:
            self._size_verdict()

    def _size_verdict(self) -> None:
        if self.size_note is None and self._arriving is not None and 2 * self._off > self._checked:
            width, height = self._arriving
            self.size_note = (
                f"{self._off} of the first {self._checked} events lie off the {width}x{height} "
                f"sensor (x up to {self._reach[0]}, y up to {self._reach[1]}) and are dropped: "
                "is the sensor size right (--sensor-size)?"
            )

    def _usable(self, chunk: np.ndarray) -> Iterator[np.ndarray]:
        """The events of ``chunk`` inside the sensor and not earlier than any event before them
        (each other one is a drop), in one part; in two where the sensor restarted inside it
        (:data:`STDIN_RESTART_EVENTS` usable events in a row went back), with
        :attr:`SourceStats.restarts` counted between them (once the first part is taken).

        Events going back at the end of a chunk are held, not dropped, while their run is
        shorter than a restart's: if it becomes one, they are the new stream's first events."""
        while len(chunk):
            t = chunk["t"]
            inside = t <= _MAX_TIME_US
            if self._arriving is not None:
                width, height = self._arriving
                inside &= (chunk["x"] < width) & (chunk["y"] < height)
            # The latest time before each event, among the usable ones: a backwards event is
            # dropped alone, not the events that follow it.
            times = np.where(inside, t, np.uint64(0))
            first = np.array([self._last_t], dtype=np.uint64)
            before = np.maximum.accumulate(np.concatenate((first, times[:-1])))
            ok = inside & (t >= before)
            back = inside & ~ok
            restart = self._restart_point(inside, ok)
            if restart is None:
                oks = np.flatnonzero(ok)
                if len(oks):  # the run held so far is broken: those events are dropped
                    self._drop_held()
                # The run the chunk ends in (after its last good event) is held.
                tail = back.copy()
                tail[: (int(oks[-1]) + 1 if len(oks) else 0)] = False
                if tail.any():
                    self._held.append(chunk[tail])
                kept = chunk if ok.all() else chunk[ok]
                self.stats.dropped += len(chunk) - len(kept) - int(tail.sum())
                if len(kept):
                    self._last_t = max(self._last_t, int(kept["t"][-1]))
                    yield kept
                return
            begin, carried = restart
            head, head_ok = chunk[:begin], ok[:begin]
            kept = head if head_ok.all() else head[head_ok]
            self.stats.dropped += len(head) - len(kept)
            replay = self._held if carried else []
            if not carried:
                self._drop_held()
            self._held = []
            if len(kept):
                self._last_t = max(self._last_t, int(kept["t"][-1]))
                yield kept
            # The run's events, held ones first, start a new stream from their own clock.
            self.stats.restarts += 1
            self._last_t, self._back_run = 0, 0
            chunk = np.concatenate([*replay, chunk[begin:]])

    def _drop_held(self) -> None:
        self.stats.dropped += sum(len(h) for h in self._held)
        self._held = []

    def _restart_point(self, inside: np.ndarray, ok: np.ndarray) -> tuple[int, bool] | None:
        """Where in the chunk a run of :data:`STDIN_RESTART_EVENTS` usable events going back
        starts, and whether it began before the chunk (its first events held); ``None`` when
        none does, keeping the length of the run the chunk ends in."""
        at = np.flatnonzero(inside)
        if not len(at):
            return None
        back = ~ok[at]
        index = np.arange(len(at))
        # For each usable event, the last one before or at it that did not go back (-1: none).
        last = np.maximum.accumulate(np.where(back, -1, index))
        run = np.where(last < 0, index + 1 + self._back_run, index - last)
        hit = np.flatnonzero(back & (run >= STDIN_RESTART_EVENTS))
        if len(hit):
            begin = int(last[hit[0]]) + 1
            carried = begin == 0 and self._back_run > 0
            return (0 if carried else int(at[begin])), carried
        self._back_run = int(run[-1]) if back[-1] else 0
        return None

    def _set_columns(self, named: dict[str, int], width: int) -> dict[str, int]:
        """Read the columns a header names (a line then has its ``width`` fields); the default
        order, a line of 4."""
        self._columns = named
        self._width = 4 if named == _csv.DEFAULT_COLUMNS else width
        return named

    def _parse_csv(self, text: bytes) -> np.ndarray:
        rows: list[tuple[int, int, int, bool]] = []
        at = self._columns
        for line in text.splitlines():
            fields = line.strip()
            if not fields:
                continue
            if fields[:1] == b"#":
                # A comment, skipped; before the header and the first event, one that names
                # the four columns (``# x,y,t,p``) names them, as in a file.
                named = _csv.comment_columns(fields) if self._lines == 0 else None
                if named is not None:
                    at = self._set_columns(named, len(fields.split(b",")))
                continue
            try:
                values = fields.split(b",")
                if len(values) != self._width:
                    raise ValueError
                t, x, y, p = (int(values[at[field]]) for field in "txyp")
                # A time beyond 64 bits is as malformed as a negative one.
                if not (0 <= t < 1 << 64 and 0 <= x < 65536 and 0 <= y < 65536):
                    raise ValueError
            except ValueError:
                # The stream's first line (but comments) may be a header (naming the columns,
                # or not) unless it starts with a number; any other bad line is a drop. One
                # naming some columns out of the default order, but not all four, is refused
                # (read in that order, its events would be wrong).
                header = self._lines == 0 and not _csv.is_number(fields.split(b",", 1)[0])
                if header:
                    try:
                        named = _csv.columns(fields)
                    except RecordingFileError as exc:
                        raise StreamError(f"standard input: {exc}") from exc
                    at = self._set_columns(named, len(fields.split(b",")))
                self.stats.dropped += not header
                self._lines += 1
                continue
            self._lines += 1
            rows.append((t, x, y, p > 0))
        if not rows:
            return EMPTY
        return np.array(rows, dtype=EVENT_DTYPE)


def _not_binary(stream: Any) -> str:
    got = type(stream).__name__
    if isinstance(stream, TextIOBase):
        got = f"a text stream ({got})"
    return (
        "stream must be a binary stream (its read1 or read returning bytes: a file opened "
        f"'rb', sys.stdin.buffer, io.BytesIO), got {got}"
        + (": pass sys.stdin.buffer" if stream is sys.stdin else "")
    )
