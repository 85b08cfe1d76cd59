"""Build labelled datasets: recordings, windows, labels, splits by recording, a manifest.

The rules — what makes a window a UAV window, how splits and balanced test sets are drawn,
what each domain contains — are in ``docs/dataset.md``; this module carries them out.
"""

from __future__ import annotations

import math
import shutil
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn import __version__
from uavsnn.dataset.footage import real_splits
from uavsnn.dataset.format import (
    FORMAT_NAME,
    FORMAT_VERSION,
    MANIFEST,
    LabelledWindows,
    save_split,
    write_manifest,
)
from uavsnn.dataset.splits import POOL_FACTOR, SENSOR, Progress, Recorder, WindowCut
from uavsnn.dataset.synthetic import SceneSource, synthetic_split
from uavsnn.errors import DatasetError, ParameterError
from uavsnn.sim import Pix2NvsParams
from uavsnn.windows import Windows

__all__ = ["DATASET_DOMAINS", "DatasetPaths", "build", "build_demo"]

DATASET_DOMAINS = ("dvs", "sim", "real", "combined")


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
    window = WindowCut(round(window_ms * 1000), float(overlap), float(min_fraction))
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
    rec = Recorder(seed, window, report)
    if domain in ("dvs", "sim"):
        splits, sources, description = _synthetic(
            rec, dvs if domain == "dvs" else sim, n_test, n_train or 0
        )
    elif domain == "real":
        if video_dir is None:  # checked above; for the type checker
            raise ParameterError("the real domain needs videos")
        splits = real_splits(rec, video_dir, n_test, n_train, test_fraction, pix2nvs_params)
        sources = [_real_source(video_dir, pix2nvs_params)]
        description = f"labelled videos in {video_dir} through PIX2NVS"
    else:
        splits, sources, description = _combined(
            rec, dvs, sim, video_dir, n_test, n_train or 0, test_fraction, pix2nvs_params
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
        "recordings": rec.records,
    }
    manifest_path = write_manifest(root, _jsonable(manifest))
    getattr(report, "close", lambda: None)()  # the bar's last line
    return DatasetPaths(root, manifest_path, paths)


def _synthetic(
    rec: Recorder, source: SceneSource, n_test: int, n_train: int
) -> tuple[dict[str, LabelledWindows], list[dict[str, Any]], str]:
    splits = {"test": synthetic_split(rec, source, "test", n_test)}
    if n_train:
        splits["train"] = synthetic_split(rec, source, "train", n_train)
    simulator = "the DVS emulator" if source.domain == "dvs" else "PIX2NVS"
    return splits, [source.describe()], f"rendered scenes (uavsnn.scenes) through {simulator}"


def _combined(
    rec: Recorder,
    dvs: SceneSource,
    sim: SceneSource,
    video_dir: Path | None,
    n_test: int,
    n_train: int,
    test_fraction: float,
    params: Pix2NvsParams | None,
) -> tuple[dict[str, LabelledWindows], list[dict[str, Any]], str]:
    """Test: the dvs test set. Train: equal shares of dvs, sim and (with videos) real."""
    splits = {"test": synthetic_split(rec, dvs, "test", n_test)}
    sources = [dvs.describe(), sim.describe()]
    names = ["dvs", "sim"] + (["real"] if video_dir is not None else [])
    share = [n_train // len(names) + (k < n_train % len(names)) for k in range(len(names))]
    parts = []
    if share[0]:
        parts.append(synthetic_split(rec, dvs, "train", share[0]))
    if share[1]:
        parts.append(synthetic_split(rec, sim, "train", share[1]))
    if video_dir is not None:
        sources.append(_real_source(video_dir, params))
        if share[2]:
            # The real clips are split as a real build with this seed splits them; only the
            # train clips are used.
            real = real_splits(
                rec, video_dir, n_test, share[2], test_fraction, params, make=("train",)
            )
            parts.append(real["train"])
    if parts:
        splits["train"] = _concat(parts)
    return splits, sources, f"train: {' + '.join(names)}; test: dvs"


def _real_source(video_dir: Path, params: Pix2NvsParams | None) -> dict[str, Any]:
    return {
        "domain": "real",
        "videos": str(video_dir),
        "simulator": "uavsnn.sim.video_to_recording(mode='sim')",
        "simulator_params": _describe(params or Pix2NvsParams()),
    }


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
    from uavsnn.progress import bar as new_bar

    bar = new_bar(total=None, desc="dataset", unit=" step", leave=False)

    def step(msg: str) -> None:
        bar.set_description_str(msg, refresh=False)
        bar.update(1)

    step.close = bar.close  # type: ignore[attr-defined]
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
