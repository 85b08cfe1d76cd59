"""Windows: the time-embedded frames the network looks through (SPEC §2, docs/model.md §1).

A window is ``[t0, t0 + L)``; windows start every ``L·(1 − o)`` µs (:func:`window_step`) from
the recording's first event (or ``start_us``) while ``t0`` is before one past the last event (or
``end_us``). A window's input spikes are each pixel's first event in it, polarities merged, in
time order (ties: order of arrival); a pixel fires at most once per window. Empty windows are
kept, so that window ``i`` starts at ``start + i·step``. An empty recording gives no windows
(unless both ``start_us`` and ``end_us`` are given: then the empty windows of that range).

With ``median=True`` the paper's 3×3 median filter cleans each window's active pixels: an active
pixel is kept iff at least 5 of the 9 pixels of its 3×3 neighbourhood (itself included, zero
padding outside the sensor) are active; silent pixels stay silent.

The work is done by the Rust engine (``rust/windows.rs``) in one pass over the events.
"""

from __future__ import annotations

import math
import numbers
import os
import sys
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn import _core
from uavsnn._validate import MAX_TIME_US, check_sensor_size, int_param, listed
from uavsnn.errors import ParameterError, ShapeError
from uavsnn.events import Recording, SensorSizeLike, packed_bytes

__all__ = [
    "MEMORY_LIMIT",
    "Windows",
    "add_noise",
    "make_windows",
    "noise_per_window",
    "window_step",
]


#: Where a container's memory limit is written (cgroup v2, then v1); "max" or a number past
#: the machine's memory means none.
_CGROUP_LIMITS = ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes")


def _memory_limit(cgroup_files: Sequence[str] = _CGROUP_LIMITS) -> int | None:
    """The most memory this process can have: the least of the machine's physical memory, its
    container's limit (cgroup) and its address-space limit (``ulimit -v``); ``None`` when none
    is known."""
    limits = []
    try:
        limits.append(int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE")))
    except (AttributeError, OSError, ValueError):
        physical = _windows_physical_memory() if sys.platform == "win32" else None
        if physical:
            limits.append(physical)
    for name in cgroup_files:
        try:
            text = Path(name).read_text().strip()
        except OSError:
            continue
        if text.isdigit():
            limits.append(int(text))
        break  # the first file found is this process's hierarchy
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
        if soft != resource.RLIM_INFINITY:
            limits.append(int(soft))
    except (ImportError, OSError, ValueError):
        pass
    return min(limits) if limits else None


def _windows_physical_memory() -> int | None:
    """The machine's physical memory on Windows (``GlobalMemoryStatusEx``), which has no
    ``sysconf``; ``None`` when it cannot be read."""
    import ctypes

    class MemoryStatus(ctypes.Structure):
        _fields_ = [
            ("dwLength", ctypes.c_uint32),
            ("dwMemoryLoad", ctypes.c_uint32),
            ("ullTotalPhys", ctypes.c_uint64),
            ("ullAvailPhys", ctypes.c_uint64),
            ("ullTotalPageFile", ctypes.c_uint64),
            ("ullAvailPageFile", ctypes.c_uint64),
            ("ullTotalVirtual", ctypes.c_uint64),
            ("ullAvailVirtual", ctypes.c_uint64),
            ("ullAvailExtendedVirtual", ctypes.c_uint64),
        ]

    status = MemoryStatus()
    status.dwLength = ctypes.sizeof(MemoryStatus)
    try:
        ok = ctypes.windll.kernel32.GlobalMemoryStatusEx(ctypes.byref(status))  # type: ignore[attr-defined]
    except (AttributeError, OSError):
        return None
    return int(status.ullTotalPhys) if ok else None


#: Bytes :func:`make_windows` and the recording readers may plan to allocate (``None``: no
#: bound); by default the most this process can have (:func:`_memory_limit`: the machine's
#: physical memory, less where a container or ``ulimit -v`` sets less). A recording whose
#: windows could need more is refused with its size, instead of dying on an allocation the
#: system cannot honour.
MEMORY_LIMIT: int | None = _memory_limit()

# Bytes the engine allocates per input event (its time, place and window range while sweeping)
# and per window spike (time and place in the output columns).
_BYTES_PER_EVENT = 16
_BYTES_PER_SPIKE = 12
# ... and per window (its start, offset and preceding count).
_BYTES_PER_WINDOW = 24


def _check_memory(n_events: int, length_us: int, overlap: float, span_us: int = 0) -> None:
    """Refuse a windowing whose worst case (every event in every window that holds it, and a
    window every step over ``span_us``) exceeds :data:`MEMORY_LIMIT`."""
    if MEMORY_LIMIT is None or n_events == 0:
        return
    step = max(1, math.floor(length_us * (1.0 - overlap)))
    per_event = _BYTES_PER_EVENT + _BYTES_PER_SPIKE * -(-length_us // step)
    # Windows beyond the engine's limit are its to refuse (it says to check the time unit).
    windows = min(-(-span_us // step), _core.MAX_WINDOWS)
    need = n_events * per_event + windows * _BYTES_PER_WINDOW
    if need > MEMORY_LIMIT:
        raise ParameterError(
            f"windowing {n_events:,} events (overlap {overlap}) may need {need / 2**30:.1f} GiB, "
            f"more than the {MEMORY_LIMIT / 2**30:.1f} GiB allowed (uavsnn.windows.MEMORY_LIMIT):"
            " stream the recording through uavsnn.Detector ('uavsnn detect'), which needs "
            "memory for its live windows only (windowing it a part at a time with "
            "start_us/end_us cuts short the windows that cross a part's end_us)"
        )


# The array fields of Windows, in the order the engine returns them.
_COLUMNS = ("t0", "offsets", "t", "x", "y", "n_preceding")


def _overlap(value: Any) -> float:
    """The window overlap, a number in ``[0, 1)``, as ``float``; a string or a ``bool`` is
    refused, not read as a number."""
    if isinstance(value, (str, bytes, bool, np.bool_)):
        raise ParameterError(f"overlap must be a number in [0, 1), got {value!r}")
    try:
        overlap = float(value)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"overlap must be a number in [0, 1), got {value!r}") from exc
    if not (0.0 <= overlap < 1.0):  # also refuses NaN
        raise ParameterError(f"overlap must be in [0, 1), got {value!r}")
    return overlap


def _column(name: str, values: Any, dtype: type[np.integer[Any]]) -> np.ndarray:
    """A contiguous 1-D column of ``dtype``; values that do not fit are a ShapeError."""
    arr = np.asarray(values)
    if arr.ndim != 1:
        raise ShapeError(f"{name} must be 1-D, got shape {arr.shape}")
    if arr.size == 0:
        return np.zeros(0, dtype)
    if arr.dtype.kind not in "iu":
        raise ShapeError(f"{name} must hold integers, got {arr.dtype}")
    info = np.iinfo(dtype)
    if arr.dtype != dtype and (arr.min() < info.min or arr.max() > info.max):
        raise ShapeError(f"{name} holds values outside [{info.min}, {info.max}]")
    return np.ascontiguousarray(arr, dtype=dtype)


def window_step(length_us: int, overlap: float = 0.0) -> int:
    """The step between window starts: ``length_us·(1 − overlap)`` rounded down to whole µs, at
    least 1 (a product within 1e-9 of an integer counts as that integer, so 10 ms at 90 % gives
    exactly 1 ms)."""
    length = int_param("length_us", length_us, 1, MAX_TIME_US)
    return int(_core.window_step(length, _overlap(overlap)))


@dataclass(frozen=True)
class Windows:
    """Many windows in compressed sparse rows: window ``i``'s spikes are
    ``t[offsets[i]:offsets[i+1]]`` (and the same range of ``x``, ``y``).

    Attributes:
        sensor_size: ``(width, height)`` of the coordinates.
        length_us: the window length ``L``.
        t0: ``(n,)`` uint64, window starts.
        offsets: ``(n + 1,)`` int64.
        t: ``(m,)`` uint64, absolute spike times, sorted within each window.
        x: ``(m,)`` uint16.
        y: ``(m,)`` uint16.
        n_preceding: ``(n,)`` int64, distinct pixels with an event in ``[t0 − L, t0)`` (raw
            events, before any median filter): PENT's "preceding" estimate.

    Building one checks that the columns agree (``ShapeError``), that every window starts at
    most 2^62 µs (``ParameterError``), and that every spike lies on the sensor and inside its
    window, sorted (``EventError``).
    """

    sensor_size: tuple[int, int]
    length_us: int
    t0: np.ndarray
    offsets: np.ndarray
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    n_preceding: np.ndarray

    def __post_init__(self) -> None:
        width, height = check_sensor_size(self.sensor_size)
        object.__setattr__(self, "sensor_size", (width, height))
        length = int_param("length_us", self.length_us, 1, MAX_TIME_US)
        object.__setattr__(self, "length_us", length)
        for name, dtype in (
            ("t0", np.uint64),
            ("offsets", np.int64),
            ("t", np.uint64),
            ("x", np.uint16),
            ("y", np.uint16),
            ("n_preceding", np.int64),
        ):
            object.__setattr__(self, name, _column(name, getattr(self, name), dtype))
        if len(self.n_preceding) != len(self.t0):
            raise ShapeError(
                f"n_preceding has {len(self.n_preceding)} entries for {len(self.t0)} windows"
            )
        if len(self.n_preceding) and self.n_preceding.min() < 0:
            raise ShapeError("n_preceding holds negative counts")
        _core.check_windows(width, height, self.length_us, *self._columns())

    @classmethod
    def _from_engine(
        cls,
        sensor_size: tuple[int, int],
        length_us: int,
        columns: tuple[np.ndarray, ...],
    ) -> Windows:
        """Windows the engine just built (columns of the exact dtypes, already consistent by
        construction), without checking them again: that pass over every spike cost as much as
        a tenth of windowing itself."""
        windows = object.__new__(cls)
        object.__setattr__(windows, "sensor_size", (int(sensor_size[0]), int(sensor_size[1])))
        object.__setattr__(windows, "length_us", int(length_us))
        for name, value in zip(_COLUMNS, columns, strict=True):
            object.__setattr__(windows, name, value)
        return windows

    def _columns(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return (self.t0, self.offsets, self.t, self.x, self.y)

    def __len__(self) -> int:
        return len(self.t0)

    def _indices(self, indices: Any, name: str = "indices") -> np.ndarray:
        """Window indices as int64 (negative ones count from the end), range-checked; ``name``:
        the caller's argument, for the message (one index: ``"i"``)."""
        idx = np.atleast_1d(np.asarray(indices))
        if idx.ndim != 1:
            raise ShapeError(f"indices must be 1-D, got shape {idx.shape}")
        if idx.size == 0:
            return np.zeros(0, np.int64)
        if idx.dtype.kind not in "iu":
            raise ParameterError(f"{name} must be integers, got {idx.dtype}")
        n = len(self)
        bad = (idx < -n) | (idx >= n)
        if bad.any():
            i = int(np.argmax(bad))
            which = name if np.ndim(indices) == 0 else f"{name}[{i}]"
            raise ParameterError(f"{which}={idx[i]} is out of range for {n} windows")
        idx = idx.astype(np.int64)
        return np.where(idx < 0, idx + n, idx)

    def spikes(self, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(t, x, y)`` of window ``i`` (views, not copies)."""
        (k,) = self._indices(i, "i")
        a, b = int(self.offsets[k]), int(self.offsets[k + 1])
        return self.t[a:b], self.x[a:b], self.y[a:b]

    def frames(self, indices: Any = None) -> np.ndarray:
        """Dense time-embedded frames ``(k, height, width)`` float32: ``t − t0`` of each pixel's
        spike, ``+inf`` where silent; all windows when ``indices`` is ``None``."""
        idx = np.arange(len(self), dtype=np.int64) if indices is None else self._indices(indices)
        width, height = self.sensor_size
        return _core.window_frames(width, height, self.length_us, *self._columns(), idx)

    def select(self, indices: Any) -> Windows:
        """The windows ``indices`` (ints, negative from the end), in the given order."""
        idx = self._indices(indices)
        starts = self.offsets[idx]
        counts = self.offsets[idx + 1] - starts
        offsets = np.zeros(len(idx) + 1, np.int64)
        np.cumsum(counts, out=offsets[1:])
        # A window chosen many times is copied each time: its position and columns, 20 bytes a
        # spike.
        need = int(offsets[-1]) * 20
        if MEMORY_LIMIT is not None and need > MEMORY_LIMIT:
            raise ParameterError(
                f"selecting {len(idx):,} windows copies {int(offsets[-1]):,} spikes "
                f"({need / 2**30:.1f} GiB), more than the {MEMORY_LIMIT / 2**30:.1f} GiB allowed "
                f"(uavsnn.windows.MEMORY_LIMIT)"
            )
        # Position of each selected spike in the original columns.
        gather = np.repeat(starts - offsets[:-1], counts) + np.arange(offsets[-1], dtype=np.int64)
        return Windows(
            self.sensor_size,
            self.length_us,
            self.t0[idx],
            offsets,
            self.t[gather],
            self.x[gather],
            self.y[gather],
            self.n_preceding[idx],
        )

    @staticmethod
    def concatenate(parts: Iterable[Windows]) -> Windows:
        """The windows of ``parts`` (any iterable: a list, a generator) one after the other;
        all must share sensor and length."""
        parts = listed(parts, "Windows")
        if len(parts) == 0:
            raise ParameterError("concatenate needs at least one Windows")
        first = parts[0]
        for i, part in enumerate(parts):
            if not isinstance(part, Windows):
                raise ParameterError(f"parts[{i}] is a {type(part).__name__}, not Windows")
            if (part.sensor_size, part.length_us) != (first.sensor_size, first.length_us):
                raise ShapeError(
                    f"parts[{i}] has sensor {part.sensor_size} and length {part.length_us} µs, "
                    f"parts[0] has {first.sensor_size} and {first.length_us} µs"
                )
        shifts = np.cumsum([0] + [len(p.t) for p in parts[:-1]])
        offsets = np.concatenate(
            [np.zeros(1, np.int64)]
            + [p.offsets[1:] + s for p, s in zip(parts, shifts, strict=True)]
        )
        return Windows(
            first.sensor_size,
            first.length_us,
            np.concatenate([p.t0 for p in parts]),
            offsets,
            np.concatenate([p.t for p in parts]),
            np.concatenate([p.x for p in parts]),
            np.concatenate([p.y for p in parts]),
            np.concatenate([p.n_preceding for p in parts]),
        )


def make_windows(
    recording: Recording,
    length_us: int,
    overlap: float = 0.0,
    *,
    median: bool = False,
    start_us: int | None = None,
    end_us: int | None = None,
) -> Windows:
    """Cut a recording into windows of ``length_us`` with ``overlap`` in ``[0, 1)``.

    Args:
        recording: the events.
        length_us: window length ``L`` in µs (≥ 1).
        overlap: fraction of a window shared with the next; windows start every
            :func:`window_step` µs.
        median: apply the 3×3 median filter to each window's active pixels (a ``bool``).
        start_us: start of the first window (default: the first event's time).
        end_us: windows start before this time and events at or after it are ignored
            (default: one past the last event's time).

    Raises:
        ParameterError: a length below 1 µs, an overlap outside ``[0, 1)``, NaN, a string or
            a ``bool``, negative or inverted ``start_us``/``end_us``, a ``median`` that is not a
            ``bool``, more windows than the engine's limit, or a recording whose windows may
            need more than :data:`MEMORY_LIMIT` bytes.
    """
    if not isinstance(recording, Recording):
        raise ParameterError(f"expected a Recording, got {type(recording).__name__}")
    if not isinstance(median, bool | np.bool_):
        raise ParameterError(f"median must be True or False, got {median!r}")
    length = int_param("length_us", length_us, 1, MAX_TIME_US)
    start = None if start_us is None else int_param("start_us", start_us, 0, MAX_TIME_US)
    end = None if end_us is None else int_param("end_us", end_us, 0, MAX_TIME_US)
    width, height = recording.sensor_size
    overlap = _overlap(overlap)
    times = recording.events["t"]
    if len(times):
        first = int(times[0]) if start is None else start
        last = int(times[-1]) + 1 if end is None else end
        _check_memory(len(times), length, overlap, max(0, last - first))
    columns = _core.make_windows(
        packed_bytes(recording.events),
        width,
        height,
        length,
        overlap,
        bool(median),
        start,
        end,
    )
    return Windows._from_engine(recording.sensor_size, length, columns)


def _fraction(value: Any) -> float:
    """A noise fraction: a number (not ``bool``, nor a string such as ``"0.5"``) in
    ``[0, 1]``."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise ParameterError(f"fraction must be a number in [0, 1], got {value!r}")
    try:
        frac = float(value)
    except OverflowError:  # an integer beyond a float's range
        frac = math.inf
    if not (0.0 <= frac <= 1.0):  # also refuses NaN
        raise ParameterError(f"fraction must be in [0, 1], got {value!r}")
    return frac


def noise_per_window(fraction: float, sensor_size: SensorSizeLike) -> int:
    """The noise events :func:`add_noise` draws per window on a ``sensor_size`` sensor:
    ``fraction · W · H`` rounded half away from zero, as the engine rounds it.

    Raises:
        ParameterError: ``fraction`` outside ``[0, 1]`` or NaN (as :func:`add_noise`), or a bad
            ``sensor_size``.
    """
    frac = _fraction(fraction)
    width, height = check_sensor_size(sensor_size)
    return math.floor(frac * width * height + 0.5)


def add_noise(
    windows: Windows, fraction: float, *, seed: int, first: int = 0
) -> tuple[Windows, np.ndarray]:
    """Add uniform noise events to every window (SPEC §5, the paper's noise experiment).

    Each window gets ``fraction · W · H`` rounded half away from zero (``floor(v + 0.5)``, not
    Python's half-to-even ``round``) noise events on distinct pixels drawn uniformly
    over the sensor, at times drawn uniformly in the window; a pixel keeps its earliest spike
    (the signal's on a tie). Window ``i`` draws from its own generator seeded by
    ``(seed, first + i)``: ``first`` is the index of ``windows``' first window in a larger set
    that gets its noise part by part (``windows.select(range(a, b))`` with ``first=a`` gets the
    noise that windows ``a`` to ``b`` of the whole set get at once).

    Returns:
        the noisy windows and the signal-to-noise ratio of each window in dB,
        ``10·log10(S / N)`` with ``S`` the window's spikes before noise and ``N`` the noise events
        added (``+inf`` when ``N = 0``, ``-inf`` when ``S = 0 < N``). ``n_preceding`` becomes the
        expected count once the same noise falls on the preceding interval,
        ``round(P + N − P·N/(W·H))``.

    Raises:
        ParameterError: ``fraction`` outside ``[0, 1]`` or NaN, or a bad ``seed`` or ``first``.
    """
    if not isinstance(windows, Windows):
        raise ParameterError(f"expected Windows, got {type(windows).__name__}")
    frac = _fraction(fraction)
    seed_value = int_param("seed", seed, 0)
    first_value = int_param("first", first, 0)
    width, height = windows.sensor_size
    columns, snr = _core.add_noise(
        width,
        height,
        windows.length_us,
        *windows._columns(),
        windows.n_preceding,
        frac,
        seed_value,
        first_value,
    )
    noisy = Windows._from_engine(windows.sensor_size, windows.length_us, columns)
    return noisy, snr
