"""Prophesee's RAW (EVT 2.0/2.1/3.0) and DAT files as :mod:`uavsnn.io` reads them: the header
(its ``% key value`` lines, the version and where the data starts), the checks that the data is
a whole number of words, the sensor size a header gives or implies (its geometry, or the camera
generation it names), and the EVT 2.1 decoder (faery 0.7 does not implement EVT 2.1).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from uavsnn.errors import RecordingFileError
from uavsnn.events import EVENT_DTYPE

__all__ = [
    "CAMERA_SENSOR_SIZES",
    "camera_size",
    "check_dat_times",
    "decode_evt21",
    "file_geometry",
    "format_geometry",
    "format_options",
    "raw_header",
]


# Bytes per word of each EVT version (RAW files); faery reads a RAW file without a version line
# as EVT 3.0.
_EVT_WORD = {"2.0": 4, "2.1": 8, "3.0": 2}


def raw_header(file: Path, kind: str, size: int) -> dict[str, str]:
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
        if record and record != _DAT_RECORD:
            # faery reads 8-byte records only: another size is a corrupt header, or no DAT.
            raise RecordingFileError(
                f"{file}: not a DAT recording, or its header is corrupt: it gives records of "
                f"{record} bytes, DAT's are {_DAT_RECORD}"
            )
        data = size - pos - 2
        if record and data % record:
            raise RecordingFileError(
                f"{file}: truncated: its event data holds {data} bytes, not a whole number "
                f"of {record}-byte DAT records"
            )
    return fields


# DAT records (8 bytes, little-endian) hold the time in µs in their low 32 bits. faery 0.7 reads
# a time more than 2^31 µs earlier than the one before as the 32-bit time rolling over, and
# clamps any other earlier time to the one before, silently.
_DAT_ROLLOVER = 1 << 31
_DAT_RECORD = 8
_DAT_CHUNK_RECORDS = 1 << 20


def check_dat_times(file: Path, offset: int) -> None:
    """Refuse a DAT file of 8-byte records whose data section (its type and size bytes at
    ``offset``, then the records) has a time earlier than the one before it, other than the
    32-bit time rolling over (a jump back of more than 2^31 µs), naming the event: faery would
    clamp it to the time before."""
    start = offset + 2
    previous = 0  # the last time (low 32 bits), as faery starts
    turns = 0  # the rollovers so far
    first = 0  # the index of the chunk's first record
    with open(file, "rb") as handle:
        handle.seek(start)
        while chunk := handle.read(8 * _DAT_CHUNK_RECORDS):
            words = np.frombuffer(chunk, "<u8", count=len(chunk) // 8)
            t = (words & 0xFFFF_FFFF).astype(np.int64)
            back = np.concatenate(([previous], t[:-1])) - t  # > 0: earlier than the one before
            rollover = back > _DAT_ROLLOVER
            late = np.flatnonzero((back > 0) & ~rollover)
            if len(late):
                k = int(late[0])
                base = (turns + int(rollover[:k].sum())) << 32
                index = first + k
                raise RecordingFileError(
                    f"{file}: event {index} (byte {start + 8 * index}): time {base + int(t[k])} "
                    f"is earlier than the time before it ({base + int(t[k]) + int(back[k])}); "
                    "events must be in time order"
                )
            turns += int(rollover.sum())
            previous = int(t[-1]) if len(t) else previous
            first += len(t)


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


def camera_size(fields: dict[str, str]) -> tuple[str, tuple[int, int]] | None:
    """The camera generation named in a header, and its sensor size, or ``None``."""
    text = " ".join(
        fields.get(k, "") for k in ("plugin_name", "sensor_generation", "camera_integrator_name")
    ).lower()
    for name, size in CAMERA_SENSOR_SIZES.items():
        if name in text:
            return name, size
    return None


def file_geometry(file: Path, kind: str) -> tuple[int, int] | None:
    """The sensor size written in the header of a RAW (``kind`` ``"evt"``) or DAT (``"dat"``)
    file, or ``None`` if it has none.

    faery reports the fallback it is given when the header has no geometry, so two different
    fallbacks tell the cases apart.
    """
    import faery

    first, second = (
        faery.events_stream_from_file(file, dimensions_fallback=size, file_type=kind).dimensions()
        for size in ((1, 1), (2, 2))
    )
    return (int(first[0]), int(first[1])) if tuple(first) == tuple(second) else None


def format_options(fields: dict[str, str]) -> dict[str, str]:
    """The ``key=value`` options of a ``% format`` header line (``height``, ``width``,
    ``endianness``)."""
    return dict(
        part.split("=", 1) for part in fields.get("format", "").split(";")[1:] if "=" in part
    )


def format_geometry(file: Path, fields: dict[str, str]) -> tuple[int, int] | None:
    """The geometry of a RAW/DAT header (``% format EVT21;height=320;width=320``, ``% geometry
    320x320``, ``% Width 320`` and ``% Height 320``, the lines faery reads, in that order of
    precedence), or ``None`` if it has none. A line that states a geometry that cannot be a
    sensor size (faery would ignore it and take its fallback) is refused, naming it."""
    options = format_options(fields)
    stated = []  # (the line(s), the form expected, width, height)
    if "width" in options or "height" in options:
        line = f"% format {fields['format']}"
        stated.append((line, "width=W;height=H", options.get("width"), options.get("height")))
    if "geometry" in fields:
        width, _, height = fields["geometry"].lower().partition("x")
        stated.append((f"% geometry {fields['geometry']}", "WxH", width, height))
    if "Width" in fields or "Height" in fields:
        line = " and ".join(
            f"% {key} {fields[key]}" for key in ("Width", "Height") if key in fields
        )
        stated.append((line, "Width and Height", fields.get("Width"), fields.get("Height")))
    sizes = []
    for line, form, *sides in stated:
        numbers = [int(v) if v and re.fullmatch(r"\s*\d{1,9}\s*", v) else 0 for v in sides]
        if not all(0 < v <= 65535 for v in numbers):
            raise RecordingFileError(
                f"{file}: corrupt header: {line.strip()!r} is not a sensor size ({form}, each "
                "side 1 to 65535 pixels)"
            )
        sizes.append((numbers[0], numbers[1]))
    return sizes[0] if sizes else None


# EVT 2.1 words (Prophesee's 64-bit vectorised format), little-endian: type in bits 63..60;
# CD events (0: OFF, 1: ON) hold the time's low 6 bits in 59..54, x (a multiple of 32) in
# 53..43, y in 42..32 and a mask of 32 pixels x..x+31 in 31..0; TIME_HIGH (8) holds the time's
# high 28 bits in 59..32. Other types (triggers, others, continued) carry no CD event. The
# IMX636 family sends each word as its two 32-bit halves, the high half first ("endianness=
# legacy" in OpenEB's header; Prophesee: 0x0102030405060708 arrives as bytes 04 03 02 01 08 07
# 06 05): read little-endian, its halves are swapped back.
_EVT21_TIME_HIGH = 8
_EVT21_CHUNK_WORDS = 1 << 18


def decode_evt21(file: Path, offset: int, *, legacy: bool = False) -> Iterator[np.ndarray]:
    """The CD events of an EVT 2.1 data section, decoded in bounded chunks (faery 0.7 does not
    implement EVT 2.1). Events before the first TIME_HIGH word have no time and are skipped.
    ``legacy``: each word's 32-bit halves come high half first (the IMX636's)."""
    words = np.memmap(file, dtype="<u8", mode="r", offset=offset)
    high = -1  # the last TIME_HIGH value, -1 before the first
    for start in range(0, len(words), _EVT21_CHUNK_WORDS):
        w = np.asarray(words[start : start + _EVT21_CHUNK_WORDS])
        if legacy:
            w = (w << np.uint64(32)) | (w >> np.uint64(32))
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
