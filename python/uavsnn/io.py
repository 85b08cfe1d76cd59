"""Reading and writing recordings (SPEC §1).

The formats that event cameras and their tools write (AEDAT4, Prophesee RAW EVT 2.0/2.1/3.0,
DAT, ES, CSV) are decoded by `faery <https://github.com/aestream/faery>`_, the field's maintained
Rust decoder, except EVT 2.1 (faery 0.7 does not implement it), which is decoded here, from
``% evt 2.1`` headers and from GenX320's ``% format EVT21;height=...;width=...``; NumPy ``.npz``
and ``.npy`` are read natively, and recordings are written as ``.npz``.

The sensor size comes from the file when the file has one (AEDAT4, ES, and RAW/DAT files whose
header carries the geometry). Otherwise it is the ``sensor_size`` argument; or, for a RAW/DAT
file whose header names the camera generation (Prophesee Gen3 files carry no geometry, only a
``plugin_name`` such as ``hal_plugin_gen3_fx3``), that generation's sensor size
(:data:`CAMERA_SENSOR_SIZES`, recorded in ``metadata["camera"]``); or else faery's fallback of
1280×720 (``.npy``: the events' bounding box). The recording's
``metadata["sensor_size_source"]`` says which: ``"file"``, ``"argument"``, ``"camera"``,
``"fallback"`` or ``"inferred"``. A ``sensor_size`` that contradicts the file's is an error.

A CSV file may start with a header line or not (faery would take the first line as a header
always); its times must not go backwards (faery would clamp them): such a file is refused,
naming the line.

Every failure to read is a :class:`~uavsnn.RecordingFileError` naming the file: missing, empty,
of an unknown extension, truncated (RAW and DAT: a data section that is not a whole number of
words; AEDAT4: a cut packet), or corrupt (undecodable, events off the sensor or out of order).
A RAW file cut exactly on a word boundary is indistinguishable from a shorter recording: the
format has no length field. A recording whose events would not fit in
``uavsnn.windows.MEMORY_LIMIT`` (the machine's physical memory by default) is refused while it
is read, before the allocation that would fail.
"""

from __future__ import annotations

import json
import os
import secrets
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn._validate import check_sensor_size
from uavsnn.errors import EventError, ParameterError, RecordingFileError
from uavsnn.events import EVENT_DTYPE, Recording, convert

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

# Bytes per word of each EVT version (RAW files); faery reads a RAW file without a version line
# as EVT 3.0.
_EVT_WORD = {"2.0": 4, "2.1": 8, "3.0": 2}


def read(path: str | os.PathLike[str], sensor_size: tuple[int, int] | None = None) -> Recording:
    """Read a recording.

    Args:
        path: an ``.aedat4``, ``.raw``/``.evt``, ``.dat``, ``.es``, ``.csv``, ``.npz`` or
            ``.npy`` file.
        sensor_size: ``(width, height)`` for files without geometry (RAW files whose header
            has none, such as Prophesee Gen3 files; CSV; ``.npy``).

    Returns:
        the :class:`~uavsnn.Recording`, with ``metadata`` holding ``path``, ``format`` and
        ``sensor_size_source``.

    Raises:
        RecordingFileError: the file is missing, empty, of an unknown type, truncated or corrupt.
        ParameterError: ``sensor_size`` is malformed or contradicts the file's own.
    """
    file = Path(path)
    given = None if sensor_size is None else check_sensor_size(sensor_size)
    kind = FORMATS.get(file.suffix.lower())
    if kind is None:
        raise RecordingFileError(
            f"{file}: unknown file type {file.suffix!r}; expected one of {sorted(FORMATS)}"
        )
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


def _read_npz(file: Path, given: tuple[int, int] | None) -> Recording:
    try:
        with np.load(file, allow_pickle=False) as data:
            missing = {"events", "sensor_size"} - set(data.files)
            if missing:
                raise RecordingFileError(
                    f"{file}: an .npz recording needs arrays 'events' and 'sensor_size', "
                    f"missing {sorted(missing)}"
                )
            raw_events = data["events"]
            stored_size = data["sensor_size"]
            stored_meta = data["metadata"] if "metadata" in data.files else None
    except RecordingFileError:
        raise
    except Exception as exc:  # zipfile, numpy format and pickle refusals alike
        raise RecordingFileError(f"{file}: cannot read as .npz: {exc}") from exc
    try:
        events = convert(raw_events)
    except EventError as exc:
        raise RecordingFileError(f"{file}: bad 'events' array: {exc}") from exc
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
        if isinstance(loaded, dict):
            metadata.update(loaded)
    metadata.update(path=str(file), format="npz", sensor_size_source="file")
    return _recording(file, events, sensor, metadata)


def _read_npy(file: Path, given: tuple[int, int] | None) -> Recording:
    with open(file, "rb") as handle:
        magic = handle.read(6)
    if magic != b"\x93NUMPY":
        # NumPy calls any file without its magic "pickled"; say what it is.
        raise RecordingFileError(f"{file}: not a NumPy .npy file (no .npy header)")
    try:
        raw_events = np.load(file, allow_pickle=False)
    except Exception as exc:
        raise RecordingFileError(f"{file}: cannot read as .npy: {exc}") from exc
    try:
        events = convert(raw_events)
    except EventError as exc:
        raise RecordingFileError(f"{file}: not an event array: {exc}") from exc
    if given is not None:
        sensor, source = given, "argument"
    elif len(events):
        sensor = (int(events["x"].max()) + 1, int(events["y"].max()) + 1)
        source = "inferred"
    else:
        raise ParameterError(f"{file}: an empty .npy recording needs sensor_size=(width, height)")
    metadata = {"path": str(file), "format": "npy", "sensor_size_source": source}
    return _recording(file, events, sensor, metadata)


def _check_words(file: Path, kind: str, size: int) -> dict[str, str]:
    """Refuse RAW/DAT files whose data section is not a whole number of words; returns the
    header's ``% key value`` lines as a dict."""
    with open(file, "rb") as handle:
        head = handle.read(1 << 16)
    pos = 0
    version = None
    fields: dict[str, str] = {}
    while pos < len(head) and head[pos : pos + 1] == b"%":
        end = head.find(b"\n", pos)
        if end < 0:
            if len(head) == size:
                raise RecordingFileError(f"{file}: truncated inside its header")
            return fields  # a header longer than 64 KiB: leave it to faery
        line = head[pos + 1 : end].decode("latin-1").strip()
        pos = end + 1
        key, _, value = line.partition(" ")
        fields.setdefault(key, value.strip())
        if line.startswith("evt "):
            version = line.split()[1]
        elif line.startswith("format "):
            version = {"EVT2": "2.0", "EVT21": "2.1", "EVT3": "3.0"}.get(
                line.split()[1].split(";")[0].upper(), version
            )
        elif line == "end":
            break
    fields["<version>"] = version or ""
    fields["<data>"] = str(pos)
    if kind == "evt":
        word = _EVT_WORD.get(version or "3.0")
        data = size - pos
        if word is not None and data % word:
            raise RecordingFileError(
                f"{file}: truncated: its event data holds {data} bytes, not a whole number "
                f"of {word}-byte EVT {version or '3.0'} words"
            )
    else:  # DAT: a type byte and a size byte, then records of that size
        if size - pos < 2:
            raise RecordingFileError(f"{file}: truncated after its header")
        record = head[pos + 1] if pos + 1 < len(head) else 0
        data = size - pos - 2
        if record and data % record:
            raise RecordingFileError(
                f"{file}: truncated: its event data holds {data} bytes, not a whole number "
                f"of {record}-byte DAT records"
            )
    return fields


#: Sensor sizes of Prophesee's camera generations, found in a RAW/DAT header's
#: ``plugin_name`` (``hal_plugin_gen3_fx3``, ``hal_plugin_gen41_evk3`` ...) or
#: ``integrator_name``/``sensor_generation`` lines, for files whose header carries no geometry.
#: Longer names first (``gen41`` before ``gen4``). From Prophesee's sensor data sheets: Gen3
#: (PPS3MVCD) 640×480, Gen3.1 (ATIS) 640×480, Gen4/Gen4.1 and IMX636 1280×720, GenX320 320×320.
CAMERA_SENSOR_SIZES: dict[str, tuple[int, int]] = {
    "genx320": (320, 320),
    "gen41": (1280, 720),
    "gen4": (1280, 720),
    "imx636": (1280, 720),
    "gen31": (640, 480),
    "gen3": (640, 480),
}


def _camera_size(fields: dict[str, str]) -> tuple[str, tuple[int, int]] | None:
    """The camera generation named in a header, and its sensor size, or ``None``."""
    text = " ".join(
        fields.get(k, "") for k in ("plugin_name", "sensor_generation", "camera_integrator_name")
    ).lower()
    for name, size in CAMERA_SENSOR_SIZES.items():
        if name in text:
            return name, size
    return None


def _file_geometry(file: Path) -> tuple[int, int] | None:
    """The sensor size written in a RAW/DAT file's header, or ``None`` if it has none.

    faery reports the fallback it is given when the header has no geometry, so two different
    fallbacks tell the cases apart.
    """
    import faery

    first = faery.events_stream_from_file(file, dimensions_fallback=(1, 1)).dimensions()
    second = faery.events_stream_from_file(file, dimensions_fallback=(2, 2)).dimensions()
    return (int(first[0]), int(first[1])) if tuple(first) == tuple(second) else None


def _format_geometry(fields: dict[str, str]) -> tuple[int, int] | None:
    """The geometry of a ``% format EVT21;height=320;width=320`` or ``% geometry 320x320``
    header line, or ``None``."""
    options = dict(
        part.split("=", 1) for part in fields.get("format", "").split(";")[1:] if "=" in part
    )
    try:
        if "width" in options and "height" in options:
            return int(options["width"]), int(options["height"])
        if "geometry" in fields:
            width, height = fields["geometry"].lower().split("x")
            return int(width), int(height)
    except ValueError:
        return None
    return None


# EVT 2.1 words (Prophesee's 64-bit vectorised format), little-endian: type in bits 63..60;
# CD events (0: OFF, 1: ON) hold the time's low 6 bits in 59..54, x (a multiple of 32) in
# 53..43, y in 42..32 and a mask of 32 pixels x..x+31 in 31..0; TIME_HIGH (8) holds the time's
# high 28 bits in 59..32. Other types (triggers, others, continued) carry no CD event.
_EVT21_TIME_HIGH = 8
_EVT21_CHUNK_WORDS = 1 << 18


def _decode_evt21(file: Path, offset: int) -> Iterator[np.ndarray]:
    """The CD events of an EVT 2.1 data section, decoded in bounded chunks (faery 0.7 does not
    implement EVT 2.1). Events before the first TIME_HIGH word have no time and are skipped."""
    words = np.memmap(file, dtype="<u8", mode="r", offset=offset)
    high = -1  # the last TIME_HIGH value, -1 before the first
    for start in range(0, len(words), _EVT21_CHUNK_WORDS):
        w = np.asarray(words[start : start + _EVT21_CHUNK_WORDS])
        kind = (w >> np.uint64(60)).astype(np.int64)
        is_high = kind == _EVT21_TIME_HIGH
        # The TIME_HIGH in force at each word: the last one at or before it.
        values = np.where(
            is_high, ((w >> np.uint64(32)) & np.uint64(0x0FFF_FFFF)).astype(np.int64), -1
        )
        where = np.maximum.accumulate(np.where(is_high, np.arange(len(w)), -1))
        current = np.where(where >= 0, values[np.maximum(where, 0)], high)
        if is_high.any():
            high = int(values[np.flatnonzero(is_high)[-1]])
        cd = (kind <= 1) & (current >= 0)
        if not cd.any():
            continue
        w, current, on = w[cd], current[cd], kind[cd] == 1
        t = (current.astype(np.uint64) << np.uint64(6)) | ((w >> np.uint64(54)) & np.uint64(63))
        x0 = ((w >> np.uint64(43)) & np.uint64(0x7FF)).astype(np.int64)
        y = ((w >> np.uint64(32)) & np.uint64(0x7FF)).astype(np.uint16)
        mask = (w & np.uint64(0xFFFF_FFFF)).astype("<u4")
        bits = np.unpackbits(mask.view(np.uint8).reshape(-1, 4), axis=1, bitorder="little")
        row, bit = np.nonzero(bits)
        out = np.empty(len(row), dtype=EVENT_DTYPE)
        out["t"] = t[row]
        out["x"] = x0[row] + bit
        out["y"] = y[row]
        out["p"] = on[row]
        yield out


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
        if given is not None and given != geometry:
            raise ParameterError(f"{file}: sensor_size={given} contradicts the file's {geometry}")
        return geometry, "file"
    if given is not None:
        return given, "argument"
    if camera is not None:
        metadata["camera"], sensor = camera
        return sensor, "camera"
    return FAERY_FALLBACK_SIZE, "fallback"


def _read_evt21(file: Path, header: dict[str, str], given: tuple[int, int] | None) -> Recording:
    geometry = _format_geometry(header)
    camera = _camera_size(header)
    metadata: dict[str, Any] = {"path": str(file), "format": "evt"}
    sensor, source = _sensor_size(file, geometry, given, camera, metadata)
    try:
        chunks = _read_chunks(file, _decode_evt21(file, int(header["<data>"])))
    except RecordingFileError:
        raise
    except (ValueError, OSError) as exc:
        raise RecordingFileError(f"{file}: cannot decode as EVT 2.1: {exc}") from exc
    events = np.concatenate(chunks) if chunks else np.empty(0, EVENT_DTYPE)
    metadata["sensor_size_source"] = source
    return _recording(file, events, sensor, metadata)


def _read_faery(file: Path, kind: str, size: int, given: tuple[int, int] | None) -> Recording:
    import faery

    header: dict[str, str] = {}
    if kind in ("evt", "dat"):
        header = _check_words(file, kind, size)
    if kind == "evt" and header.get("<version>") == "2.1":
        # GenX320 cameras write "% format EVT21", which faery refuses; faery 0.7 cannot decode
        # EVT 2.1 at all ("not yet implemented").
        return _read_evt21(file, header, given)
    if kind == "csv":
        has_header = _check_csv(file)
    geometry: tuple[int, int] | None = None
    sensor, source = FAERY_FALLBACK_SIZE, "fallback"
    camera = _camera_size(header)
    metadata: dict[str, Any] = {"path": str(file), "format": kind}
    try:
        if kind in ("evt", "dat"):
            geometry = _file_geometry(file)
        elif kind == "csv":
            geometry = None
        else:
            width, height = faery.events_stream_from_file(file).dimensions()
            geometry = (int(width), int(height))
        sensor, source = _sensor_size(file, geometry, given, camera, metadata)
        if kind == "csv":
            props = faery.CsvProperties.default()
            stream = faery.events_stream_from_file(
                file,
                dimensions_fallback=sensor,
                csv_properties=faery.CsvProperties(**(vars(props) | {"has_header": has_header})),
            )
        else:
            stream = faery.events_stream_from_file(file, dimensions_fallback=sensor)
        chunks = _read_chunks(file, stream)
    except (ParameterError, RecordingFileError):
        raise
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as exc:  # faery raises RuntimeError, bare Exception, and panics
        hint = ""
        if source == "fallback" and "overflow" in str(exc):
            hint = (
                f" (the file has no geometry; the sensor was taken as {sensor}: give sensor_size)"
            )
        raise RecordingFileError(f"{file}: cannot decode as {kind}: {exc}{hint}") from exc
    events = np.concatenate(chunks) if chunks else np.empty(0, EVENT_DTYPE)
    metadata["sensor_size_source"] = source
    return _recording(file, events, sensor, metadata)


def _read_chunks(file: Path, stream: Any) -> list[np.ndarray]:
    """The decoded chunks of a faery stream, refusing a recording whose events (twice: the
    chunks, then the joined array) would exceed ``uavsnn.windows.MEMORY_LIMIT``."""
    from uavsnn import windows

    limit = windows.MEMORY_LIMIT
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


def _check_csv(file: Path) -> bool:
    """Whether a CSV recording starts with a header line; refuse times that go backwards
    (faery would clamp them to the time before, silently), naming the line.

    Lines are read in blocks; the time is the first column, as faery reads it.
    """
    has_header = False
    previous = -1
    line_no = 0
    rest = b""
    with open(file, "rb") as handle:
        while True:
            block = handle.read(1 << 22)
            data = rest + block
            cut = len(data) if not block else data.rfind(b"\n") + 1
            rest = data[cut:]
            lines = data[:cut].splitlines()
            first = [line.split(b",", 1)[0].strip() for line in lines]
            if line_no == 0 and first and not first[0].lstrip(b"-").isdigit():
                has_header = True
            # Negative or malformed times are left to faery, which refuses them.
            numbers = [(i, f) for i, f in enumerate(first) if f.isdigit()]
            if numbers:
                t = np.array([int(f) for _, f in numbers], dtype=np.int64)
                back = np.flatnonzero(np.diff(t, prepend=previous) < 0)
                if len(back):
                    k = int(back[0])
                    before = previous if k == 0 else int(t[k - 1])
                    raise RecordingFileError(
                        f"{file}: line {line_no + numbers[k][0] + 1}: time {int(t[k])} is "
                        f"earlier than the time before it ({before}); events must be in time "
                        "order"
                    )
                previous = int(t[-1])
            line_no += len(lines)
            if not block:
                return has_header


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON-serialisable")


def write_npz(recording: Recording, path: str | os.PathLike[str]) -> None:
    """Write a recording as ``.npz`` (arrays ``events``, ``sensor_size``, ``metadata`` as JSON),
    atomically: to a temporary file in the same directory, then renamed over ``path``.

    Raises:
        ParameterError: ``recording`` is not a :class:`~uavsnn.Recording` or its metadata is
            not JSON-serialisable.
        RecordingFileError: the file cannot be written.
    """
    if not isinstance(recording, Recording):
        raise ParameterError(f"expected a Recording, got {type(recording).__name__}")
    try:
        meta = json.dumps(recording.metadata, default=_json_default)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"recording metadata is not JSON-serialisable: {exc}") from exc
    target = Path(path)
    tmp = target.with_name(f".{target.name}.{secrets.token_hex(6)}.tmp")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        with os.fdopen(fd, "wb") as handle:
            np.savez(
                handle,
                events=np.ascontiguousarray(recording.events),
                sensor_size=np.asarray(recording.sensor_size, dtype=np.int64),
                metadata=np.asarray(meta),
            )
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, target)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise RecordingFileError(f"{target}: cannot write: {exc}") from exc
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
