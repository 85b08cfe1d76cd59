"""What every build shares: cutting and labelling windows, pools of usable windows, balanced
draws, keyed seeds, and the record of the recordings a build makes (the manifest's
``recordings``)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from uavsnn.dataset.format import LabelledWindows, RawEvents
from uavsnn.dataset.labels import WindowLabels, label_windows
from uavsnn.distributed import SERIAL, Runner
from uavsnn.errors import DatasetError
from uavsnn.events import Recording
from uavsnn.windows import Windows, make_windows, window_step

__all__ = [
    "DOMAIN_KEY",
    "POOL_FACTOR",
    "SENSOR",
    "SPLIT_KEY",
    "Pool",
    "Progress",
    "Recorder",
    "WindowCut",
    "balanced",
    "first_uav_us",
    "keyed_rng",
    "keyed_seed",
    "take_labels",
]

SENSOR = (240, 180)
#: A split's pools hold this many times the windows it needs before sampling, for variety.
POOL_FACTOR = 1.25
#: Seed keys: every recording and draw has its own stream, so one split never shifts another.
DOMAIN_KEY = {"dvs": 1, "sim": 2, "real": 3}
SPLIT_KEY = {"test": 1, "train": 2}

Progress = Callable[[str], None]


def keyed_rng(seed: int, *key: int) -> np.random.Generator:
    """A generator of its own for ``key`` under the dataset ``seed``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=key))


def keyed_seed(seed: int, *key: int) -> int:
    """A 32-bit seed of its own for ``key`` under the dataset ``seed``."""
    return int(np.random.SeedSequence(seed, spawn_key=key).generate_state(1)[0])


@dataclass(frozen=True)
class WindowCut:
    """How windows are cut (``length_us``, ``overlap``) and labelled (``min_fraction``)."""

    length_us: int
    overlap: float
    min_fraction: float

    @property
    def step_us(self) -> int:
        """Time between window starts."""
        return window_step(self.length_us, self.overlap)

    def starts(self, end_us: int) -> np.ndarray:
        """Window starts for a recording of ``[0, end_us)``: what :meth:`cut` makes."""
        return np.arange(0, end_us, self.step_us, dtype=np.uint64)

    def label(
        self,
        t0: np.ndarray,
        timestamps_us: np.ndarray,
        frame_labels: np.ndarray,
        labelled: np.ndarray,
    ) -> WindowLabels:
        """Label windows starting at ``t0`` from the frames' labels."""
        return label_windows(
            t0,
            self.length_us,
            timestamps_us,
            frame_labels,
            labelled,
            min_fraction=self.min_fraction,
        )

    def cut(self, recording: Recording, end_us: int) -> Windows:
        """The windows of a recording of ``[0, end_us)``, starting at 0."""
        return make_windows(recording, self.length_us, self.overlap, start_us=0, end_us=end_us)


def first_uav_us(t0: np.ndarray, labels: WindowLabels) -> int | None:
    """The start of a recording's first usable UAV window among all its windows (starting at
    ``t0``, labelled ``labels``), or ``None`` without one: the manifest's ``first_uav_us``, from
    which the track-level time to first alarm runs (a split keeps only some of the windows)."""
    uav = labels.usable & labels.label
    return int(np.asarray(t0)[uav].min()) if uav.any() else None


def take_labels(labels: WindowLabels, idx: np.ndarray) -> WindowLabels:
    """The labels of the windows at ``idx``."""
    return WindowLabels(
        labels.label[idx], labels.cls[idx], labels.box[idx], labels.status[idx],
        labels.uav_fraction[idx], labels.range_m[idx], labels.size_px[idx],
    )  # fmt: skip


class Pool:
    """Usable windows gathered from recordings, with their labels and recording ids."""

    def __init__(self) -> None:
        self._windows: list[Windows] = []
        self._label: list[np.ndarray] = []
        self._cls: list[np.ndarray] = []
        self._box: list[np.ndarray] = []
        self._recording: list[np.ndarray] = []
        self._range: list[np.ndarray] = []
        self._size: list[np.ndarray] = []
        self._raw: list[RawEvents] | None = []
        self.positives = 0
        self.negatives = 0

    def add(
        self,
        rec_id: int,
        windows: Windows,
        labels: WindowLabels,
        keep: np.ndarray | None = None,
        events: np.ndarray | None = None,
        raw: RawEvents | None = None,
    ) -> None:
        """Add the usable windows (or those in ``keep``) of one recording, and the raw events
        behind them: from ``events`` (the recording's), or ``raw`` (one entry per window of
        ``windows``, as a build's tasks return them)."""
        idx = np.flatnonzero(labels.usable if keep is None else keep)
        if len(idx) == 0:
            return
        if events is None and raw is None:
            self._raw = None
        elif self._raw is not None and raw is not None:
            self._raw.append(raw.select(idx).compact())
        elif self._raw is not None and events is not None:
            length = windows.length_us
            self._raw.append(RawEvents.of_recording(events, windows.t0[idx], length, length))
        self._windows.append(windows.select(idx))
        self._label.append(labels.label[idx])
        self._cls.append(labels.cls[idx])
        self._box.append(labels.box[idx])
        self._recording.append(np.full(len(idx), rec_id, dtype=np.int64))
        self._range.append(labels.range_m[idx])
        self._size.append(labels.size_px[idx])
        pos = int(labels.label[idx].sum())
        self.positives += pos
        self.negatives += len(idx) - pos

    def labels(self) -> np.ndarray:
        """The UAV label of every window in the pool."""
        return np.concatenate(self._label) if self._label else np.zeros(0, dtype=bool)

    def take(self, indices: np.ndarray | None = None) -> LabelledWindows:
        """The pool's windows (or those at ``indices``) as one :class:`LabelledWindows`."""
        if not self._windows:
            raise DatasetError("no usable windows were made")
        data = LabelledWindows(
            Windows.concatenate(self._windows),
            np.concatenate(self._label),
            np.concatenate(self._cls),
            np.concatenate(self._recording),
            np.concatenate(self._box),
            range_m=np.concatenate(self._range),
            size_px=np.concatenate(self._size),
            raw=RawEvents.concatenate(self._raw) if self._raw else None,
        )
        return data if indices is None else data.select(indices)


def balanced(label: np.ndarray, n: int, rng: np.random.Generator, what: str) -> np.ndarray:
    """``n // 2`` UAV and ``n - n // 2`` other windows drawn without replacement, sorted.

    Raises:
        DatasetError: too few windows of either label.
    """
    pos, neg = np.flatnonzero(label), np.flatnonzero(~label)
    n_pos, n_neg = n // 2, n - n // 2
    if len(pos) < n_pos or len(neg) < n_neg:
        raise DatasetError(
            f"cannot balance the {what}: it has {len(pos)} UAV and {len(neg)} non-UAV windows, "
            f"{n_pos} and {n_neg} are needed"
        )
    pick = np.concatenate(
        [rng.choice(pos, n_pos, replace=False), rng.choice(neg, n_neg, replace=False)]
    )
    return np.sort(pick)


class Recorder:
    """One build's seed, window settings and progress, and the manifest entries of the
    recordings it makes (their ids are their positions). ``runner`` runs the per-recording
    work (:mod:`uavsnn.distributed`; default: in this process). ``stratify``: synthetic
    splits give their object scenes each kind of object in its share
    (:func:`uavsnn.dataset.synthetic.synthetic_split`)."""

    def __init__(
        self,
        seed: int,
        cut: WindowCut,
        progress: Progress,
        runner: Runner | None = None,
        *,
        stratify: bool = False,
    ) -> None:
        self.seed = seed
        self.stratify = stratify
        self.cut = cut
        self.progress = progress
        self.runner = runner if runner is not None else SERIAL
        self.records: list[dict[str, Any]] = []

    def record(self, entry: dict[str, Any]) -> int:
        """Add a recording's entry; returns its id."""
        rec_id = len(self.records)
        self.records.append({"id": rec_id, **entry, "windows_used": 0})
        return rec_id

    def mark_used(self, data: LabelledWindows) -> LabelledWindows:
        """Note how many windows of each recording ``data`` uses; returns ``data``."""
        ids, counts = np.unique(data.recording, return_counts=True)
        for rec_id, count in zip(ids.tolist(), counts.tolist(), strict=True):
            self.records[rec_id]["windows_used"] = int(count)
        return data
