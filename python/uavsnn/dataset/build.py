"""Build labelled datasets: recordings, windows, labels, splits by recording, a manifest.

The rules — what makes a window a UAV window, how splits and balanced test sets are drawn,
what each domain contains — are in ``docs/dataset.md``; this module carries them out.
"""

from __future__ import annotations

import math
import shutil
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn import __version__
from uavsnn.dataset.format import (
    FORMAT_NAME,
    FORMAT_VERSION,
    MANIFEST,
    LabelledWindows,
    save_split,
    write_manifest,
)
from uavsnn.dataset.labels import WindowLabels, label_windows
from uavsnn.dataset.real import Clip, clip_labels, find_clips
from uavsnn.dataset.synthetic import LabelledRecording, SceneSource, synthetic_recording
from uavsnn.errors import DatasetError, InternalError, ParameterError
from uavsnn.sim import Pix2NvsParams, probe_video, video_to_recording
from uavsnn.windows import Windows, make_windows, window_step

__all__ = ["DATASET_DOMAINS", "DatasetPaths", "build", "build_demo"]

DATASET_DOMAINS = ("dvs", "sim", "real", "combined")
SENSOR = (240, 180)
_DOMAIN_KEY = {"dvs": 1, "sim": 2, "real": 3}
_SPLIT_KEY = {"test": 1, "train": 2}
#: A split's pools hold this many times the windows it needs before sampling, for variety.
POOL_FACTOR = 1.25
#: Give up when this many recordings in a row add nothing that a split still needs.
_STALL = 25

Progress = Callable[[str], None]


@dataclass(frozen=True)
class DatasetPaths:
    """Where a built dataset lies: its folder, manifest and split files by name."""

    root: Path
    manifest: Path
    splits: dict[str, Path] = field(default_factory=dict)

    @property
    def test(self) -> Path:
        """The test split's file."""
        return self.splits["test"]

    @property
    def train(self) -> Path | None:
        """The train split's file (``None`` when built with ``n_train=0``)."""
        return self.splits.get("train")


@dataclass(frozen=True)
class _Window:
    """Settings that cut and label windows."""

    length_us: int
    overlap: float
    min_fraction: float

    @property
    def step_us(self) -> int:
        return window_step(self.length_us, self.overlap)

    def starts(self, end_us: int) -> np.ndarray:
        """Window starts for a recording of ``[0, end_us)`` — what ``make_windows`` gives."""
        return np.arange(0, end_us, self.step_us, dtype=np.uint64)

    def cut(self, lr: LabelledRecording) -> tuple[Windows, WindowLabels]:
        windows = make_windows(
            lr.recording, self.length_us, self.overlap, start_us=0, end_us=lr.end_us
        )
        labels = label_windows(
            windows.t0,
            self.length_us,
            lr.timestamps_us,
            lr.labels,
            lr.labelled,
            min_fraction=self.min_fraction,
        )
        return windows, labels


class _Pool:
    """Usable windows gathered from recordings, with their labels."""

    def __init__(self) -> None:
        self.windows: list[Windows] = []
        self.label: list[np.ndarray] = []
        self.cls: list[np.ndarray] = []
        self.box: list[np.ndarray] = []
        self.recording: list[np.ndarray] = []
        self.positives = 0
        self.negatives = 0

    def add(
        self, rec_id: int, windows: Windows, labels: WindowLabels, keep: np.ndarray | None = None
    ) -> None:
        idx = np.flatnonzero(labels.usable if keep is None else keep)
        if len(idx) == 0:
            return
        self.windows.append(windows.select(idx))
        self.label.append(labels.label[idx])
        self.cls.append(labels.cls[idx])
        self.box.append(labels.box[idx])
        self.recording.append(np.full(len(idx), rec_id, dtype=np.int64))
        pos = int(labels.label[idx].sum())
        self.positives += pos
        self.negatives += len(idx) - pos

    def labels(self) -> np.ndarray:
        return np.concatenate(self.label) if self.label else np.zeros(0, dtype=bool)

    def take(self, indices: np.ndarray | None = None) -> LabelledWindows:
        if not self.windows:
            raise DatasetError("no usable windows were made")
        data = LabelledWindows(
            Windows.concatenate(self.windows),
            np.concatenate(self.label),
            np.concatenate(self.cls),
            np.concatenate(self.recording),
            np.concatenate(self.box),
        )
        return data if indices is None else data.select(indices)


def _balanced(label: np.ndarray, n: int, rng: np.random.Generator, what: str) -> np.ndarray:
    """``n // 2`` UAV and ``n - n // 2`` other windows drawn without replacement, sorted."""
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


def _rng(seed: int, *key: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=key))


def _summary(data: LabelledWindows, file: str, recordings: Iterable[int]) -> dict[str, Any]:
    n_uav = int(data.label.sum())
    return {
        "file": file,
        "windows": len(data),
        "uav": n_uav,
        "non_uav": len(data) - n_uav,
        "classes": data.class_counts(),
        "recordings": sorted({int(r) for r in recordings}),
    }


class _Builder:
    """One build: the recordings made so far and the manifest entries that describe them."""

    def __init__(self, seed: int, window: _Window, progress: Progress) -> None:
        self.seed = seed
        self.window = window
        self.progress = progress
        self.records: list[dict[str, Any]] = []

    def _record(self, entry: dict[str, Any]) -> int:
        rec_id = len(self.records)
        self.records.append({"id": rec_id, **entry})
        return rec_id

    # -- synthetic ---------------------------------------------------------------------------

    def synthetic(self, source: SceneSource, split: str, n: int) -> LabelledWindows:
        """Render recordings for ``split`` until its pools hold ``POOL_FACTOR`` times ``n``
        balanced windows, then draw ``n`` of them."""
        need_pos, need_neg = (
            math.ceil(POOL_FACTOR * (n // 2)),
            math.ceil(POOL_FACTOR * (n - n // 2)),
        )
        dkey, skey = _DOMAIN_KEY[source.domain], _SPLIT_KEY[split]
        kinds = _rng(self.seed, dkey, skey, 0)
        pool = _Pool()
        stall, i = 0, 0
        while pool.positives < need_pos or pool.negatives < need_neg:
            short_pos = pool.positives / max(need_pos, 1)
            short_neg = pool.negatives / max(need_neg, 1)
            if need_pos and short_pos <= short_neg:
                kind = "uav"
            else:
                kind = "object" if kinds.random() < 0.7 else "empty"
            rec_seed = int(
                np.random.SeedSequence(self.seed, spawn_key=(dkey, skey, 1, i)).generate_state(1)[0]
            )
            lr = synthetic_recording(source, kind, rec_seed)
            windows, labels = self.window.cut(lr)
            before = (pool.positives, pool.negatives)
            usable = labels.usable
            rec_id = self._record(
                {
                    "name": f"{source.domain}-{split}-{i:05d}",
                    "domain": source.domain,
                    "split": split,
                    **lr.info,
                    "windows": len(windows),
                    "usable": int(usable.sum()),
                    "usable_uav": int((usable & labels.label).sum()),
                    "windows_used": 0,
                }
            )
            pool.add(rec_id, windows, labels)
            gained = (pool.positives > before[0] and pool.positives <= need_pos) or (
                pool.negatives > before[1] and pool.negatives <= need_neg
            )
            stall = 0 if gained else stall + 1
            if stall >= _STALL:
                raise DatasetError(
                    f"the {source.domain} {split} split stalled: {_STALL} recordings in a row "
                    f"added no needed window ({pool.positives}/{need_pos} UAV, "
                    f"{pool.negatives}/{need_neg} non-UAV); are the windows longer than the "
                    f"{source.duration_s} s recordings?"
                )
            i += 1
            self.progress(
                f"{source.domain} {split}: {i} recordings, {pool.positives} UAV and "
                f"{pool.negatives} non-UAV windows"
            )
        pick = _balanced(
            pool.labels(), n, _rng(self.seed, dkey, skey, 2), f"{source.domain} {split} pool"
        )
        return self._used(pool.take(pick))

    def _used(self, data: LabelledWindows) -> LabelledWindows:
        ids, counts = np.unique(data.recording, return_counts=True)
        for rec_id, count in zip(ids.tolist(), counts.tolist(), strict=True):
            self.records[rec_id]["windows_used"] = int(count)
        return data

    # -- real footage ------------------------------------------------------------------------

    def real(
        self,
        videos: Path,
        n_test: int,
        n_train: int | None,
        test_fraction: float,
        params: Pix2NvsParams | None,
        make: tuple[str, ...] = ("test", "train"),
    ) -> dict[str, LabelledWindows]:
        """Plan every clip's windows from its box file, split the clips by class, draw the
        windows, then simulate only the clips that contribute to the splits in ``make``."""
        clips = find_clips(videos)
        plans = [self._plan(c) for c in clips]
        is_test = self._split_clips(clips, plans, n_test or 0, test_fraction)
        chosen: dict[str, dict[int, np.ndarray]] = {}
        for split, n in (("test", n_test), ("train", n_train)):
            if n == 0 or split not in make:
                continue
            members = [j for j in range(len(clips)) if is_test[j] == (split == "test")]
            empty = np.zeros(0, dtype=np.int64)
            flat_clip = np.concatenate(
                [np.full(int(plans[j][2].usable.sum()), j, dtype=np.int64) for j in members]
                or [empty]
            )
            flat_win = np.concatenate(
                [np.flatnonzero(plans[j][2].usable) for j in members] or [empty]
            )
            flat_label = np.concatenate(
                [plans[j][2].label[plans[j][2].usable] for j in members] or [np.zeros(0, bool)]
            )
            if n is None:
                pick = np.arange(len(flat_label))
                if len(pick) == 0:
                    raise DatasetError(f"the real {split} split has no usable windows")
            else:
                pick = _balanced(
                    flat_label, n, _rng(self.seed, 3, _SPLIT_KEY[split], 2), f"real {split} pool"
                )
            per_clip: dict[int, np.ndarray] = {}
            for j in np.unique(flat_clip[pick]).tolist():
                per_clip[j] = np.sort(flat_win[pick][flat_clip[pick] == j])
            chosen[split] = per_clip
        out: dict[str, LabelledWindows] = {}
        pools = {split: _Pool() for split in chosen}
        for j, clip in enumerate(clips):
            splits = [s for s in chosen if j in chosen[s]]
            entry = {
                "name": clip.name,
                "domain": "real",
                "split": "test" if is_test[j] else "train",
                "kind": clip.cls,
                "video": clip.video.name,
                "usable": int(plans[j][2].usable.sum()),
                "usable_uav": int((plans[j][2].usable & plans[j][2].label).sum()),
                "windows_used": 0,
            }
            rec_id = self._record(entry)
            if not splits:
                continue
            windows, labels, n_events = self._simulate(j, clip, plans[j], params)
            self.records[rec_id]["events"] = n_events
            for split in splits:
                keep = np.zeros(len(windows), dtype=bool)
                keep[chosen[split][j]] = True
                if not np.all(labels.usable[keep]):
                    raise DatasetError(
                        f"clip {clip.name} decodes differently from what its container and box "
                        f"file promised; windows planned as usable are not"
                    )
                pools[split].add(rec_id, windows, labels, keep)
            self.progress(f"real: simulated {clip.name}")
        for split, pool in pools.items():
            out[split] = self._used(pool.take())
        return out

    def _plan(self, clip: Clip) -> tuple[np.ndarray, int, WindowLabels, dict[str, Any]]:
        info = probe_video(clip.video)
        if info.frame_count < 2 or not info.fps > 0:
            raise DatasetError(
                f"video {clip.video.name} reports {info.frame_count} frames at {info.fps} fps; "
                f"need at least 2 frames and a frame rate"
            )
        n = int(info.frame_count)
        ts = np.round(np.arange(n) * 1e6 / info.fps).astype(np.uint64)
        labels, labelled = clip_labels(clip, n, (info.width, info.height), SENSOR)
        end_us = int(ts[-1] + (ts[-1] - ts[-2]))
        wl = label_windows(
            self.window.starts(end_us),
            self.window.length_us,
            ts,
            labels,
            labelled,
            min_fraction=self.window.min_fraction,
        )
        meta = {
            "frames": n,
            "fps": info.fps,
            "size": (info.width, info.height),
            "ts": ts,
            "labels": labels,
            "labelled": labelled,
        }
        return ts, end_us, wl, meta

    def _split_clips(
        self, clips: list[Clip], plans: list[Any], n_test: int, test_fraction: float
    ) -> np.ndarray:
        """Per class, a shuffled ``test_fraction`` of the clips (at least one) for testing; more
        if the test pools are short of ``n_test / 2`` windows of either label."""
        rng = _rng(self.seed, 3, 0)
        is_test = np.zeros(len(clips), dtype=bool)
        if n_test == 0:
            return is_test
        queues: dict[str, list[int]] = {}
        for cls in sorted({c.cls for c in clips}):
            members = [j for j, c in enumerate(clips) if c.cls == cls]
            order = [members[k] for k in rng.permutation(len(members))]
            k = min(len(order), max(1, round(test_fraction * len(order))))
            is_test[order[:k]] = True
            queues[cls] = order[k:]

        def count(label: bool) -> int:
            return sum(
                int((p[2].usable & (p[2].label == label)).sum())
                for j, p in enumerate(plans)
                if is_test[j]
            )

        uav_classes = {c.cls for c in clips if c.uav}
        for label, need in ((True, n_test // 2), (False, n_test - n_test // 2)):
            # UAV windows come from UAV clips; other windows first from the other classes.
            classes = [c for c in queues if (c in uav_classes) == label]
            while count(label) < need and any(queues[c] for c in classes):
                for c in classes:
                    if queues[c] and count(label) < need:
                        is_test[queues[c].pop(0)] = True
        return is_test

    def _simulate(
        self, j: int, clip: Clip, plan: Any, params: Pix2NvsParams | None
    ) -> tuple[Windows, WindowLabels, int]:
        ts, end_us, _, meta = plan
        rec_seed = int(np.random.SeedSequence(self.seed, spawn_key=(3, 9, j)).generate_state(1)[0])
        rec = video_to_recording(clip.video, "sim", size=SENSOR, seed=rec_seed, params=params)
        n_done = int(rec.metadata.get("frames", meta["frames"]))
        lr = LabelledRecording(rec, ts, meta["labels"], meta["labelled"].copy())
        if n_done < meta["frames"]:
            # Frames the container promised but did not decode carry no events: unscored.
            lr.labelled[n_done:] = False
        windows = make_windows(
            rec, self.window.length_us, self.window.overlap, start_us=0, end_us=end_us
        )
        if not np.array_equal(windows.t0, self.window.starts(end_us)):
            raise InternalError(f"windows of {clip.name} do not start where they were planned")
        labels = label_windows(
            windows.t0,
            self.window.length_us,
            ts,
            lr.labels,
            lr.labelled,
            min_fraction=self.window.min_fraction,
        )
        return windows, labels, len(rec)


def _check_build_args(
    domain: str,
    videos: str | Path | None,
    n_test: int,
    n_train: int | None,
    window_ms: float,
    overlap: float,
    seed: int,
    min_fraction: float,
    test_fraction: float,
) -> None:
    if domain not in DATASET_DOMAINS:
        raise ParameterError(f"domain must be one of {DATASET_DOMAINS}, got {domain!r}")
    if domain == "real" and videos is None:
        raise ParameterError("the real domain needs videos: a folder like svanstrom-dev")
    if isinstance(n_test, bool) or not isinstance(n_test, int) or n_test < 2 or n_test % 2:
        raise ParameterError(f"n_test must be an even integer >= 2, got {n_test!r}")
    if n_train is not None and (
        isinstance(n_train, bool) or not isinstance(n_train, int) or n_train < 0
    ):
        raise ParameterError(f"n_train must be a non-negative integer or None, got {n_train!r}")
    if not (
        isinstance(window_ms, (int, float)) and math.isfinite(window_ms) and window_ms >= 0.001
    ):
        raise ParameterError(f"window_ms must be at least 0.001 (1 µs), got {window_ms!r}")
    if not (isinstance(overlap, (int, float)) and 0.0 <= overlap < 1.0):
        raise ParameterError(f"overlap must be in [0, 1), got {overlap!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ParameterError(f"seed must be a non-negative integer, got {seed!r}")
    if not (isinstance(min_fraction, (int, float)) and 0.0 < min_fraction <= 1.0):
        raise ParameterError(f"min_fraction must be in (0, 1], got {min_fraction!r}")
    if not (isinstance(test_fraction, (int, float)) and 0.0 < test_fraction < 1.0):
        raise ParameterError(f"test_fraction must be in (0, 1), got {test_fraction!r}")


def _prepare(out_dir: str | Path, overwrite: bool) -> Path:
    root = Path(out_dir)
    if root.exists() and not root.is_dir():
        raise DatasetError(f"{root} exists and is not a folder")
    if root.is_dir() and any(root.iterdir()):
        if not overwrite:
            raise DatasetError(
                f"{root} is not empty; choose another folder, or overwrite a dataset there "
                "(overwrite=True, --overwrite)"
            )
        if not (root / MANIFEST).is_file():
            raise DatasetError(f"{root} is not empty and not a dataset: refusing to overwrite it")
        for path in root.iterdir():
            if path.is_dir():
                shutil.rmtree(path)
            else:
                path.unlink()
    root.mkdir(parents=True, exist_ok=True)
    return root


def build(
    out_dir: str | Path,
    domain: str,
    *,
    videos: str | Path | None = None,
    n_test: int = 2000,
    n_train: int | None = 4000,
    window_ms: float = 50.0,
    overlap: float = 0.5,
    seed: int = 0,
    min_fraction: float = 0.5,
    test_fraction: float = 0.3,
    dvs: SceneSource | None = None,
    sim: SceneSource | None = None,
    pix2nvs_params: Pix2NvsParams | None = None,
    overwrite: bool = False,
    progress: bool | Progress = False,
) -> DatasetPaths:
    """Build a dataset in ``out_dir``: ``test.npz`` (``n_test`` windows, half with a UAV),
    ``train.npz`` (``n_train`` windows, balanced the same way; all usable windows of the train
    clips for ``domain="real"`` with ``n_train=None``; none for 0) and ``manifest.json``.

    ``domain``: ``"dvs"`` (rendered scenes through the DVS emulator), ``"sim"`` (rendered video
    through PIX2NVS), ``"real"`` (the labelled videos in ``videos`` through PIX2NVS) or
    ``"combined"`` (train: dvs and sim, and real when ``videos`` is given, in equal shares;
    test: the dvs test set — the paper tests every network on DVS data). Splits are by
    recording; ``docs/dataset.md`` gives every rule. ``dvs``/``sim`` override how those scenes
    are made (defaults: 1 s at 500 fps at 240×180; 3 s at 30/60 fps at 480×360).

    Raises:
        ParameterError: impossible arguments.
        DatasetError: a non-empty ``out_dir`` (unless ``overwrite`` and it holds a dataset),
            missing or malformed footage, or too few windows to fill a balanced split.
    """
    _check_build_args(
        domain, videos, n_test, n_train, window_ms, overlap, seed, min_fraction, test_fraction
    )
    if n_train is None and domain != "real":
        raise ParameterError("n_train=None (all windows) is only for the real domain")
    window = _Window(round(window_ms * 1000), float(overlap), float(min_fraction))
    dvs = dvs or SceneSource("dvs", SENSOR, 500.0, 1.0)
    sim = sim or SceneSource("sim", (480, 360), None, 3.0, pix2nvs_params=pix2nvs_params)
    for source in (dvs, sim):
        if source.duration_s * 1e6 < window.length_us:
            raise ParameterError(
                f"windows of {window_ms} ms are longer than the {source.domain} recordings "
                f"({source.duration_s} s)"
            )
    video_dir = Path(videos) if videos is not None else None
    if video_dir is not None and not video_dir.is_dir():
        raise DatasetError(f"video folder {video_dir} does not exist or is not a folder")
    root = _prepare(out_dir, overwrite)
    report = _reporter(progress)
    b = _Builder(seed, window, report)
    splits: dict[str, LabelledWindows] = {}
    sources: list[dict[str, Any]] = []
    if domain in ("dvs", "sim"):
        source = dvs if domain == "dvs" else sim
        sources.append(source.describe())
        splits["test"] = b.synthetic(source, "test", n_test)
        if n_train:
            splits["train"] = b.synthetic(source, "train", n_train)
        description = (
            f"rendered scenes (uavsnn.scenes) through "
            f"{'the DVS emulator' if domain == 'dvs' else 'PIX2NVS'}"
        )
    elif domain == "real":
        assert video_dir is not None
        sources.append(
            {
                "domain": "real",
                "videos": str(video_dir),
                "simulator": "uavsnn.sim.video_to_recording(mode='sim')",
                "simulator_params": _describe(pix2nvs_params or Pix2NvsParams()),
            }
        )
        splits = b.real(video_dir, n_test, n_train, test_fraction, pix2nvs_params)
        if n_train == 0:
            splits.pop("train", None)
        description = f"labelled videos in {video_dir} through PIX2NVS"
    else:
        sources += [dvs.describe(), sim.describe()]
        splits["test"] = b.synthetic(dvs, "test", n_test)
        parts: list[LabelledWindows] = []
        shares = 3 if video_dir is not None else 2
        each = (
            [n_train // shares + (1 if k < n_train % shares else 0) for k in range(shares)]
            if n_train
            else [0] * shares
        )
        if each[0]:
            parts.append(b.synthetic(dvs, "train", each[0]))
        if each[1]:
            parts.append(b.synthetic(sim, "train", each[1]))
        if video_dir is not None and each[2]:
            sources.append(
                {
                    "domain": "real",
                    "videos": str(video_dir),
                    "simulator": "uavsnn.sim.video_to_recording(mode='sim')",
                    "simulator_params": _describe(pix2nvs_params or Pix2NvsParams()),
                }
            )
            parts.append(
                b.real(video_dir, n_test, each[2], test_fraction, pix2nvs_params, make=("train",))[
                    "train"
                ]
            )
        if parts:
            splits["train"] = _concat(parts)
        description = (
            "train: "
            + " + ".join(["dvs", "sim"] + (["real"] if video_dir is not None else []))
            + "; test: dvs"
        )
    paths: dict[str, Path] = {}
    for name, data in splits.items():
        if len(data) == 0:
            raise DatasetError(f"the {name} split is empty")
        paths[name] = save_split(root / f"{name}.npz", data)
    manifest = {
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "created_by": f"uavsnn {__version__}",
        "domain": domain,
        "source": description,
        "seed": seed,
        "parameters": {
            "sensor_size": list(SENSOR),
            "window_ms": window_ms,
            "window_us": window.length_us,
            "overlap": overlap,
            "step_us": window.step_us,
            "min_visible_fraction": min_fraction,
            "n_test": n_test,
            "n_train": n_train,
            "test_fraction": test_fraction if domain in ("real", "combined") else None,
            "pool_factor": POOL_FACTOR,
            "sources": sources,
        },
        "splits": {
            name: _summary(data, paths[name].name, data.recording) for name, data in splits.items()
        },
        "recordings": b.records,
    }
    manifest_path = write_manifest(root, _jsonable(manifest))
    return DatasetPaths(root, manifest_path, paths)


def _describe(p: Any) -> dict[str, Any]:
    return {k: getattr(p, k) for k in p.__dataclass_fields__}


def _concat(parts: list[LabelledWindows]) -> LabelledWindows:
    return LabelledWindows(
        Windows.concatenate([p.windows for p in parts]),
        np.concatenate([p.label for p in parts]),
        np.concatenate([p.cls for p in parts]),
        np.concatenate([p.recording for p in parts]),
        np.concatenate([p.box for p in parts]),
    )


def _jsonable(obj: Any) -> Any:
    """Plain JSON types: tuples to lists, NumPy scalars to Python, non-finite floats to None."""
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def _reporter(progress: bool | Progress) -> Progress:
    if callable(progress):
        return progress
    if not progress:
        return lambda _msg: None
    from tqdm import tqdm

    bar = tqdm(total=None, unit=" step", leave=False)

    def step(msg: str) -> None:
        bar.set_description_str(msg, refresh=False)
        bar.update(1)

    return step


def build_demo(
    out_dir: str | Path,
    seed: int = 0,
    *,
    n_test: int = 200,
    n_train: int = 400,
    overwrite: bool = False,
    progress: bool | Progress = False,
) -> DatasetPaths:
    """The small built-in synthetic set for ``uavsnn demo``: the dvs domain, windows of 50 ms
    with 50 % overlap, ``n_test`` balanced test windows and ``n_train`` training windows, from
    1 s scenes rendered at 400 fps. It builds in about a minute on two cores."""
    return build(
        out_dir,
        "dvs",
        n_test=n_test,
        n_train=n_train,
        window_ms=50.0,
        overlap=0.5,
        seed=seed,
        dvs=SceneSource("dvs", SENSOR, 400.0, 1.0),
        overwrite=overwrite,
        progress=progress,
    )
