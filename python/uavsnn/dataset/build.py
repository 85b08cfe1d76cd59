"""Build labelled datasets: recordings, windows, labels, splits by recording, a manifest.

The rules — what makes a window a UAV window, how splits and balanced test sets are drawn,
what each domain contains — are in ``docs/dataset.md``; this module carries them out.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import secrets
import shutil
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn import __version__
from uavsnn.dataset.footage import plan_clip, real_splits, split_clips
from uavsnn.dataset.format import (
    FORMAT_NAME,
    FORMAT_VERSION,
    LOCK,
    MANIFEST,
    LabelledWindows,
    RawEvents,
    locked_folder,
    save_split,
    write_manifest,
)
from uavsnn.dataset.real import find_clips
from uavsnn.dataset.splits import POOL_FACTOR, SENSOR, Progress, Recorder, WindowCut, balanced
from uavsnn.dataset.synthetic import SceneSource, default_source, synthetic_split
from uavsnn.distributed import Runner
from uavsnn.errors import DatasetError, ParameterError
from uavsnn.sim import Pix2NvsParams
from uavsnn.windows import Windows

__all__ = [
    "DATASET_DOMAINS",
    "MAX_SENSOR_SIDE",
    "SENSOR_SIZES",
    "DatasetPaths",
    "build",
    "build_demo",
    "check_footage",
    "parse_sensor",
]

DATASET_DOMAINS = ("dvs", "sim", "real", "combined")
#: The sensors that users buy: the paper's DVS240, DAVIS346, Prophesee Gen3 and Gen4.
SENSOR_SIZES = ((240, 180), (346, 260), (640, 480), (1280, 720))
#: The largest sensor side a dataset takes: the scene renderer's largest frame (the engine's
#: events and windows reach 65535).
MAX_SENSOR_SIDE = 4096
#: The most windows a split may ask for (500 times the SPEC §5 test split): a bound on
#: counts no build means, not on memory, which grows with the sensor (docs/dataset.md).
MAX_SPLIT_WINDOWS = 10**6
_MIN_SENSOR_SIDE = 8
#: The share of each class's real clips kept for test where ``test_fraction`` is not given.
TEST_FRACTION = 0.3
_WXH = re.compile(r"^\s*(\d+)\s*[xX×]\s*(\d+)\s*$")


def parse_sensor(value: object) -> tuple[int, int]:
    """A sensor size from ``"WxH"`` or a ``(width, height)`` pair of integers, each side in
    ``[8, MAX_SENSOR_SIDE]``.

    Raises:
        ParameterError: anything else, saying what was expected.
    """
    if isinstance(value, str):
        m = _WXH.match(value)
        if m is None:
            raise ParameterError(f"sensor must be WIDTHxHEIGHT in whole pixels, got {value!r}")
        size: tuple[object, ...] = (int(m.group(1)), int(m.group(2)))
    elif isinstance(value, (tuple, list)) and len(value) == 2:
        size = tuple(value)
    else:
        raise ParameterError(f"sensor must be WIDTHxHEIGHT or (width, height), got {value!r}")
    if not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in size):
        raise ParameterError(f"sensor sides must be integers, got {value!r}")
    w, h = (int(v) for v in size)  # type: ignore[call-overload]
    if not (_MIN_SENSOR_SIDE <= w <= MAX_SENSOR_SIDE and _MIN_SENSOR_SIDE <= h <= MAX_SENSOR_SIDE):
        raise ParameterError(
            f"sensor sides must be {_MIN_SENSOR_SIDE} to {MAX_SENSOR_SIDE} pixels (the largest "
            f"frame the scene renderer draws), got {w}x{h}"
        )
    return w, h


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
    test_fraction: float | None,
) -> None:
    if domain not in DATASET_DOMAINS:
        raise ParameterError(f"domain must be one of {DATASET_DOMAINS}, got {domain!r}")
    if domain == "real" and videos is None:
        raise ParameterError("the real domain needs videos: a folder like svanstrom-dev")
    if domain in ("dvs", "sim") and videos is not None:
        raise ParameterError(
            f"videos are real clips: for the real or combined domain, not {domain} (a {domain} "
            "build would leave them unread)"
        )
    if test_fraction is not None and (
        domain in ("dvs", "sim") or (domain == "combined" and videos is None)
    ):
        raise ParameterError(
            "test_fraction splits the real clips: for the real domain, or combined with videos, "
            f"not {domain}" + (" without videos" if domain == "combined" else "") + f" (a "
            f"{domain} build would leave it unused)"
        )
    if isinstance(n_test, bool) or not isinstance(n_test, int) or n_test < 2 or n_test % 2:
        raise ParameterError(f"n_test must be an even integer >= 2, got {n_test!r}")
    if n_train is not None and (
        isinstance(n_train, bool) or not isinstance(n_train, int) or n_train < 0
    ):
        raise ParameterError(f"n_train must be a non-negative integer or None, got {n_train!r}")
    if n_train is not None and n_train % 2:
        # Half UAV, as the test split: 1 window had no UAV, 3 had 1 UAV and 2 not.
        raise ParameterError(
            f"n_train must be an even integer >= 2 (half UAV) or 0 (no train split), "
            f"got {n_train!r}"
        )
    for name, n in (("n_test", n_test), ("n_train", n_train or 0)):
        if n > MAX_SPLIT_WINDOWS:
            # A split is held whole before it is written: 2·10^9 windows ran until killed.
            raise ParameterError(
                f"{name} must be at most {MAX_SPLIT_WINDOWS:,} windows, got {n:,} (a split is "
                "held in memory: about 70 MB per 1000 windows at 240x180, 1.5 GB at 1280x720)"
            )
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
    if test_fraction is not None and not (
        isinstance(test_fraction, (int, float)) and 0.0 < test_fraction < 1.0
    ):
        raise ParameterError(f"test_fraction must be in (0, 1), got {test_fraction!r}")


#: What a dataset's folder holds of its own (beside :data:`LOCK`): its manifest, its split files,
#: and what a build killed part way may leave there (a staging folder made inside the folder,
#: a file's temporary name). An overwrite replaces these, and nothing else.
_OWN = re.compile(
    r"(manifest\.json|(test|train)\.npz|\.building-[0-9a-f]{12}"
    r"|\.(manifest\.json|(test|train)\.npz)\.[0-9a-f]{12}\.tmp)"
)


def _own(name: str) -> bool:
    """Whether ``name`` in a dataset's folder is the dataset's (:data:`_OWN`)."""
    return _OWN.fullmatch(name) is not None


def _prepare(out_dir: str | Path, overwrite: bool) -> Path:
    """Check that a build may write its dataset into ``out_dir`` (empty, or a dataset and
    ``overwrite``, holding nothing that is not the dataset's); nothing there is removed yet:
    :func:`_replace_contents` does it once the new dataset is whole."""
    root = Path(out_dir)
    if root.exists() and not root.is_dir():
        raise DatasetError(f"{root} exists and is not a folder")
    if root.is_dir() and any(p.name != LOCK for p in root.iterdir()):
        if not overwrite:
            raise DatasetError(
                f"{root} is not empty; choose another folder, or overwrite a dataset there "
                "(overwrite=True, --overwrite)"
            )
        if not (root / MANIFEST).is_file():
            raise DatasetError(f"{root} is not empty and not a dataset: refusing to overwrite it")
        others = sorted(
            p.name + ("/" if p.is_dir() else "")
            for p in root.iterdir()
            if p.name != LOCK and not _own(p.name)
        )
        if others:
            more = f" and {len(others) - 3} more" if len(others) > 3 else ""
            raise DatasetError(
                f"{root} holds more than a dataset ({', '.join(others[:3])}{more}): refusing to "
                "overwrite it (overwrite replaces a dataset's own manifest.json, test.npz and "
                "train.npz); move the others out, or choose another folder"
            )
    root.mkdir(parents=True, exist_ok=True)
    return root


@contextlib.contextmanager
def _staging(root: Path) -> Iterator[Path]:
    """A new, empty, hidden folder to build ``root``'s dataset in, removed with whatever it
    holds when the block is left (by :func:`_replace_contents`, the old dataset). It lies
    beside ``root`` (the folder it resolves to, so that a link is followed), or inside it
    where the folder beside it could not be made or is on another file system (a rename
    cannot move a file between file systems)."""
    real = root.resolve()
    token = secrets.token_hex(6)
    stage = real.parent / f".{real.name}.building-{token}"
    try:
        stage.mkdir()
    except OSError:
        beside = False
    else:
        beside = stage.stat().st_dev == real.stat().st_dev
        if not beside:
            stage.rmdir()
    if not beside:
        stage = real / f".building-{token}"
        stage.mkdir()
    try:
        yield stage
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def _replace_contents(root: Path, stage: Path) -> None:
    """Put the dataset built in ``stage`` in ``root`` in place of the dataset ``root`` holds
    (its own files, :data:`_OWN`: not :data:`LOCK`, held by the build, nor a file put there
    while it ran), which goes into ``stage`` (removed with it). Each file is
    renamed, no data copied: the old manifest goes first and the new one comes last, so the
    folder is never a dataset of mixed files; should a rename fail, or be interrupted, the
    ones done are undone, and ``root`` is as it was."""
    old = stage / ".old"
    old.mkdir()
    # The old manifest first, the new one last.
    leaving = sorted(
        (p.name for p in root.iterdir() if p.name != stage.name and _own(p.name)),
        key=lambda name: name != MANIFEST,
    )
    coming = sorted((p.name for p in stage.iterdir() if p != old), key=lambda n: n == MANIFEST)
    gone: list[str] = []
    came: list[str] = []
    try:
        for name in leaving:
            os.replace(root / name, old / name)
            gone.append(name)
        for name in coming:
            os.replace(stage / name, root / name)
            came.append(name)
    except BaseException:
        for name in reversed(came):
            os.replace(root / name, stage / name)
        for name in reversed(gone):
            os.replace(old / name, root / name)
        raise


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
    test_fraction: float | None = None,
    dvs: SceneSource | None = None,
    sim: SceneSource | None = None,
    pix2nvs_params: Pix2NvsParams | None = None,
    sensor: tuple[int, int] | str = SENSOR,
    overwrite: bool = False,
    progress: bool | Progress = False,
    runner: Runner | None = None,
    stratify: bool = False,
) -> DatasetPaths:
    """Build a dataset in ``out_dir``: ``test.npz`` (``n_test`` windows, half with a UAV),
    ``train.npz`` (``n_train`` windows, balanced the same way; all usable windows of the train
    clips for ``domain="real"`` with ``n_train=None``; none for 0) and ``manifest.json``.

    ``domain``: ``"dvs"`` (rendered scenes through the DVS emulator), ``"sim"`` (rendered video
    through PIX2NVS), ``"real"`` (the labelled videos in ``videos`` through PIX2NVS) or
    ``"combined"`` (train: dvs and sim, and real when ``videos`` is given, in equal shares;
    test: the dvs test set — the paper tests every network on DVS data). Splits are by
    recording; ``docs/dataset.md`` gives every rule. ``dvs``/``sim`` override how those scenes
    are made (defaults: 1 s at 500 fps at the sensor's size; 3 s at 30/60 fps at
    :func:`~uavsnn.dataset.synthetic.sim_render_size`, 480×360 for 240×180).

    ``test_fraction``: the share of each class's real clips kept for test (default 0.3), for
    ``domain="real"``, or ``"combined"`` with ``videos``; refused where no real clip is read.

    ``sensor``: ``(width, height)`` or ``"WxH"`` (default 240×180; 346×260, 640×480 and
    1280×720 are today's cameras). Scenes keep their field of view in degrees, so the same
    recording shows its objects over more pixels on a larger sensor; real clips must be at
    least the sensor's size once cropped to its aspect ratio.
    ``runner`` simulates the recordings: in this process by default, or as Ray tasks
    (:func:`uavsnn.distributed.connect`); the dataset is the same either way.
    ``stratify``: the rendered scenes of non-UAV objects take each kind of object in its share
    (:func:`uavsnn.scenes.object_shares`) instead of drawing it, so that a small set — a
    tuning set — holds every kind (manifest: ``"object_scenes": "stratified"``).

    The dataset is built in a hidden folder beside ``out_dir`` and put in its place only once
    whole (with ``overwrite``, the old dataset goes then; a folder that holds anything else is
    refused before any work, so nothing but a dataset is replaced): a build that fails or is
    interrupted leaves ``out_dir`` as it was, the old dataset whole, and no folder it made.

    Raises:
        ParameterError: impossible arguments.
        DatasetError: a non-empty ``out_dir`` (unless ``overwrite`` and it holds a dataset and
            nothing else: ``overwrite`` replaces the dataset's own files, never others),
            missing or malformed footage, or too few windows to fill a balanced split.
    """
    _check_build_args(
        domain, videos, n_test, n_train, window_ms, overlap, seed, min_fraction, test_fraction
    )
    sensor = parse_sensor(sensor)
    fraction = TEST_FRACTION if test_fraction is None else test_fraction
    if n_train is None and domain != "real":
        raise ParameterError("n_train=None (all windows) is only for the real domain")
    if stratify and domain == "real":
        raise ParameterError("stratify is for rendered scenes; the real domain has none")
    window = WindowCut(round(window_ms * 1000), float(overlap), float(min_fraction))
    # Only the sources the domain uses are made and checked.
    uses = {"dvs": ("dvs",), "sim": ("sim",), "real": (), "combined": ("dvs", "sim")}[domain]
    if "dvs" in uses:
        dvs = dvs or default_source("dvs", sensor)
    if "sim" in uses:
        sim = sim or replace(default_source("sim", sensor), pix2nvs_params=pix2nvs_params)
    for source in (dvs, sim):
        if source is None or source.domain not in uses:
            continue
        if tuple(source.sensor) != sensor:
            raise ParameterError(
                f"the {source.domain} source makes {source.sensor[0]}x{source.sensor[1]} "
                f"events, the dataset's sensor is {sensor[0]}x{sensor[1]}"
            )
        if source.duration_s * 1e6 < window.length_us:
            raise ParameterError(
                f"windows of {window_ms} ms are longer than the {source.domain} recordings "
                f"({source.duration_s} s)"
            )
    video_dir = Path(videos) if videos is not None else None
    if video_dir is not None and not video_dir.is_dir():
        raise DatasetError(f"video folder {video_dir} does not exist or is not a folder")
    # Folders are made only now, every argument checked: a refused build leaves none. The
    # dataset is built in a folder of its own, and put in place of what ``out_dir`` holds only
    # once whole: a build that fails or is interrupted leaves ``out_dir`` as it was.
    with locked_folder(out_dir) as root, _staging(_prepare(root, overwrite)) as stage:
        report = _reporter(progress)
        rec = Recorder(seed, window, report, runner, stratify=stratify)
        if domain in ("dvs", "sim"):
            source = dvs if domain == "dvs" else sim
            if source is None:  # made above; for the type checker
                raise ParameterError(f"no {domain} source")
            splits, sources, description = _synthetic(rec, source, n_test, n_train or 0)
        elif domain == "real":
            if video_dir is None:  # checked above; for the type checker
                raise ParameterError("the real domain needs videos")
            splits = real_splits(
                rec, video_dir, n_test, n_train, fraction, pix2nvs_params, sensor=sensor
            )
            sources = [_real_source(video_dir, pix2nvs_params)]
            description = f"labelled videos in {video_dir} through PIX2NVS"
        else:
            if dvs is None or sim is None:  # made above; for the type checker
                raise ParameterError("the combined domain needs dvs and sim sources")
            splits, sources, description = _combined(
                rec,
                dvs,
                sim,
                video_dir,
                n_test,
                n_train or 0,
                fraction,
                pix2nvs_params,
                sensor,
            )
        for described in sources:
            if described["domain"] == "real" and video_dir is not None:
                described.update(_videos_from(root, video_dir))
        paths: dict[str, Path] = {}
        for name, data in splits.items():
            if len(data) == 0:
                raise DatasetError(f"the {name} split is empty")
            paths[name] = root / save_split(stage / f"{name}.npz", data).name
        manifest = {
            "format": FORMAT_NAME,
            "format_version": FORMAT_VERSION,
            "created_by": f"uavsnn {__version__}",
            "domain": domain,
            "source": description,
            "seed": seed,
            "parameters": {
                "sensor_size": list(sensor),
                "window_ms": window_ms,
                "window_us": window.length_us,
                "overlap": overlap,
                "step_us": window.step_us,
                "min_visible_fraction": min_fraction,
                "n_test": n_test,
                "n_train": n_train,
                "test_fraction": fraction if domain in ("real", "combined") else None,
                "pool_factor": POOL_FACTOR,
                # Real footage draws no scenes: None (a combined set's dvs and sim ones are).
                "object_scenes": (
                    None if domain == "real" else "stratified" if stratify else "drawn"
                ),
                "sources": sources,
            },
            "splits": {
                name: _summary(data, paths[name].name, data.recording)
                for name, data in splits.items()
            },
            "recordings": rec.records,
        }
        write_manifest(stage, _jsonable(manifest))
        _replace_contents(root, stage)
        getattr(report, "close", lambda: None)()  # the bar's last line
        return DatasetPaths(root, root / MANIFEST, paths)


def check_footage(
    videos: str | Path,
    sensor: tuple[int, int] | str = SENSOR,
    *,
    n_test: int = 2000,
    n_train: int | None = None,
    seed: int = 0,
    window_ms: float = 50.0,
    overlap: float = 0.5,
    min_fraction: float = 0.5,
    test_fraction: float = 0.3,
) -> int:
    """Check, without decoding a frame, that the labelled videos in ``videos`` give a real
    build (:func:`build` with ``domain="real"`` and these arguments) its splits, as the build
    plans them before it simulates a clip: the clips and their box files are found and read,
    each container reports its frames and frame rate and is large enough for ``sensor``, the
    clips are split by class, and each split's windows are drawn. A clip that decodes to fewer
    frames than its container reports is seen only when the build decodes it. Returns the
    number of clips.

    Raises:
        ParameterError: impossible arguments (as :func:`build` refuses them).
        DatasetError: no such folder, no labelled videos in it, a box file or a container
            that the build refuses, a video smaller than ``sensor``, or too few windows to
            fill a balanced split.
    """
    _check_build_args(
        "real", videos, n_test, n_train, window_ms, overlap, seed, min_fraction, test_fraction
    )
    sensor = parse_sensor(sensor)
    cut = WindowCut(round(window_ms * 1000), float(overlap), float(min_fraction))
    rec = Recorder(seed, cut, lambda _msg: None)
    plans = [plan_clip(cut, clip, sensor) for clip in find_clips(Path(videos))]
    is_test = split_clips(rec, plans, n_test, test_fraction)
    for split, n in (("test", n_test), ("train", n_train)):
        if n == 0:
            continue
        # The usable windows' labels of the split's clips, refused as the build's draw does.
        members = [p.windows for j, p in enumerate(plans) if is_test[j] == (split == "test")]
        label = np.concatenate([w.label[w.usable] for w in members] or [np.zeros(0, bool)])
        if n is None and len(label) == 0:
            raise DatasetError(f"the real {split} split has no usable windows")
        if n is not None:
            balanced(label, n, np.random.default_rng(0), f"real {split} pool")
    return len(plans)


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
    sensor: tuple[int, int],
) -> tuple[dict[str, LabelledWindows], list[dict[str, Any]], str]:
    """Test: the dvs test set. Train: equal shares of dvs, sim and (with videos) real."""
    splits = {"test": synthetic_split(rec, dvs, "test", n_test)}
    sources = [dvs.describe(), sim.describe()]
    names = ["dvs", "sim"] + (["real"] if video_dir is not None else [])
    # Shared in pairs, so that each part, and so the whole, is half UAV (shares of 3 windows
    # from 6 held 1 UAV each: 2 of 6).
    pairs = n_train // 2
    share = [2 * (pairs // len(names) + (k < pairs % len(names))) for k in range(len(names))]
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
                rec,
                video_dir,
                n_test,
                share[2],
                test_fraction,
                params,
                make=("train",),
                sensor=sensor,
            )
            parts.append(real["train"])
    if parts:
        splits["train"] = _concat(parts)
    return splits, sources, f"train: {' + '.join(names)}; test: dvs"


def _videos_from(root: Path, video_dir: Path) -> dict[str, str]:
    """``videos_from_dataset``: the folder of videos as a path from the dataset's folder
    ``root``, so that a dataset read from another working folder finds its clips again
    (``videos`` is the folder as it was given, relative to the build's working folder); none
    where there is no such path (another drive)."""
    try:
        relative = os.path.relpath(video_dir.resolve(), root.resolve())
    except ValueError:
        return {}
    return {"videos_from_dataset": Path(relative).as_posix()}


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
        range_m=np.concatenate([p.range_m for p in parts]),
        size_px=np.concatenate([p.size_px for p in parts]),
        raw=RawEvents.concatenate([p.raw for p in parts if p.raw is not None])
        if all(p.raw is not None for p in parts)
        else None,
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
