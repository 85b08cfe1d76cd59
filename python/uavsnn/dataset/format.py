"""The dataset on disk: ``manifest.json`` and one ``<split>.npz`` per split.

A split file is a plain NumPy ``.npz`` (no pickled objects; strings are fixed-width unicode)
that any NumPy reads with ``np.load(path)``. It holds a :class:`~uavsnn.windows.Windows` as its
arrays — ``sensor_size`` (2,) int64, ``length_us`` () int64, ``t0`` (n,) uint64, ``offsets``
(n+1,) int64, ``t`` (m,) uint64, ``x``/``y`` (m,) uint16, ``n_preceding`` (n,) int64 — and
per window ``label`` (n,) bool (a UAV), ``cls`` (n,) <U12, ``recording`` (n,) int64 (an id in
the manifest's ``recordings``) and ``box`` (n, 4) float32 (x0, y0, x1, y1 in sensor pixels,
NaN without an object), ``range_m`` (n,) float32 (the object's range in metres; NaN without
an object or where unknown) and ``size_px`` (n,) float32 (its size in sensor pixels), plus
``format_version`` () int64; and, for windows cut from recordings, the raw events each window
was made from and those of the time just before it (:class:`RawEvents`): ``raw_t`` (k,)
uint64, ``raw_x``/``raw_y`` (k,) uint16, ``raw_p`` (k,) bool, ``raw_start``/``raw_stop`` (n,)
int64 (window ``i``'s raw events are ``[raw_start[i], raw_stop[i])``) and ``raw_before_us``
() int64. Windows of one recording share its events, each stored once. ``docs/dataset.md``
describes every field of the manifest.

Files are written to a temporary name and renamed, so a file is either whole or absent; the
manifest is written last, so a folder with a manifest is a finished dataset. The manifest holds
each split file's SHA-256 (``splits.<name>.sha256``), checked on load, so a split file from
another build is refused. A build holds a lock on its folder (:data:`LOCK`, an advisory
``flock``, on Windows ``msvcrt.locking``, that ends with the process), so a second build into
the same folder fails at once.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import sys
import zipfile
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from uavsnn import windows as windows_module
from uavsnn._files import write_atomic
from uavsnn._npy import npz_arrays, npz_header, npz_read
from uavsnn.errors import DatasetError, UavsnnError
from uavsnn.events import EVENT_DTYPE
from uavsnn.windows import Windows

__all__ = [
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "LOCK",
    "MANIFEST",
    "LabelledWindows",
    "RawEvents",
    "load",
    "read_manifest",
    "save_split",
    "write_manifest",
]

FORMAT_NAME = "uavsnn-dataset"
FORMAT_VERSION = 2
#: What to tell the owner of a dataset of an older format.
_REBUILD = (
    "rebuild it with this uavsnn (`uavsnn dataset build` with the parameters in its manifest, "
    "or `uavsnn dataset demo`): format 2 adds each window's range, size and raw events"
)
MANIFEST = "manifest.json"
#: The lock file a build holds in its folder while it writes.
LOCK = ".uavsnn-build.lock"
_WINDOW_COLUMNS = {
    "t0": np.uint64,
    "offsets": np.int64,
    "t": np.uint64,
    "x": np.uint16,
    "y": np.uint16,
    "n_preceding": np.int64,
}
_LABEL_COLUMNS = {"label": np.bool_, "recording": np.int64}


_RAW_COLUMNS = {"raw_t": np.uint64, "raw_x": np.uint16, "raw_y": np.uint16, "raw_p": np.bool_}
_RAW_NAMES = {*_RAW_COLUMNS, "raw_start", "raw_stop", "raw_before_us"}


@dataclass(frozen=True)
class RawEvents:
    """The raw events behind windows: window ``i`` was made from ``events[start[i]:stop[i]]``,
    every event of its recording in ``[t0 − before_us, t0 + length_us)`` — the window and the
    time just before it, what a streaming :class:`~uavsnn.Detector` has seen when it decides
    on the window (``before_us`` is the window length: PENT's preceding window). ``events``
    (k,) of :data:`uavsnn.EVENT_DTYPE`, grouped by recording and sorted by time within one,
    may be shared by windows of one recording."""

    events: np.ndarray
    start: np.ndarray
    stop: np.ndarray
    before_us: int

    def __post_init__(self) -> None:
        if self.events.dtype != EVENT_DTYPE or self.events.ndim != 1:
            raise DatasetError(f"raw events must be a 1-D array of {EVENT_DTYPE.descr}")
        start = np.asarray(self.start, dtype=np.int64)
        stop = np.asarray(self.stop, dtype=np.int64)
        if start.shape != stop.shape or start.ndim != 1:
            raise DatasetError("raw start and stop must be 1-D and of one length")
        if np.any(start < 0) or np.any(stop < start) or np.any(stop > len(self.events)):
            raise DatasetError(f"raw ranges must lie in [0, {len(self.events)}] with start <= stop")
        object.__setattr__(self, "start", start)
        object.__setattr__(self, "stop", stop)

    def __len__(self) -> int:
        return len(self.start)

    def window(self, i: int) -> np.ndarray:
        """The raw events of window ``i``."""
        return self.events[self.start[i] : self.stop[i]]

    def select(self, indices: np.ndarray) -> RawEvents:
        """The ranges of windows ``indices`` (the events are shared, not copied)."""
        return RawEvents(self.events, self.start[indices], self.stop[indices], self.before_us)

    def compact(self) -> RawEvents:
        """The same ranges over only the events some window uses."""
        n = len(self.events)
        edge = np.zeros(n + 1, dtype=np.int64)
        np.add.at(edge, self.start, 1)
        np.add.at(edge, self.stop, -1)
        used = np.cumsum(edge[:-1]) > 0
        before = np.concatenate([[0], np.cumsum(used)])
        return RawEvents(self.events[used], before[self.start], before[self.stop], self.before_us)

    @staticmethod
    def concatenate(parts: list[RawEvents]) -> RawEvents:
        """The windows of ``parts`` one after the other."""
        if not parts:
            raise DatasetError("nothing to concatenate")
        if len({p.before_us for p in parts}) != 1:
            raise DatasetError("raw events kept for different times before their windows")
        shift = np.cumsum([0] + [len(p.events) for p in parts[:-1]])
        return RawEvents(
            np.concatenate([p.events for p in parts]),
            np.concatenate([p.start + k for p, k in zip(parts, shift, strict=True)]),
            np.concatenate([p.stop + k for p, k in zip(parts, shift, strict=True)]),
            parts[0].before_us,
        )

    @staticmethod
    def of_recording(
        events: np.ndarray, t0: np.ndarray, length_us: int, before_us: int
    ) -> RawEvents:
        """The events of one recording (sorted by time) behind windows starting at ``t0``,
        kept once for all of them."""
        t = events["t"]
        starts = np.asarray(t0, dtype=np.int64)
        lo = np.searchsorted(t, np.maximum(starts - before_us, 0).astype(np.uint64), "left")
        hi = np.searchsorted(t, (starts + length_us).astype(np.uint64), "left")
        return RawEvents(events, lo, hi, before_us).compact()


@dataclass(frozen=True)
class LabelledWindows:
    """Windows and their labels: ``label`` (n,) bool — a UAV; ``cls`` (n,) <U12 — the labelled
    object's class (``"drone"``, ``"bird"``... or ``"none"``); ``recording`` (n,) int64 — the
    recording's id in ``manifest["recordings"]``; ``box`` (n, 4) float32; and the dataset's
    ``manifest``; ``range_m`` and ``size_px`` (n,) float32 — the labelled object's range in
    metres and size in pixels (NaN without an object or where unknown; all NaN when not
    given)."""

    windows: Windows
    label: np.ndarray
    cls: np.ndarray
    recording: np.ndarray
    box: np.ndarray
    manifest: dict[str, Any] = field(default_factory=dict)
    range_m: np.ndarray = None  # type: ignore[assignment]  # None: all NaN (__post_init__)
    size_px: np.ndarray = None  # type: ignore[assignment]
    raw: RawEvents | None = None

    if TYPE_CHECKING:  # what the constructor takes: range_m and size_px may be None

        def __init__(
            self,
            windows: Windows,
            label: np.ndarray,
            cls: np.ndarray,
            recording: np.ndarray,
            box: np.ndarray,
            manifest: dict[str, Any] = ...,
            range_m: np.ndarray | None = None,
            size_px: np.ndarray | None = None,
            raw: RawEvents | None = None,
        ) -> None: ...

    def __post_init__(self) -> None:
        n = len(self.windows)
        if self.raw is not None and len(self.raw) != n:
            raise DatasetError(f"raw events for {len(self.raw)} windows, not {n}")
        for name in ("range_m", "size_px"):
            arr = getattr(self, name)
            arr = np.full(n, np.nan, dtype=np.float32) if arr is None else arr
            object.__setattr__(self, name, np.asarray(arr, dtype=np.float32))
        for name in ("label", "cls", "recording", "box", "range_m", "size_px"):
            arr = getattr(self, name)
            if len(arr) != n:
                raise DatasetError(f"{name} has {len(arr)} entries for {n} windows")
        if self.box.shape != (n, 4):
            raise DatasetError(f"box must have shape ({n}, 4), got {self.box.shape}")

    def __len__(self) -> int:
        return len(self.windows)

    def select(self, indices: Any) -> LabelledWindows:
        """The windows ``indices``, with their labels, in the given order."""
        idx = np.asarray(indices, dtype=np.int64)
        return LabelledWindows(
            self.windows.select(idx),
            self.label[idx],
            self.cls[idx],
            self.recording[idx],
            self.box[idx],
            self.manifest,
            self.range_m[idx],
            self.size_px[idx],
            None if self.raw is None else self.raw.select(idx),
        )

    def class_counts(self) -> dict[str, int]:
        """Windows per class."""
        names, counts = np.unique(self.cls, return_counts=True)
        return {str(k): int(v) for k, v in zip(names, counts, strict=True)}

    def recording_domains(self) -> np.ndarray:
        """The domain (``"dvs"``, ``"sim"``, ``"real"``) of each window's recording, from the
        manifest."""
        table = {int(r["id"]): str(r["domain"]) for r in self.manifest.get("recordings", [])}
        try:
            return np.array([table[int(r)] for r in self.recording], dtype="<U8")
        except KeyError as exc:
            raise DatasetError(f"recording {exc.args[0]} is not in the manifest") from exc


def save_split(path: str | Path, data: LabelledWindows) -> Path:
    """Write ``data`` as a split file (atomically); returns the path."""
    path = Path(path)
    w = data.windows
    arrays: dict[str, np.ndarray] = {
        "format_version": np.asarray(FORMAT_VERSION, dtype=np.int64),
        "sensor_size": np.asarray(w.sensor_size, dtype=np.int64),
        "length_us": np.asarray(w.length_us, dtype=np.int64),
    }
    for name, dtype in _WINDOW_COLUMNS.items():
        arrays[name] = np.ascontiguousarray(getattr(w, name), dtype=dtype)
    arrays["label"] = np.asarray(data.label, dtype=np.bool_)
    arrays["cls"] = np.asarray(data.cls, dtype="<U12")
    arrays["recording"] = np.asarray(data.recording, dtype=np.int64)
    arrays["box"] = np.asarray(data.box, dtype=np.float32)
    arrays["range_m"] = np.asarray(data.range_m, dtype=np.float32)
    arrays["size_px"] = np.asarray(data.size_px, dtype=np.float32)
    if data.raw is not None:
        raw = data.raw.compact()
        for name in _RAW_COLUMNS:
            arrays[name] = np.ascontiguousarray(raw.events[name[4:]])
        arrays["raw_start"], arrays["raw_stop"] = raw.start, raw.stop
        arrays["raw_before_us"] = np.asarray(raw.before_us, dtype=np.int64)
    columns: dict[str, Any] = arrays
    write_atomic(path, lambda f: np.savez(f, **columns))
    return path


def file_sha256(path: Path) -> str:
    """The SHA-256 of a file's bytes, in hex."""
    digest = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


@contextlib.contextmanager
def locked_folder(out_dir: str | Path) -> Iterator[Path]:
    """Hold :data:`LOCK` in the folder ``out_dir`` while the block runs (a build writing there):
    the folder, and the folders above it, are made if missing; on leaving, the lock is removed,
    and so are the folders it made that are empty again (a build that failed before writing
    leaves no folder behind, nor the folders above it).

    Raises:
        DatasetError: ``out_dir`` is not a folder, or another build holds it.
        OSError: the folder cannot be made.
    """
    root = Path(out_dir)
    if root.exists() and not root.is_dir():
        raise DatasetError(f"{root} exists and is not a folder")
    # The folders to make, the deepest first: removed again, in that order, when left empty.
    made = []
    for folder in (root, *root.parents):
        if folder.exists():
            break
        made.append(folder)
    try:
        root.mkdir(parents=True, exist_ok=True)
        fd = os.open(root / LOCK, os.O_WRONLY | os.O_CREAT, 0o666)
    except OSError as exc:
        _remove_empty(made)
        raise DatasetError(f"{root}: cannot create the folder or its lock: {exc}") from exc
    except BaseException:
        _remove_empty(made)
        raise
    try:
        if not _lock(fd):
            raise DatasetError(
                f"{root}: another build is writing into this folder (it holds {LOCK}); "
                "wait for it or choose another folder"
            )
        try:
            yield root
        finally:
            if sys.platform == "win32":
                # Windows removes no file that is open (here, or in a build refused now).
                os.close(fd)
                fd = -1
                with contextlib.suppress(PermissionError):
                    (root / LOCK).unlink(missing_ok=True)
            else:
                (root / LOCK).unlink(missing_ok=True)
            _remove_empty(made)
    finally:
        if fd >= 0:
            os.close(fd)


def _lock(fd: int) -> bool:
    """Lock the open file ``fd`` for this process, without waiting: ``False`` when another
    holds it. POSIX: ``flock``; Windows: ``msvcrt.locking`` of its first byte. Either ends
    with the process."""
    if sys.platform == "win32":
        import msvcrt

        try:
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
        except OSError:
            return False
        return True
    import fcntl

    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    return True


def _remove_empty(folders: list[Path]) -> None:
    """Remove ``folders`` (each inside the next) while they are empty."""
    for folder in folders:
        try:
            folder.rmdir()
        except OSError:
            return  # not empty (or gone): the folders above it hold it


def write_manifest(root: str | Path, manifest: dict[str, Any]) -> Path:
    """Write ``manifest.json`` (atomically), with the SHA-256 of each split file it lists that
    is in ``root``; returns its path."""
    path = Path(root) / MANIFEST
    splits = manifest.get("splits")
    if isinstance(splits, dict):
        hashed = {}
        for name, entry in splits.items():
            file = Path(root) / str(entry.get("file", f"{name}.npz"))
            hashed[name] = entry | {"sha256": file_sha256(file)} if file.is_file() else entry
        manifest = manifest | {"splits": hashed}
    text = json.dumps(manifest, indent=2, sort_keys=False, allow_nan=False) + "\n"
    write_atomic(path, lambda f: f.write(text.encode("utf-8")))
    return path


def _split_entry(entry: object) -> bool:
    """Whether a manifest's entry for a split is a mapping whose file name, window count and
    SHA-256, where given, are a string, an integer and a string."""
    if not isinstance(entry, dict):
        return False
    kinds = {"file": str, "windows": int, "sha256": str}
    return all(
        isinstance(entry[key], kind) and not isinstance(entry[key], bool)
        for key, kind in kinds.items()
        if key in entry
    )


def read_manifest(root: str | Path) -> dict[str, Any]:
    """Read and check a dataset's manifest.

    Raises:
        DatasetError: no such folder (a file named instead: a split's ``.npz`` is named with
            its folder) or manifest, not JSON, not a uavsnn dataset, or of another format
            version.
    """
    root = Path(root)
    if root.exists() and not root.is_dir():
        hint = f" (its folder is {root.parent})" if root.name.endswith(".npz") else ""
        raise DatasetError(f"{root} is a file: a dataset is a folder{hint}")
    if not root.is_dir():
        raise DatasetError(f"dataset folder {root} does not exist")
    path = root / MANIFEST
    if not path.is_file():
        raise DatasetError(f"{root} has no {MANIFEST}: not a dataset, or its build did not finish")
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise DatasetError(f"cannot read {path}: {exc}") from exc
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT_NAME:
        raise DatasetError(f"{path} is not a {FORMAT_NAME} manifest")
    version = manifest.get("format_version")
    if version != FORMAT_VERSION:
        raise DatasetError(
            f"{path} is format version {version!r}; this uavsnn reads version {FORMAT_VERSION}"
            + (f": {_REBUILD}" if isinstance(version, int) and version < FORMAT_VERSION else "")
        )
    splits = manifest.get("splits", {})
    if not isinstance(splits, dict):
        raise DatasetError(f"{path}: 'splits' must map each split's name to its entry")
    for name, entry in splits.items():
        if not _split_entry(entry):
            raise DatasetError(
                f"{path}: split {name!r} must be an entry with a file name, a window count and "
                f"a SHA-256, got {entry!r}"
            )
    return manifest


def load(root: str | Path, split: str) -> LabelledWindows:
    """Load one split of the dataset in ``root``.

    Raises:
        DatasetError: a missing or unreadable manifest or split file, a split the manifest does
            not list, missing or inconsistent arrays, or counts that disagree with the
            manifest.
    """
    root = Path(root)
    manifest = read_manifest(root)
    splits = manifest.get("splits", {})
    if split not in splits:
        raise DatasetError(
            f"dataset {root} has no split {split!r}; it has: {', '.join(sorted(splits)) or 'none'}"
        )
    path = root / str(splits[split].get("file", f"{split}.npz"))
    if not path.is_file():
        raise DatasetError(f"split file {path} is missing")
    need = {
        "format_version",
        "sensor_size",
        "length_us",
        "cls",
        "box",
        "range_m",
        "size_px",
        *_WINDOW_COLUMNS,
        *_LABEL_COLUMNS,
    }
    arrays = _read_split(path, need | _RAW_NAMES)
    version = None
    if "format_version" in arrays:
        stored = arrays["format_version"]
        if stored.shape != () or stored.dtype.kind not in "iu":
            raise DatasetError(
                f"split file {path}: format_version must be one integer, got an array of "
                f"{stored.dtype} {stored.shape}"
            )
        version = int(stored)
    if version is not None and version != FORMAT_VERSION:
        raise DatasetError(
            f"split file {path} is format version {version}; this uavsnn reads version "
            f"{FORMAT_VERSION}" + (f": {_REBUILD}" if version < FORMAT_VERSION else "")
        )
    missing = sorted(need - set(arrays))
    if missing:
        raise DatasetError(f"split file {path} lacks arrays: {', '.join(missing)}")
    for name, dtype in {**_WINDOW_COLUMNS, **_LABEL_COLUMNS}.items():
        if arrays[name].dtype != dtype:
            raise DatasetError(
                f"{path}: {name} has dtype {arrays[name].dtype}, expected {np.dtype(dtype)}"
            )
    if _RAW_NAMES & set(arrays) and not _RAW_NAMES <= set(arrays):
        lacking = ", ".join(sorted(_RAW_NAMES - set(arrays)))
        raise DatasetError(f"split file {path} has raw events but lacks arrays: {lacking}")
    for name, dtype in _RAW_COLUMNS.items():
        if name in arrays and arrays[name].dtype != dtype:
            raise DatasetError(
                f"{path}: {name} has dtype {arrays[name].dtype}, expected {np.dtype(dtype)}"
            )
    if arrays["cls"].dtype.kind != "U" or any(
        arrays[k].dtype != np.float32 for k in ("box", "range_m", "size_px")
    ):
        raise DatasetError(f"{path}: cls must be unicode and box, range_m, size_px float32")
    try:
        width, height = (int(v) for v in arrays["sensor_size"])
        windows = Windows(
            (width, height), int(arrays["length_us"]), *(arrays[k] for k in _WINDOW_COLUMNS)
        )
        data = LabelledWindows(
            windows,
            arrays["label"],
            arrays["cls"],
            arrays["recording"],
            arrays["box"],
            manifest,
            arrays["range_m"],
            arrays["size_px"],
            _raw(arrays) if "raw_t" in arrays else None,
        )
    except UavsnnError as exc:
        raise DatasetError(f"split file {path} is inconsistent: {exc}") from exc
    except (TypeError, ValueError) as exc:
        raise DatasetError(f"split file {path} is malformed: {exc}") from exc
    expected = splits[split].get("windows")
    if expected is not None and expected != len(data):
        raise DatasetError(
            f"split file {path} holds {len(data)} windows, the manifest says {expected}"
        )
    # A well-formed file that is not the one built with this manifest.
    expected_hash = splits[split].get("sha256")
    if expected_hash is not None and file_sha256(path) != expected_hash:
        raise DatasetError(
            f"split file {path} is not the one the manifest lists (its SHA-256 differs): "
            "it was changed or comes from another build; rebuild the dataset"
        )
    return data


def _read_split(path: Path, names: set[str]) -> dict[str, np.ndarray]:
    """The arrays of a split file named in ``names`` (others are not read), each header
    checked first: a file whose arrays, with the raw events' canonical copy, would exceed
    ``uavsnn.windows.MEMORY_LIMIT``, or whose header claims more than its member holds, is
    refused before any data is read."""
    try:
        with zipfile.ZipFile(path) as archive:
            members = {k: v for k, v in npz_arrays(archive).items() if k in names}
            sizes = {name: npz_header(archive, info) for name, info in members.items()}
            # At least a byte an item (an array of empty strings is converted too).
            need = sum(max(nbytes, math.prod(shape)) for shape, _, nbytes in sizes.values())
            if "raw_t" in sizes:  # the raw events are joined into one array
                need += math.prod(sizes["raw_t"][0][:1]) * EVENT_DTYPE.itemsize
            limit = windows_module.MEMORY_LIMIT
            if limit is not None and need > limit:
                raise DatasetError(
                    f"split file {path} would take {need / 2**30:.2f} GiB to load, more than "
                    f"the {limit / 2**30:.2f} GiB allowed (uavsnn.windows.MEMORY_LIMIT)"
                )
            return {name: npz_read(archive, info) for name, info in members.items()}
    except DatasetError:
        raise
    except MemoryError as exc:
        raise DatasetError(f"cannot read split file {path}: not enough memory") from exc
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise DatasetError(f"cannot read split file {path}: {exc}") from exc


def _raw(arrays: dict[str, np.ndarray]) -> RawEvents:
    events = np.empty(len(arrays["raw_t"]), dtype=EVENT_DTYPE)
    for name in _RAW_COLUMNS:
        if len(arrays[name]) != len(events):
            raise DatasetError(f"{name} has {len(arrays[name])} entries, raw_t {len(events)}")
        events[name[4:]] = arrays[name]
    return RawEvents(events, arrays["raw_start"], arrays["raw_stop"], int(arrays["raw_before_us"]))
