"""Reading and writing recordings (SPEC §1).

The formats that event cameras and their tools write (AEDAT4, Prophesee RAW EVT 2.0/2.1/3.0,
DAT, ES, CSV) are decoded by `faery <https://github.com/aestream/faery>`_, the field's maintained
Rust decoder, except EVT 2.1 (faery 0.7 does not implement it), which is decoded here, from
``% evt 2.1`` headers and from ``% format EVT21;height=...;width=...`` (GenX320's, each 64-bit
word little-endian; and the IMX636's, Gen4.1's and IMX646's ``...;endianness=legacy``, whose two
32-bit halves come high half first); NumPy ``.npz`` and ``.npy`` are read natively, and
recordings are written as ``.npz``. A file's format is named by its extension, in any case
(``.RAW`` as ``.raw``), and faery is told it (faery's own guess takes lower case only). DAT
files of CD events are read; the Event2D DAT files of the Gen1 automotive and N-CARS sets are
refused (faery 0.7 reads only CD). A DAT time more than 2^31 µs earlier than the one before is
the 32-bit time rolling over, as faery reads it; any other time earlier than the one before
is refused, naming the event (faery would clamp it to the time before). Known limit of
faery 0.7's EVT 3.0 decoder: in a file whose events lie more than about 4 ms apart (as faery's
own writer writes a sparse recording; camera recordings were not checked), the times after the
24-bit time base wraps (16.8 s) come out wrong and are clamped, so no error is raised.

The sensor size comes from the file when the file has one (AEDAT4, ES, and RAW/DAT files whose
header carries the geometry). Otherwise it is the ``sensor_size`` argument; or, for a RAW/DAT
file whose header names the camera generation (Prophesee Gen3 files carry no geometry, only a
``plugin_name`` such as ``hal_plugin_gen3_fx3``), that generation's sensor size
(:data:`CAMERA_SENSOR_SIZES`, recorded in ``metadata["camera"]``); or else faery's fallback of
1280×720 (``.npy``: the events' bounding box). The recording's
``metadata["sensor_size_source"]`` says which: ``"file"``, ``"argument"``, ``"camera"``,
``"fallback"`` or ``"inferred"``. A ``sensor_size`` that contradicts the file's is an error;
one that differs from the size of the camera its header names is taken, and
``metadata["sensor_size_note"]`` says so (``uavsnn info`` and ``uavsnn detect`` print it: the
table's sizes are each generation's usual sensor, not every variant's).

A CSV file may start with a header line or not (faery would take the first line as a header
always; a UTF-8 byte-order mark is skipped, and a first line that starts with a number is not a
header); a header names its columns in words (``t,x,y,p``, ``foo,bar``): a first line that is
neither an event line nor such a header (numbers separated by tabs or semicolons, quoted
numbers, a ``nan`` time) is refused, naming its line, rather than dropped as a header; blank
lines (or white space only) and comment lines (starting with ``#``) are skipped, wherever they
are, the header being the first line that is neither (without one, a comment before the first
event naming all four columns, ``# t,x,y,p`` as ``np.savetxt`` writes it, names them); lines
end in ``\n`` or ``\r\n`` (a carriage return alone is refused, naming its line). Its columns
are ``t,x,y,p`` in that order, unless the header names all four in another (``t``/``ts``/
``time``/``timestamp``, ``x``, ``y``, ``p``/``pol``/``polarity``/``on``, any case, ``_us``
allowed on the time); OFF events are ``0`` or ``-1`` (ON ``1``), one or the other throughout.
Its times must be integers up to the engine's 2^62 µs and must not go backwards (faery would
clamp them): such a file is refused, naming the line, as is a line faery cannot read as an
event (a field missing or not a number, another polarity, an event off the sensor).

Every failure to read is a :class:`~uavsnn.RecordingFileError` naming the file: missing,
unreadable, empty, of an unknown extension, truncated (RAW and DAT: a data section that is not
a whole number of words; AEDAT4: a cut packet), or corrupt (undecodable, events off the sensor
or out of order, a header geometry that cannot be a sensor size; AEDAT4: a container checked
here before faery reads it, sizes beyond the file, a description that is not UTF-8).
A RAW file cut exactly on a word boundary is indistinguishable from a shorter recording: the
format has no length field. A recording whose events would not fit in
``uavsnn.windows.MEMORY_LIMIT`` (by default the most this process can have) is refused while it
is read, before the allocation that would fail; for ``.npz`` and ``.npy`` files, from the
arrays' headers, before any data is read (a compressed ``.npz`` may expand a thousandfold), and
an array header that claims more data than its file or member holds is refused as corrupt.
A CSV line longer than :data:`CSV_MAX_LINE` bytes, or a time of more than 20 digits, is
refused.
"""

from __future__ import annotations

import json
import math
import os
import struct
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn import _core, _csv
from uavsnn._csv import CSV_MAX_LINE as CSV_MAX_LINE  # uavsnn.io.CSV_MAX_LINE, as before
from uavsnn._files import write_atomic
from uavsnn._npy import npy_header, npz_arrays, npz_header, npz_read
from uavsnn._prophesee import (
    CAMERA_SENSOR_SIZES,
    camera_size,
    check_dat_times,
    decode_evt21,
    file_geometry,
    format_geometry,
    format_options,
    raw_header,
)
from uavsnn._validate import check_path, check_sensor_size
from uavsnn.errors import EventError, ParameterError, RecordingFileError
from uavsnn.events import EVENT_DTYPE, Recording, SensorSizeLike, convert, packed_bytes

__all__ = ["CAMERA_SENSOR_SIZES", "FAERY_FALLBACK_SIZE", "FORMATS", "read", "write_npz"]

#: File extensions and the format each is read as.
FORMATS: dict[str, str] = {
    ".aedat4": "aedat",
    ".aedat": "aedat",
    ".raw": "evt",
    ".evt": "evt",
    ".dat": "dat",
    ".es": "es",
    ".csv": "csv",
    ".npz": "npz",
    ".npy": "npy",
}

#: The sensor size faery assumes for a RAW, DAT or CSV file without geometry.
FAERY_FALLBACK_SIZE = (1280, 720)


def read(path: str | os.PathLike[str], sensor_size: SensorSizeLike | None = None) -> Recording:
    """Read a recording.

    Args:
        path: an ``.aedat4``, ``.raw``/``.evt``, ``.dat``, ``.es``, ``.csv``, ``.npz`` or
            ``.npy`` file.
        sensor_size: ``(width, height)`` for files without geometry (RAW files whose header
            has none, such as Prophesee Gen3 files; CSV; ``.npy``).

    Returns:
        the :class:`~uavsnn.Recording`, with ``metadata`` holding ``path``, ``format`` and
        ``sensor_size_source``; an ``.npz`` file's own metadata beside them (its keys, or
        under ``stored`` when it is not a JSON object).

    Raises:
        RecordingFileError: the file is missing, empty, of an unknown type, truncated or corrupt.
        ParameterError: ``sensor_size`` is malformed or contradicts the file's own, or
            ``path`` is not a ``str`` or ``os.PathLike[str]``.
    """
    file = Path(check_path(path))
    given = None if sensor_size is None else check_sensor_size(sensor_size)
    kind = FORMATS.get(file.suffix.lower())
    if kind is None:
        from uavsnn.dataset.real import VIDEO_SUFFIXES

        video = (
            f"; a video becomes events with `uavsnn simulate {file.name} -o EVENTS.npz`"
            if file.suffix.lower() in VIDEO_SUFFIXES
            else ""
        )
        raise RecordingFileError(
            f"{file}: unknown file type {file.suffix!r}; expected one of {sorted(FORMATS)}{video}"
        )
    try:
        return _read(file, kind, given)
    except RecordingFileError:
        raise
    except OSError as exc:  # permissions, I/O errors: the readers' own open() calls
        raise RecordingFileError(f"{file}: cannot read: {exc.strerror or exc}") from exc


def _read(file: Path, kind: str, given: tuple[int, int] | None) -> Recording:
    if file.is_dir():
        raise RecordingFileError(f"{file}: is a folder, not a recording file")
    if not file.exists():
        raise RecordingFileError(f"{file}: no such file")
    if not file.is_file():
        raise RecordingFileError(f"{file}: not a regular file")
    size = file.stat().st_size
    if size == 0:
        raise RecordingFileError(f"{file}: the file is empty")
    if kind == "npz":
        return _read_npz(file, given)
    if kind == "npy":
        return _read_npy(file, given)
    return _read_faery(file, kind, size, given)


def _recording(
    file: Path, events: np.ndarray, sensor: tuple[int, int], metadata: dict[str, Any]
) -> Recording:
    try:
        return Recording(events, sensor, metadata)
    except EventError as exc:
        raise RecordingFileError(f"{file}: corrupt or not a recording: {exc}") from exc


def _allowed_memory() -> int | None:
    """``uavsnn.windows.MEMORY_LIMIT``, read when it is needed (a test may change it)."""
    from uavsnn import windows

    return windows.MEMORY_LIMIT


def _check_event_memory(file: Path, count: int, stored: int) -> None:
    """Refuse a recording of ``count`` events whose arrays take ``stored`` bytes as stored
    when those and the canonical copy of the events would exceed
    ``uavsnn.windows.MEMORY_LIMIT``."""
    limit = _allowed_memory()
    need = stored + count * EVENT_DTYPE.itemsize
    if limit is not None and need > limit:
        raise RecordingFileError(
            f"{file}: {count:,} events would take {need / 2**30:.2f} GiB to read (the arrays as "
            f"stored and the events' canonical copy), more than the {limit / 2**30:.2f} GiB "
            "allowed (uavsnn.windows.MEMORY_LIMIT): cut the recording into shorter files"
        )


def _read_npz(file: Path, given: tuple[int, int] | None) -> Recording:
    try:
        with zipfile.ZipFile(file) as archive:
            members = npz_arrays(archive)
            missing = {"events", "sensor_size"} - set(members)
            if missing:
                raise RecordingFileError(
                    f"{file}: an .npz recording needs arrays 'events' and 'sensor_size', "
                    f"missing {sorted(missing)}"
                )
            # Only these are read; each header is checked before any data is.
            names = [n for n in ("events", "sensor_size", "metadata") if n in members]
            headers = {name: npz_header(archive, members[name]) for name in names}
            shape, _, stored = headers["events"]
            # The other arrays are read whole and converted to Python objects (the metadata
            # parsed as JSON): twice their bytes, at least 8 bytes an item.
            others = 2 * sum(
                max(nbytes, 8 * math.prod(dims))
                for n, (dims, _, nbytes) in headers.items()
                if n != "events"
            )
            _check_event_memory(file, math.prod(shape[:1]), stored + others)
            arrays = [npz_read(archive, members[n]) for n in names]
    except RecordingFileError:
        raise
    except MemoryError as exc:
        raise RecordingFileError(f"{file}: not enough memory to read it") from exc
    except Exception as exc:  # zipfile, numpy format and pickle refusals alike
        raise RecordingFileError(f"{file}: cannot read as .npz: {exc}") from exc
    raw_events, stored_size, *rest = arrays
    stored_meta = rest[0] if rest else None
    try:
        events = convert(raw_events)
    except EventError as exc:
        raise RecordingFileError(f"{file}: bad 'events' array: {_why(raw_events, exc)}") from exc
    except MemoryError as exc:
        raise RecordingFileError(f"{file}: not enough memory to read its events") from exc
    del raw_events, arrays
    try:
        sensor = check_sensor_size(stored_size.tolist())
    except ParameterError as exc:
        raise RecordingFileError(f"{file}: bad 'sensor_size' array: {exc}") from exc
    if given is not None and given != sensor:
        raise ParameterError(f"{file}: sensor_size={given} contradicts the file's {sensor}")
    metadata: dict[str, Any] = {}
    if stored_meta is not None:
        try:
            loaded = json.loads(str(stored_meta[()]))
        except (ValueError, TypeError, IndexError) as exc:
            raise RecordingFileError(f"{file}: bad 'metadata' (not JSON): {exc}") from exc
        except RecursionError as exc:
            raise RecordingFileError(f"{file}: bad 'metadata': JSON nested too deeply") from exc
        if isinstance(loaded, dict):
            metadata.update(loaded)
        else:  # a list, a string or a number (files of other writers): kept whole
            metadata["stored"] = loaded
    metadata.update(path=str(file), format="npz", sensor_size_source="file")
    return _recording(file, events, sensor, metadata)


def _why(array: np.ndarray, exc: EventError) -> str:
    """Why ``array`` is not events: ``exc``'s reason, or for a plain array without field names
    (which ``convert`` takes with ``layout=``, a reader cannot), how to convert it."""
    if array.dtype.names is None and array.ndim == 2 and array.shape[1] == 4:
        return (
            f"a plain {array.dtype} array of shape {array.shape} has no field names to say "
            "which column is the time: convert it with uavsnn.events.convert(array, layout=...) "
            "and save it with uavsnn.io.write_npz"
        )
    return str(exc)


def _read_npy(file: Path, given: tuple[int, int] | None) -> Recording:
    with open(file, "rb") as handle:
        magic = handle.read(6)
    if magic != b"\x93NUMPY":
        # NumPy calls any file without its magic "pickled"; say what it is.
        raise RecordingFileError(f"{file}: not a NumPy .npy file (no .npy header)")
    try:
        with open(file, "rb") as handle:
            shape, dtype, header = npy_header(handle)
        size = file.stat().st_size
        nbytes = math.prod(shape) * dtype.itemsize
        if not dtype.hasobject and nbytes > size - header:
            raise RecordingFileError(
                f"{file}: truncated or corrupt: its header claims {nbytes:,} bytes of data "
                f"({shape} of {dtype}), the file holds {max(size - header, 0):,}"
            )
        _check_event_memory(file, math.prod(shape[:1]), nbytes)
        raw_events = np.load(file, allow_pickle=False)
    except RecordingFileError:
        raise
    except MemoryError as exc:
        raise RecordingFileError(f"{file}: not enough memory to read it") from exc
    except Exception as exc:
        raise RecordingFileError(f"{file}: cannot read as .npy: {exc}") from exc
    try:
        events = convert(raw_events)
    except EventError as exc:
        raise RecordingFileError(f"{file}: not an event array: {_why(raw_events, exc)}") from exc
    except MemoryError as exc:
        raise RecordingFileError(f"{file}: not enough memory to read its events") from exc
    del raw_events
    if given is not None:
        sensor, source = given, "argument"
    elif len(events):
        sensor = (int(events["x"].max()) + 1, int(events["y"].max()) + 1)
        source = "inferred"
        if max(sensor) > 65535:
            raise RecordingFileError(
                f"{file}: events reach x={sensor[0] - 1}, y={sensor[1] - 1}: no sensor is that "
                "large (each side 1 to 65535 pixels)"
            )
    else:
        raise ParameterError(f"{file}: an empty .npy recording needs sensor_size=(width, height)")
    metadata = {"path": str(file), "format": "npy", "sensor_size_source": source}
    return _recording(file, events, sensor, metadata)


def _sensor_size(
    file: Path,
    geometry: tuple[int, int] | None,
    given: tuple[int, int] | None,
    camera: tuple[str, tuple[int, int]] | None,
    metadata: dict[str, Any],
) -> tuple[tuple[int, int], str]:
    """The recording's sensor size and where it came from: the file's geometry (which a given
    size must match), else the given size, else the camera named in the header (noted in
    ``metadata``), else faery's fallback."""
    if geometry is not None:
        try:
            check_sensor_size(geometry)
        except ParameterError as exc:
            raise RecordingFileError(
                f"{file}: corrupt: the file gives a sensor size of {geometry[0]}x{geometry[1]}; "
                "each side must be 1 to 65535 pixels"
            ) from exc
        if given is not None and given != geometry:
            raise ParameterError(f"{file}: sensor_size={given} contradicts the file's {geometry}")
        return geometry, "file"
    if given is not None:
        if camera is not None and camera[1] != given:
            (name, (width, height)), (gw, gh) = camera, given
            metadata["sensor_size_note"] = (
                f"{file.name}'s header names a {name} camera, whose sensor is {width}x{height}, "
                f"and {gw}x{gh} was given: the given size is taken"
            )
        return given, "argument"
    if camera is not None:
        metadata["camera"], sensor = camera
        return sensor, "camera"
    return FAERY_FALLBACK_SIZE, "fallback"


def _read_evt21(file: Path, header: dict[str, str], given: tuple[int, int] | None) -> Recording:
    geometry = format_geometry(file, header)
    camera = camera_size(header)
    metadata: dict[str, Any] = {"path": str(file), "format": "evt"}
    sensor, source = _sensor_size(file, geometry, given, camera, metadata)
    endianness = format_options(header).get("endianness", "little").strip().lower()
    if endianness not in ("little", "legacy"):
        raise RecordingFileError(
            f"{file}: EVT 2.1 with endianness={endianness} is not read (little-endian words, "
            "and the IMX636's 'legacy' halves, are)"
        )
    legacy = endianness == "legacy"
    try:
        chunks = _read_chunks(file, decode_evt21(file, int(header["<data>"]), legacy=legacy))
    except RecordingFileError:
        raise
    except (ValueError, OSError) as exc:
        raise RecordingFileError(f"{file}: cannot decode as EVT 2.1: {exc}") from exc
    events = np.concatenate(chunks) if chunks else np.empty(0, EVENT_DTYPE)
    metadata["sensor_size_source"] = source
    return _recording(file, events, sensor, metadata)


_AEDAT4_MAGIC = b"#!AER-DAT4.0\r\n"


def _check_aedat4(file: Path, size: int) -> None:
    """Refuse an AEDAT4 file whose container is certainly malformed, before faery reads it
    (faery 0.7 aborts the process on a description that is not UTF-8, and allocates whatever a
    size field says before it looks at the file's size).

    The layout (dv-processing's, as faery writes it): the magic, a u32 length and the IOHeader
    flatbuffer (fields: compression, dataTablePosition, infoNode, the XML description of the
    streams), then packets (an i32 stream id, a u32 size, that many bytes) up to the data table
    (to the end of the file when the IOHeader gives none, or one beyond the file).
    """
    start = len(_AEDAT4_MAGIC) + 4
    with open(file, "rb") as handle:
        head = handle.read(start)
        if head[: len(_AEDAT4_MAGIC)] != _AEDAT4_MAGIC:
            raise RecordingFileError(f"{file}: not an AEDAT4 file (no '#!AER-DAT4.0' magic)")
        if len(head) < start:
            raise RecordingFileError(f"{file}: truncated inside its AEDAT4 header")
        (length,) = struct.unpack_from("<I", head, len(_AEDAT4_MAGIC))
        if length > size - start:
            raise RecordingFileError(
                f"{file}: corrupt AEDAT4 header: it claims {length} bytes, the file holds "
                f"{size - start} after it"
            )
        table = _aedat4_io_header(file, handle.read(length))
        pos = start + length
        end = table if pos <= table <= size else size
        while pos < end:
            if size - pos < 8:
                raise RecordingFileError(
                    f"{file}: truncated inside the packet header at byte {pos}"
                )
            handle.seek(pos)
            stream, packet = struct.unpack("<iI", handle.read(8))
            if packet == 0:
                raise RecordingFileError(
                    f"{file}: corrupt AEDAT4 packet at byte {pos} (stream {stream}): its size is 0"
                )
            if packet > size - pos - 8:
                raise RecordingFileError(
                    f"{file}: truncated or corrupt: the AEDAT4 packet at byte {pos} (stream "
                    f"{stream}) claims {packet} bytes, the file holds {size - pos - 8} after it"
                )
            pos += 8 + packet
        if end == table and pos != table:
            # The packets run into the data table: a size was changed (faery would decode the
            # table's bytes as events, and may allocate whatever they say).
            raise RecordingFileError(
                f"{file}: corrupt AEDAT4 packets: they end at byte {pos}, not at the data table "
                f"at byte {table}"
            )


def _aedat4_io_header(file: Path, buf: bytes) -> int:
    """Check an AEDAT4 IOHeader flatbuffer (every offset within it, the infoNode description
    UTF-8); returns its dataTablePosition, -1 when it has none."""

    def need(ok: bool, what: str) -> None:
        if not ok:
            raise RecordingFileError(f"{file}: corrupt AEDAT4 header: {what}")

    n = len(buf)
    need(n >= 4, f"{n} bytes, too short for a flatbuffer")
    (root,) = struct.unpack_from("<I", buf, 0)
    need(root <= n - 4, f"its root table offset {root} is beyond its {n} bytes")
    vtable = root - struct.unpack_from("<i", buf, root)[0]
    need(0 <= vtable <= n - 4, f"its vtable offset {vtable} is beyond its {n} bytes")
    vsize, _ = struct.unpack_from("<HH", buf, vtable)
    need(vsize >= 4 and vtable + vsize <= n, f"its vtable of {vsize} bytes is cut")
    fields = struct.unpack_from(f"<{(vsize - 4) // 2}H", buf, vtable + 4)
    # (field, bytes): compression (i32), dataTablePosition (i64), infoNode (offset to a string)
    for index, (name, width) in enumerate((("compression", 4), ("dataTablePosition", 8))):
        off = fields[index] if index < len(fields) else 0
        need(not off or root + off + width <= n, f"its {name} is beyond its {n} bytes")
    table = -1
    if len(fields) > 1 and fields[1]:
        (table,) = struct.unpack_from("<q", buf, root + fields[1])
    off = fields[2] if len(fields) > 2 else 0
    need(off != 0, "it has no infoNode (the description of its streams)")
    at = root + off
    need(at <= n - 4, f"its infoNode is beyond its {n} bytes")
    text = at + struct.unpack_from("<I", buf, at)[0]
    need(text <= n - 4, f"its infoNode string at {text} is beyond its {n} bytes")
    (chars,) = struct.unpack_from("<I", buf, text)
    need(chars <= n - 4 - text, f"its infoNode string of {chars} bytes is beyond its {n} bytes")
    try:
        buf[text + 4 : text + 4 + chars].decode("utf-8")
    except UnicodeDecodeError as exc:
        bad = buf[text + 4 + exc.start]
        raise RecordingFileError(
            f"{file}: corrupt AEDAT4 header: its infoNode (the XML description) is not UTF-8: "
            f"byte 0x{bad:02X} at {exc.start}"
        ) from exc
    return table


def _read_faery(file: Path, kind: str, size: int, given: tuple[int, int] | None) -> Recording:
    import faery

    if kind == "aedat":
        _check_aedat4(file, size)
    header: dict[str, str] = {}
    if kind in ("evt", "dat"):
        header = raw_header(file, kind, size)
    if kind == "evt" and header.get("<version>") == "2.1":
        # GenX320 cameras write "% format EVT21", which faery refuses; faery 0.7 cannot decode
        # EVT 2.1 at all ("not yet implemented").
        return _read_evt21(file, header, given)
    csv_layout = _csv.check_file(file) if kind == "csv" else None
    geometry: tuple[int, int] | None = None
    sensor, source = FAERY_FALLBACK_SIZE, "fallback"
    camera = camera_size(header)
    metadata: dict[str, Any] = {"path": str(file), "format": kind}
    try:
        if kind in ("evt", "dat"):
            stated = format_geometry(file, header)
            geometry = file_geometry(file, kind) or stated  # faery skips a "64X48"
        elif kind == "csv":
            geometry = None
        else:
            width, height = faery.events_stream_from_file(file, file_type=kind).dimensions()
            geometry = (int(width), int(height))
        sensor, source = _sensor_size(file, geometry, given, camera, metadata)
        # The format is named: faery would guess it from the suffix, which must be lower-case.
        options: dict[str, Any] = {"dimensions_fallback": sensor, "file_type": kind}
        if csv_layout is not None:
            options["csv_properties"] = csv_layout.properties(faery)
        stream = faery.events_stream_from_file(file, **options)
        chunks = _read_chunks(file, stream)
    except (ParameterError, RecordingFileError):
        raise
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as exc:  # faery raises RuntimeError, bare Exception, and panics
        reasons = (
            [_fallback_reason(sensor)] if source == "fallback" and "overflow" in str(exc) else []
        )
        if kind == "evt" and not header.get("<version>"):
            # faery takes a RAW file that names no version for EVT 3.0: a sensor size given
            # cannot help an EVT 2.0 file read so.
            reasons.append(
                "its header names no EVT version, so it was read as EVT 3.0: an EVT 2.0 file "
                "needs a '% evt 2.0' line in its header"
            )
        hint = f" ({'; or '.join(reasons)})" if reasons else ""
        raise RecordingFileError(f"{file}: cannot decode as {kind}: {exc}{hint}") from exc
    if kind == "dat" and "<data>" in header:  # (not found in a header beyond 64 KiB)
        check_dat_times(file, int(header["<data>"]))
    if csv_layout is not None:
        count = sum(len(chunk) for chunk in chunks)
        if count != csv_layout.events:
            # faery skipped a line it could not read (it is told to, for blank lines).
            hint = _fallback_hint(sensor) if source == "fallback" else ""
            why = _csv.bad_line(file, csv_layout, sensor, count, hint)
            raise RecordingFileError(f"{file}: {why}")
        if csv_layout.first_event is not None:
            chunks.insert(0, csv_layout.first_event)
    events = np.concatenate(chunks) if chunks else np.empty(0, EVENT_DTYPE)
    metadata["sensor_size_source"] = source
    return _recording(file, events, sensor, metadata)


def _fallback_reason(sensor: tuple[int, int]) -> str:
    """What an event off the sensor of a file without geometry may mean."""
    return f"the file has no geometry; the sensor was taken as {sensor}: give sensor_size"


def _fallback_hint(sensor: tuple[int, int]) -> str:
    """:func:`_fallback_reason` in brackets, to follow an error."""
    return f" ({_fallback_reason(sensor)})"


def _read_chunks(file: Path, stream: Any) -> list[np.ndarray]:
    """The decoded chunks of a faery stream, refusing a recording whose events (twice: the
    chunks, then the joined array) would exceed ``uavsnn.windows.MEMORY_LIMIT``."""
    limit = _allowed_memory()
    chunks = []
    held = 0
    for chunk in stream:
        if not len(chunk):
            continue
        chunks.append(np.ascontiguousarray(chunk).view(EVENT_DTYPE))
        held += chunks[-1].nbytes
        if limit is not None and 2 * held > limit:
            events = sum(len(c) for c in chunks)
            raise RecordingFileError(
                f"{file}: more than {events:,} events ({held / 2**30:.2f} GiB), more than fit "
                f"in the {limit / 2**30:.2f} GiB allowed (uavsnn.windows.MEMORY_LIMIT): cut "
                "the recording into shorter files (e.g. with faery's time slicing)"
            )
    return chunks


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON-serialisable")


def write_npz(recording: Recording, path: str | os.PathLike[str]) -> None:
    """Write a recording as ``.npz`` (arrays ``events``, ``sensor_size``, ``metadata`` as JSON),
    atomically: to a temporary file in the same directory, then renamed over ``path``.

    ``path`` must end in ``.npz`` (any case), the suffix :func:`read` knows the file by: it is
    refused, not completed, so the file is always written where ``path`` says (``np.savez``
    would write ``out`` as ``out.npz``). The events are checked again before writing (on the
    sensor, in time order), so an array changed after the recording was built is refused
    rather than written as a file :func:`read` would refuse.

    Raises:
        ParameterError: ``recording`` is not a :class:`~uavsnn.Recording`, its metadata is
            not JSON-serialisable, or ``path`` is not a ``str``/``os.PathLike[str]`` ending in
            ``.npz``.
        EventError: an event is off the sensor or out of time order (nothing is written).
        RecordingFileError: the file cannot be written.
    """
    if not isinstance(recording, Recording):
        raise ParameterError(f"expected a Recording, got {type(recording).__name__}")
    target = Path(check_path(path))
    if target.suffix.lower() != ".npz":
        raise ParameterError(
            f"{target}: a recording is written as .npz: the path must end in .npz, got "
            f"{target.suffix!r}"
        )
    width, height = recording.sensor_size
    _core.validate_events(packed_bytes(recording.events), width, height)
    try:
        meta = json.dumps(recording.metadata, default=_json_default)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"recording metadata is not JSON-serialisable: {exc}") from exc
    try:
        write_atomic(
            target,
            lambda handle: np.savez(
                handle,
                events=np.ascontiguousarray(recording.events),
                sensor_size=np.asarray(recording.sensor_size, dtype=np.int64),
                metadata=np.asarray(meta),
            ),
        )
    except OSError as exc:
        # Its reason only, as Network.save gives it: the error names the temporary file.
        raise RecordingFileError(f"{target}: cannot write: {exc.strerror or exc}") from exc
