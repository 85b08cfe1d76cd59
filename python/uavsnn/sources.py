"""Live event sources for streaming detection: a recording file, standard input, a UDP socket.

Every source is an iterable of event chunks (1-D arrays of :data:`uavsnn.EVENT_DTYPE`, in time
order) with a :class:`SourceStats` of what it received and dropped. Open one from a command-line
spelling with :func:`open_source`; run a :class:`~uavsnn.detector.Detector` over it with
:class:`uavsnn.driver.StreamDriver`, the loop ``uavsnn detect`` runs.

Formats read
------------
File
    Any recording :func:`uavsnn.io.read` reads (AEDAT4, RAW EVT2/EVT3, DAT, ES, CSV, ``.npz`` /
    ``.npy``). Chunks of ``chunk_events`` events as fast as possible, or, with ``realtime``,
    chunks of ``chunk_us`` of event time released at the recording's own pace.
Standard input (``-``)
    ``packed``: the canonical 13-byte little-endian records ``t u64, x u16, y u16, p u8``
    (``events.tobytes()`` of an ``EVENT_DTYPE`` array); a record split across reads is kept until
    its end arrives. ``csv``: one ``t,x,y,p`` line per event (integers; ``p`` is 1/0 or 1/-1, any
    value > 0 is ON; a first line that is not numbers is taken as a header, and if it names the
    four columns in another order, as :func:`uavsnn.io.read` reads them, that order is read;
    one that names some of them, not all four, where the default order does not put them is
    refused with a :class:`~uavsnn.StreamError`). As in a CSV file, a leading UTF-8
    byte-order mark is dropped, and lines starting with ``#`` are comments, skipped wherever
    they are (the header is the first line that is not one; without a header, a comment
    before the first event naming all four columns, ``# x,y,t,p``, names them). Lines end at
    ``\n``, ``\r\n`` or a lone ``\r`` (a file's lone ``\r`` is refused: faery reads none).
    Each event that cannot be used — a malformed line, a line longer than
    :data:`uavsnn.io.CSV_MAX_LINE` bytes (not held: its bytes are skipped up to its end), an
    event outside the sensor, a time earlier than an event before it — is dropped alone and
    counted in :attr:`SourceStats.dropped`; the events around it are kept. A stream that ends
    without a single usable event raises :class:`~uavsnn.StreamError` (most likely the wrong
    ``--stdin-format``).
UDP (``udp://HOST:PORT``)
    One datagram = one packet, decoded whole or dropped (:class:`uavsnn._core.PacketDecoder`):

    - ``t64_x16_y16_on8`` (faery's default ``UdpFormat``): 13-byte records as above.
    - ``t32_x16_y15_on1`` (faery's compact ``UdpFormat``): 8-byte little-endian records
      ``t u32, x u16, y_on u16`` with ``y = y_on >> 1`` and ``on = y_on & 1``; the 32-bit time
      is unwrapped (a jump back by more than 2**31 µs is a wrap, as faery's receiver reads it).
    - ``spif`` (aestream's UDP output, the spif/spiffer event word): little-endian 32-bit words,
      bit 31 = no-timestamp flag, bits 30..16 = x, bit 15 = polarity, bits 14..0 = y; when bit 31
      is clear the next word is the event's u32 time in µs. Events without a time (aestream's
      default) are stamped with the time their packet is read from the socket (a monotonic
      clock, in µs since the source opened), not the time it arrived: packets that wait in the
      socket's buffer while the consumer works on a chunk are stamped together when read, so a
      consumer that falls behind compresses the stream's time. Send timestamped packets where
      that matters.

    A packet that is not a whole number of records, holds an event outside the sensor, goes back
    in time, or mixes stamped and unstamped ``spif`` events is counted in
    :attr:`SourceStats.dropped` and skipped; it never stops the stream. The socket asks the
    kernel for a receive buffer of :data:`RECEIVE_BUFFER` bytes; :attr:`UdpSource.buffer_note`
    says when it granted less (packets beyond it are dropped by the kernel). On Linux the
    datagrams the kernel dropped for want of room are counted in :attr:`SourceStats.lost`
    (``SO_RXQ_OVFL``; a drop is known when the next datagram is read).

A sensor that restarts
----------------------
A restarted sensor (or one whose driver restarts) sends times from zero again, and an event
stamped far ahead by a glitch moves the stream's last time there: every later event would go
back in time and be dropped until the new clock passed the old one, hours later. So a clock that
goes back and stays back starts a new stream: on UDP, after ``_core.RESTART_AFTER`` (8) packets
in a row refused for going back, the next one, with those 8 (held meanwhile, up to
``_core.MAX_HELD_BYTES``, and no longer counted as dropped once taken back); on standard input,
from the first of :data:`STDIN_RESTART_EVENTS` (1024) usable events in a row that went back
(held likewise). Either way none of the new stream is lost. Each restart is
counted in :attr:`SourceStats.restarts`, and no chunk spans one: a consumer ends its windows of
the old stream when the count changes (``uavsnn detect`` reports them, says so on standard
error and starts its detector again).
"""

from __future__ import annotations

import os
import socket
import sys
import time
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import numpy as np

from uavsnn import _core
from uavsnn._source_base import (
    EMPTY,
    MAX_IDLE_TIMEOUT,
    EventSource,
    IdleClock,
    SourceStats,
    check_seconds,
)
from uavsnn._stdin import SIZE_CHECK_EVENTS, STDIN_FORMATS, STDIN_RESTART_EVENTS, StdinSource
from uavsnn._validate import check_sensor_size
from uavsnn.errors import ParameterError, UavsnnError
from uavsnn.events import EVENT_DTYPE, SensorSizeLike

__all__ = [
    "MAX_IDLE_TIMEOUT",
    "PACKET_FORMATS",
    "RECEIVE_BUFFER",
    "SIZE_CHECK_EVENTS",
    "STDIN_FORMATS",
    "STDIN_RESTART_EVENTS",
    "EventSource",
    "FileSource",
    "IdleClock",
    "SourceStats",
    "StdinSource",
    "UdpSource",
    "check_applies",
    "check_fits",
    "check_seconds",
    "is_live",
    "open_source",
    "source_options",
]

#: UDP packet formats understood by :class:`UdpSource`.
PACKET_FORMATS: tuple[str, ...] = tuple(_core.PACKET_FORMATS)

#: The receive buffer (bytes) a :class:`UdpSource` asks the kernel for.
RECEIVE_BUFFER = 1 << 22
# Linux's SO_RXQ_OVFL (socket(7); Python's socket module does not name it): each datagram then
# carries the count of datagrams the socket dropped, since it opened, before this one was queued.
_SO_RXQ_OVFL = 40


class FileSource(EventSource):
    """A recording file, replayed as fast as possible or at its own pace.

    Args:
        path: any file :func:`uavsnn.io.read` reads.
        sensor_size: overrides the file's sensor size (required for files that have none).
        realtime: release each chunk when the wall clock since the start reaches its event
            time since the first event.
        chunk_events: events per chunk when not ``realtime``.
        chunk_us: event time per chunk when ``realtime``.
        downsample_to: ``(width, height)`` to crop and scale the recording to
            (:func:`uavsnn.filters.downsample`), e.g. a model's input size; ``None`` keeps it.
            Downsampling only reduces: a target wider or taller than the recording's sensor
            is refused (:class:`~uavsnn.ParameterError`).
    """

    def __init__(
        self,
        path: str | Path,
        *,
        sensor_size: SensorSizeLike | None = None,
        realtime: bool = False,
        chunk_events: int = 4096,
        chunk_us: int = 1000,
        downsample_to: tuple[int, int] | None = None,
    ) -> None:
        super().__init__()
        from uavsnn import filters, io

        if chunk_events < 1 or chunk_us < 1:
            raise ParameterError(
                f"chunk_events and chunk_us must be >= 1, got {chunk_events} and {chunk_us}"
            )
        target = None if downsample_to is None else check_sensor_size(downsample_to)
        #: The file read.
        self.path = Path(path)
        self.recording = io.read(path, sensor_size=sensor_size)
        if target is not None and self.recording.sensor_size != target:
            w, h = self.recording.sensor_size
            if self.recording.metadata.get("sensor_size_source") == "fallback":
                # Cropping faery's guess to the target's aspect would drop events silently.
                raise ParameterError(
                    f"{path} records no sensor size ({w}x{h} is only a stand-in): give its "
                    "sensor size, then it can be downsampled"
                )
            try:  # a larger target is refused: downsampling only reduces
                self.recording = filters.downsample(self.recording, target)
            except ParameterError as exc:
                raise ParameterError(f"{path}: {exc}") from None
        self.sensor_size = self.recording.sensor_size
        self.realtime = realtime
        self.chunk_events = chunk_events
        self.chunk_us = chunk_us

    def __iter__(self) -> Iterator[np.ndarray]:
        events = self.recording.events
        if len(events) == 0:
            return
        if not self.realtime:
            for i in range(0, len(events), self.chunk_events):
                chunk = events[i : i + self.chunk_events]
                self._count(chunk)
                yield chunk
            return
        # Contiguous: searchsorted copies a field of the structured array at each call (each
        # chunk cost the rest of the recording; 2 s of a 640x480 camera took 47 s to replay).
        t = np.ascontiguousarray(events["t"])
        first = int(t[0])
        start_wall = time.monotonic()
        begin = 0
        while begin < len(events):
            # The chunk_us-long slot from the first event that holds the next event (empty
            # slots are skipped), found from where the last chunk ended: nothing is held for
            # the recording's whole span, however long its gaps.
            edge = first + ((int(t[begin]) - first) // self.chunk_us + 1) * self.chunk_us
            if edge >> 64:  # past any u64 time: the rest of the recording
                end = len(events)
            else:
                end = begin + int(np.searchsorted(t[begin:], np.uint64(edge), side="left"))
            # The chunk is complete once the clock passes its slot's end.
            wait = (edge - first) / 1e6 - (time.monotonic() - start_wall)
            if wait > 0:
                time.sleep(wait)
            chunk = events[begin:end]
            begin = end
            self._count(chunk)
            yield chunk

    def _count(self, chunk: np.ndarray) -> None:
        self.stats.packets += 1
        self.stats.events += len(chunk)


class UdpSource(EventSource):
    """Events received as UDP packets on ``host:port`` (see the module docs for the formats).

    Args:
        host: address to bind, e.g. ``"127.0.0.1"``.
        port: port to bind; 0 picks a free one (read it back from :attr:`address`).
        fmt: one of :data:`PACKET_FORMATS`.
        sensor_size: ``(width, height)`` the events must lie in (packets carry no size).
        max_packets: stop after this many datagrams (dropped ones included); ``None``: never.
        idle_timeout: stop when no datagram arrived for this many seconds; ``None``: never.
        receive_buffer: the socket's receive buffer to ask the kernel for, in bytes (a burst
            beyond it is dropped by the kernel); :attr:`buffer_note` says when less was granted.
        downsample_to: ``(width, height)`` to crop and scale each packet's events onto, from
            ``sensor_size`` (as :class:`StdinSource`'s).
    """

    #: One line saying the kernel granted a smaller receive buffer than asked, and how to raise
    #: its cap; ``None`` when it granted it.
    buffer_note: str | None = None

    def __init__(
        self,
        host: str,
        port: int,
        *,
        fmt: str = "t64_x16_y16_on8",
        sensor_size: SensorSizeLike,
        max_packets: int | None = None,
        idle_timeout: float | None = None,
        receive_buffer: int | None = None,
        heartbeat_s: float | None = None,
        downsample_to: tuple[int, int] | None = None,
    ) -> None:
        super().__init__()
        self.heartbeat_s = check_seconds("heartbeat_s", heartbeat_s)
        asked = RECEIVE_BUFFER if receive_buffer is None else receive_buffer
        if not 1 <= asked < 1 << 31:
            raise ParameterError(f"receive_buffer must be 1 to 2^31 - 1 bytes, got {asked}")
        if fmt not in PACKET_FORMATS:
            raise ParameterError(f"UDP format must be one of {PACKET_FORMATS}, got {fmt!r}")
        if max_packets is not None and max_packets < 1:
            raise ParameterError(f"max_packets must be >= 1, got {max_packets}")
        check_seconds("idle_timeout", idle_timeout)
        width, height = check_sensor_size(sensor_size)
        self.sensor_size = (width, height)
        self._downsample_to(downsample_to)
        self.decoder = _core.PacketDecoder(fmt, width, height)
        self.max_packets = max_packets
        self.idle_timeout = idle_timeout
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self.socket = socket.socket(family, socket.SOCK_DGRAM)
        try:
            self.buffer_note = self._ask_buffer(asked)
            self.socket.bind((host, port))
        except OSError as exc:
            self.socket.close()
            raise ParameterError(f"cannot listen on udp://{host}:{port}: {exc}") from exc
        self._overflows = 0  # the kernel's last count of drops (SO_RXQ_OVFL)
        self._count_overflows = False
        if sys.platform.startswith("linux"):
            try:
                self.socket.setsockopt(socket.SOL_SOCKET, _SO_RXQ_OVFL, 1)
                self._count_overflows = True
                self.stats.lost = 0
            except OSError:
                pass
        self.idle_timeout = idle_timeout
        waits = [w for w in (idle_timeout, self.heartbeat_s) if w is not None]
        self.socket.settimeout(min(waits) if waits else None)
        # perf_counter: monotonic, and fine-grained on every OS (Windows' monotonic clock
        # ticks every 15.6 ms before Python 3.13).
        self._opened_ns = time.perf_counter_ns()

    def _ask_buffer(self, asked: int) -> str | None:
        """Ask for a receive buffer of ``asked`` bytes; a line saying so when less is granted."""
        try:
            self.socket.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, asked)
        except OSError:
            pass  # beyond the system's cap (macOS: ENOBUFS): its default stays
        reported = self.socket.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)
        linux = sys.platform.startswith("linux")
        # Linux reports twice the size set (the other half for its bookkeeping), capped at
        # twice net.core.rmem_max.
        granted = reported // 2 if linux else reported
        if granted >= asked:
            return None
        how = (
            f"raise the cap with `sysctl -w net.core.rmem_max={asked}` (as root)"
            if linux
            else "raise the system's cap on socket buffers (macOS: kern.ipc.maxsockbuf)"
        )
        return (
            f"the kernel granted a UDP receive buffer of {granted // 1024} KiB, not the "
            f"{asked // 1024} KiB asked: a burst of packets beyond it is dropped unread; {how}"
        )

    def _receive(self, buffer: bytearray) -> int:
        """Read one datagram into ``buffer``; its size. Counts the kernel's drops where known."""
        if not self._count_overflows:
            return self.socket.recv_into(buffer)
        size, ancillary, _flags, _address = self.socket.recvmsg_into([buffer], socket.CMSG_SPACE(4))
        for level, kind, data in ancillary:
            if level == socket.SOL_SOCKET and kind == _SO_RXQ_OVFL and len(data) >= 4:
                count = int.from_bytes(data[:4], sys.byteorder)  # since the socket opened
                self.stats.lost = (self.stats.lost or 0) + (count - self._overflows) % (1 << 32)
                self._overflows = count
        return size

    @property
    def address(self) -> tuple[str, int]:
        """The bound ``(host, port)``."""
        host, port = self.socket.getsockname()[:2]
        return host, port

    def __iter__(self) -> Iterator[np.ndarray]:
        buffer = bytearray(1 << 16)
        view = memoryview(buffer)
        quiet_since = time.monotonic()
        while self.max_packets is None or self.stats.packets < self.max_packets:
            try:
                size = self._receive(buffer)
            except TimeoutError:
                quiet = time.monotonic() - quiet_since
                if self.idle_timeout is not None and quiet >= self.idle_timeout:
                    return
                yield EMPTY  # silence: a heartbeat
                continue
            quiet_since = time.monotonic()
            self.stats.packets += 1
            arrival_us = (time.perf_counter_ns() - self._opened_ns) // 1000
            try:
                raw = self.decoder.decode(bytes(view[:size]), arrival_us)
            except (UavsnnError, ValueError):
                self.stats.dropped = self.decoder.dropped
                continue
            # A packet that started a new time base (a restarted sensor) is its own chunk,
            # with the packets refused before it that the new base took back.
            self.stats.dropped = self.decoder.dropped
            self.stats.restarts = self.decoder.restarts
            chunk = raw.view(EVENT_DTYPE)
            if len(chunk):
                self.stats.events += len(chunk)
                chunk = self._scaled(chunk)
                if len(chunk):  # (the crop may leave none: an empty chunk is a heartbeat)
                    yield chunk

    def close(self) -> None:
        """Close the socket."""
        self.socket.close()


def check_fits(source: EventSource, model_size: tuple[int, int]) -> None:
    """Refuse a source whose sensor is not ``model_size``, a model's input, saying what fits
    it, and a file that holds no event (``uavsnn detect`` and
    :func:`uavsnn.distributed.detect_streams`' streams check their source here). A source of
    no known size (standard input, UDP without ``sensor_size``) passes: the detector then
    checks the events.

    Raises:
        ParameterError: a file of no event (a header alone, or cut short inside it: it would
            detect nothing and exit 0, where standard input without a usable event is an
            error); or, naming both sizes: a file is cropped and scaled with
            ``--downsample`` (``downsample_to``) when it is at least as large as the model's
            input on both axes (a smaller one needs a model of its size), unless it records
            no sensor size, which is to be given (a ``.npy`` file whose events' extent lies
            within the model's input is asked for its size too); a live stream is cropped and
            scaled where it was opened with ``downsample_to``.
    """
    if isinstance(source, FileSource) and not len(source.recording):
        raise ParameterError(f"{source.path} holds no event: nothing to detect")
    size = source.sensor_size
    if size is None:
        return
    (w, h), (mw, mh) = size, model_size
    if (
        isinstance(source, FileSource)
        and source.recording.metadata.get("sensor_size_source") == "fallback"
    ):
        # Refused even where the stand-in is the model's size (a 1280x720 model): a 640x480
        # camera's events would sit in its corner without a word.
        raise ParameterError(
            f"{source.path} records no sensor size ({w}x{h} is only a stand-in): give "
            "--sensor-size WxH (sensor_size)"
        )
    if tuple(size) == tuple(model_size):
        return
    if not isinstance(source, FileSource):
        raise ParameterError(
            f"the stream's sensor is {w}x{h}, the model's input {mw}x{mh}: open it with "
            f"downsample_to={mw, mh} (--downsample) to crop and scale its events, or send "
            f"events of a {mw}x{mh} sensor"
        )
    if source.recording.metadata.get("sensor_size_source") == "inferred" and w <= mw and h <= mh:
        # A .npy file records no size: its events' extent stands in, and fits the model's.
        raise ParameterError(
            f"{source.path} records no sensor size, and its events reach only {w}x{h}, "
            f"within the model's input {mw}x{mh}: give --sensor-size {mw}x{mh} (sensor_size) "
            "if they come from such a sensor"
        )
    if w < mw or h < mh:  # downsampling only reduces: nothing makes it fit
        raise ParameterError(
            f"the recording's sensor is {w}x{h}, smaller than the model's input {mw}x{mh}: "
            f"--downsample (downsample_to) only reduces; use a model of a {w}x{h} input "
            "(trained on data of that size)"
        )
    raise ParameterError(
        f"the recording's sensor is {w}x{h}, the model's input {mw}x{mh}: add --downsample "
        "(downsample_to) to crop and scale it to the model"
    )


def is_live(spec: str | os.PathLike[str]) -> bool:
    """Whether a source's command-line spelling names a live stream, which ends only when
    told (``-`` or ``udp://HOST:PORT``), rather than a file. A path is read as
    :func:`open_source` reads it (``Path("-")`` is standard input).

    Raises:
        ParameterError: ``spec`` not a ``str`` or ``os.PathLike[str]``.
    """
    return _kind(spec) != "file"


def _spelling(spec: str | os.PathLike[str]) -> str:
    """``spec`` as the string :func:`open_source` reads (a path's ``os.fspath``), or
    :class:`~uavsnn.ParameterError`."""
    if isinstance(spec, os.PathLike):
        spec = os.fspath(spec)
    if not isinstance(spec, str):
        raise ParameterError(
            f"a source is a path, '-' or udp://HOST:PORT, got {type(spec).__name__}"
        )
    return spec


def _kind(spec: str | os.PathLike[str]) -> str:
    """``"stdin"``, ``"udp"`` or ``"file"``: the kind of source ``spec`` names."""
    spec = _spelling(spec)
    if spec == "-":
        return "stdin"
    return "udp" if spec.startswith("udp://") else "file"


_KIND_NAMES = {"stdin": "standard input", "udp": "a UDP source"}
_FILES = ("file",)
_LIVE = ("stdin", "udp")
# Each option of open_source: the kinds of source it applies to, where they are (as the
# refusal says it), and its default, which changes nothing whatever the source (a caller that
# spells every option, as `uavsnn detect` does, passes it for every kind).
_OPTIONS: dict[str, tuple[tuple[str, ...], str, Any]] = {
    "sensor_size": (("file", *_LIVE), "every source", None),
    "realtime": (_FILES, "files", False),
    "downsample_to": (("file", *_LIVE), "every source", None),
    "stdin_format": (("stdin",), "standard input ('-')", "packed"),
    "udp_format": (("udp",), "UDP sources (udp://HOST:PORT)", "t64_x16_y16_on8"),
    "max_packets": (("udp",), "UDP sources (udp://HOST:PORT)", None),
    "idle_timeout": (("udp",), "UDP sources (udp://HOST:PORT)", None),
    "heartbeat_s": (_LIVE, "'-' and UDP (live sources)", None),
}


def source_options(spec: str | os.PathLike[str], options: Mapping[str, Any]) -> dict[str, Any]:
    """The items of ``options`` (keyword arguments of :func:`open_source`) that apply to the
    kind of source ``spec`` names: for a caller that opens sources of several kinds with one
    set of options (:func:`uavsnn.distributed.detect_streams`' workers), each gets its own.

    Raises:
        ParameterError: a name that is no option of :func:`open_source`, or ``spec`` not a
            ``str`` or ``os.PathLike[str]``.
    """
    unknown = sorted(set(options) - set(_OPTIONS))
    if unknown:
        raise ParameterError(
            f"no option of open_source: {', '.join(map(repr, unknown))} (its options: "
            f"{', '.join(_OPTIONS)})"
        )
    kind = _kind(spec)
    return {name: value for name, value in options.items() if kind in _OPTIONS[name][0]}


def check_applies(
    specs: Sequence[str], options: Mapping[str, Any], *, spelled: Mapping[str, str] | None = None
) -> None:
    """Refuse an option of :func:`open_source` given (not ``None``, nor at its default) to a set
    of sources none of which it applies to (:func:`uavsnn.distributed.detect_streams`, whose
    sources share one set of options). ``spelled``: the caller's name of an option, where it
    differs, for the message.

    Raises:
        ParameterError: ``"{name} applies to {where}, and no stream is one"``.
    """
    kinds = {_kind(spec) for spec in specs}
    for name, value in options.items():
        scope, where, default = _OPTIONS[name]
        if kinds.isdisjoint(scope) and value is not None and not _is_default(value, default):
            name = (spelled or {}).get(name, name)
            raise ParameterError(f"{name} applies to {where}, and no stream is one")


def _check_options(spec: str, given: Mapping[str, Any]) -> None:
    """Refuse an option given, other than at its default, for a source it does not apply to."""
    kind = _kind(spec)
    for name, value in given.items():
        kinds, where, default = _OPTIONS[name]
        if kind not in kinds and not _is_default(value, default):
            what = f"a file ({spec})" if kind == "file" else _KIND_NAMES[kind]
            raise ParameterError(
                f"{name} applies to {where}, and this source is {what}: leave it out "
                f"(got {name}={value!r})"
            )


def _is_default(value: Any, default: Any) -> bool:
    if default is None or value is None:
        return value is default
    return isinstance(value, (bool, int, str)) and value == default


def open_source(
    spec: str | os.PathLike[str],
    *,
    sensor_size: SensorSizeLike | None = None,
    realtime: bool = False,
    stdin_format: str = "packed",
    udp_format: str = "t64_x16_y16_on8",
    max_packets: int | None = None,
    idle_timeout: float | None = None,
    downsample_to: tuple[int, int] | None = None,
    heartbeat_s: float | None = None,
) -> EventSource:
    """Open a source from its command-line spelling: a path, ``-`` or ``udp://HOST:PORT``.

    ``sensor_size`` is required for ``-`` and UDP (their bytes carry none); for a file it is
    needed only when the file records none (CSV, ``.npy``, a RAW/DAT header without geometry),
    and must agree with a file's own where it has one (as :func:`uavsnn.io.read`: one that
    contradicts it is refused); ``downsample_to`` crops and scales any source's events onto
    a smaller sensor (a live source's chunk by chunk, from its ``sensor_size``). ``realtime``
    applies to files, ``stdin_format`` to ``-``, and ``udp_format``, ``max_packets`` and
    ``idle_timeout`` to UDP; ``heartbeat_s`` to ``-`` and UDP
    (:attr:`EventSource.heartbeat_s`). An option given for a source it does not apply to is
    refused (:class:`~uavsnn.ParameterError`), unless it is at
    its default (which changes nothing: ``realtime=False``, ``stdin_format="packed"``,
    ``udp_format="t64_x16_y16_on8"``, ``None``); :func:`source_options` picks those of a set
    that apply to a source. ``downsample_to`` only reduces: a target wider or taller than the
    source's sensor is refused.
    """
    spec = _spelling(spec)
    _check_options(
        spec,
        {
            "realtime": realtime,
            "stdin_format": stdin_format,
            "udp_format": udp_format,
            "max_packets": max_packets,
            "idle_timeout": idle_timeout,
            "downsample_to": downsample_to,
            "heartbeat_s": heartbeat_s,
        },
    )
    if spec == "-":
        if sensor_size is None:
            raise ParameterError("standard input carries no sensor size: give sensor_size")
        return StdinSource(
            fmt=stdin_format,
            sensor_size=sensor_size,
            heartbeat_s=heartbeat_s,
            downsample_to=downsample_to,
        )
    if spec.startswith("udp://"):
        if sensor_size is None:
            raise ParameterError("UDP packets carry no sensor size: give sensor_size")
        url = urlsplit(spec)
        try:
            port = url.port
        except ValueError as exc:
            raise ParameterError(f"bad UDP address {spec!r}: {exc}") from exc
        if not url.hostname or port is None:
            raise ParameterError(f"UDP address must be udp://HOST:PORT, got {spec!r}")
        return UdpSource(
            url.hostname,
            port,
            fmt=udp_format,
            sensor_size=sensor_size,
            max_packets=max_packets,
            idle_timeout=idle_timeout,
            heartbeat_s=heartbeat_s,
            downsample_to=downsample_to,
        )
    return FileSource(spec, sensor_size=sensor_size, realtime=realtime, downsample_to=downsample_to)
