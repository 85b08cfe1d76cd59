"""Splits of real labelled footage.

The box files say, before any video is decoded, which windows of each clip are usable and
which hold a UAV, so a build plans first — every clip's windows from its box file and the
container's frame count — splits the clips by class, draws the windows, and only then simulates
the clips that contribute.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from uavsnn.dataset.format import LabelledWindows, RawEvents, file_sha256
from uavsnn.dataset.labels import WindowLabels
from uavsnn.dataset.real import Clip, clip_labels, crop_box, find_clips
from uavsnn.dataset.splits import (
    DOMAIN_KEY,
    SENSOR,
    SPLIT_KEY,
    Pool,
    Recorder,
    WindowCut,
    balanced,
    first_uav_us,
    keyed_rng,
    keyed_seed,
    take_labels,
)
from uavsnn.errors import DatasetError, InternalError
from uavsnn.events import Recording
from uavsnn.sim import Pix2NvsParams, probe_video, video_to_recording
from uavsnn.windows import Windows

__all__ = [
    "ClipPlan",
    "clip_recording",
    "decoded_labelled",
    "plan_clip",
    "real_splits",
    "simulate_clip",
    "split_clips",
]

_REAL = DOMAIN_KEY["real"]


@dataclass(frozen=True)
class ClipPlan:
    """A clip's frames as its container and box file describe them, its windows' labels, and
    the sensor they are for."""

    clip: Clip
    timestamps_us: np.ndarray
    frame_labels: np.ndarray
    labelled: np.ndarray
    end_us: int
    windows: WindowLabels
    sensor: tuple[int, int] = SENSOR


#: The most frames a clip's header may report (92 hours at 30 fps): a plan holds a time and a
#: label per frame.
MAX_CLIP_FRAMES = 10**7


def plan_clip(cut: WindowCut, clip: Clip, sensor: tuple[int, int] = SENSOR) -> ClipPlan:
    """Label a clip's windows, cut by ``cut``, on a ``sensor`` from its box file, without
    decoding it.

    Raises:
        DatasetError: the container reports fewer than two frames or more than
            :data:`MAX_CLIP_FRAMES`, or no frame rate of at most 10^6 fps (the limit of
            :mod:`uavsnn.sim`), or the video cropped to the sensor's aspect ratio is smaller
            than the sensor.
    """
    info = probe_video(clip.video)
    if not 2 <= info.frame_count <= MAX_CLIP_FRAMES or not 0 < info.fps <= 1e6:
        # A damaged header: the plan holds a time per frame (4·10^9 frames were 32 GB).
        raise DatasetError(
            f"video {clip.video.name} reports {info.frame_count} frames at {info.fps} fps; "
            f"need 2 to {MAX_CLIP_FRAMES:,} frames and a frame rate of at most 10^6 fps"
        )
    _, _, cw, ch = crop_box((info.width, info.height), sensor)
    if cw < sensor[0] or ch < sensor[1]:
        raise DatasetError(
            f"video {clip.video.name} is {info.width}x{info.height}: cropped to the sensor's "
            f"aspect ratio it is {cw}x{ch}, smaller than the {sensor[0]}x{sensor[1]} sensor "
            f"(PIX2NVS pools events onto the sensor and never enlarges frames)"
        )
    n = int(info.frame_count)
    ts = np.round(np.arange(n) * 1e6 / info.fps).astype(np.uint64)  # as uavsnn.sim times them
    labels, labelled = clip_labels(clip, n, (info.width, info.height), sensor, video_frames=n)
    end_us = int(ts[-1] + (ts[-1] - ts[-2]))
    windows = cut.label(cut.starts(end_us), ts, labels, labelled)
    return ClipPlan(clip, ts, labels, labelled, end_us, windows, sensor)


def split_clips(
    rec: Recorder, plans: list[ClipPlan], n_test: int, test_fraction: float
) -> np.ndarray:
    """Which clips are for testing: per class a shuffled ``test_fraction`` (at least one), then
    more, round-robin over the classes that supply the label, while the test clips hold fewer
    than ``n_test / 2`` usable windows of either label."""
    rng = keyed_rng(rec.seed, _REAL, 0)
    clips = [p.clip for p in plans]
    is_test = np.zeros(len(plans), dtype=bool)
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
            int((p.windows.usable & (p.windows.label == label)).sum())
            for j, p in enumerate(plans)
            if is_test[j]
        )

    uav_classes = {c.cls for c in clips if c.uav}
    for label, need in ((True, n_test // 2), (False, n_test - n_test // 2)):
        # UAV windows come from UAV clips; the others from the other classes.
        classes = [c for c in queues if (c in uav_classes) == label]
        while count(label) < need and any(queues[c] for c in classes):
            for c in classes:
                if queues[c] and count(label) < need:
                    is_test[queues[c].pop(0)] = True
    return is_test


def _draw(
    rec: Recorder, plans: list[ClipPlan], members: list[int], split: str, n: int | None
) -> dict[int, np.ndarray]:
    """Per clip, the windows ``split`` takes: ``n`` balanced ones, or all usable for ``None``."""
    empty = np.zeros(0, dtype=np.int64)
    usable = [plans[j].windows.usable for j in members]
    clip_of = np.concatenate(
        [np.full(int(u.sum()), j, dtype=np.int64) for j, u in zip(members, usable, strict=True)]
        or [empty]
    )
    window_of = np.concatenate([np.flatnonzero(u) for u in usable] or [empty])
    label = np.concatenate(
        [plans[j].windows.label[u] for j, u in zip(members, usable, strict=True)]
        or [np.zeros(0, dtype=bool)]
    )
    if n is None:
        pick = np.arange(len(label))
        if len(pick) == 0:
            raise DatasetError(f"the real {split} split has no usable windows")
    else:
        pick = balanced(
            label, n, keyed_rng(rec.seed, _REAL, SPLIT_KEY[split], 2), f"real {split} pool"
        )
    return {
        j: np.sort(window_of[pick][clip_of[pick] == j]) for j in np.unique(clip_of[pick]).tolist()
    }


def clip_recording(seed: int, j: int, plan: ClipPlan, params: Pix2NvsParams | None) -> Recording:
    """The events of clip ``j`` (its position among the folder's clips,
    :func:`~uavsnn.dataset.find_clips`) of a build with ``seed``: the clip through the "sim"
    path on the plan's sensor, as the build simulates it."""
    return video_to_recording(
        plan.clip.video, "sim", size=plan.sensor, seed=keyed_seed(seed, _REAL, 9, j), params=params
    )


def decoded_labelled(plan: ClipPlan, recording: Recording) -> np.ndarray:
    """The plan's labelled frames among those ``recording`` (the clip's events) decoded:
    frames the container promised but that did not decode carry no events, and are not
    scored."""
    labelled = plan.labelled.copy()
    labelled[int(recording.metadata.get("frames", len(labelled))) :] = False
    return labelled


def simulate_clip(
    seed: int,
    cut: WindowCut,
    j: int,
    plan: ClipPlan,
    params: Pix2NvsParams | None,
    keep: np.ndarray,
) -> tuple[Windows, WindowLabels, int, RawEvents]:
    """Clip ``j`` through the "sim" path, cut into the planned windows and labelled again;
    returns the windows at ``keep`` (sorted indices), their labels, the clip's event count and
    the raw events behind those windows (the unit of work a build runs, here or as a Ray
    task)."""
    recording = clip_recording(seed, j, plan, params)
    labelled = decoded_labelled(plan, recording)
    windows = cut.cut(recording, plan.end_us)
    if not np.array_equal(windows.t0, cut.starts(plan.end_us)):
        raise InternalError(f"windows of {plan.clip.name} do not start where they were planned")
    labels = cut.label(windows.t0, plan.timestamps_us, plan.frame_labels, labelled)
    kept = windows.select(keep)
    length = windows.length_us
    raw = RawEvents.of_recording(recording.events, kept.t0, length, length)
    return kept, take_labels(labels, keep), len(recording), raw


def real_splits(
    rec: Recorder,
    videos: Path,
    n_test: int,
    n_train: int | None,
    test_fraction: float,
    params: Pix2NvsParams | None,
    make: tuple[str, ...] = ("test", "train"),
    sensor: tuple[int, int] = SENSOR,
) -> dict[str, LabelledWindows]:
    """The splits in ``make`` of the labelled videos in ``videos`` on a ``sensor``: ``n_test``
    balanced test windows; ``n_train`` balanced train windows, or every usable one for
    ``None``.

    Raises:
        DatasetError: bad footage (see :func:`~uavsnn.dataset.find_clips`), too few windows to
            balance a split, or a clip that decodes to fewer frames than a drawn window needs.
    """
    plans = [plan_clip(rec.cut, c, sensor) for c in find_clips(videos)]
    is_test = split_clips(rec, plans, n_test, test_fraction)
    chosen: dict[str, dict[int, np.ndarray]] = {}
    for split, n in (("test", n_test), ("train", n_train)):
        if n != 0 and split in make:
            members = [j for j in range(len(plans)) if is_test[j] == (split == "test")]
            chosen[split] = _draw(rec, plans, members, split, n)
    pools = {split: Pool() for split in chosen}
    # The clips that contribute, simulated in order (in flight together on a cluster); each
    # returns only the windows some split takes.
    needed = {
        j: np.unique(np.concatenate([chosen[s][j] for s in chosen if j in chosen[s]]))
        for j in range(len(plans))
        if any(j in chosen[s] for s in chosen)
    }
    simulated = rec.runner.imap(
        simulate_clip,
        ((rec.seed, rec.cut, j, plans[j], params, keep) for j, keep in needed.items()),
    )
    try:
        for j, plan in enumerate(plans):
            w = plan.windows
            rec_id = rec.record(
                {
                    "name": plan.clip.name,
                    "domain": "real",
                    "split": "test" if is_test[j] else "train",
                    "kind": plan.clip.cls,
                    "video": plan.clip.video.name,
                    "boxes_sha256": file_sha256(plan.clip.boxes),
                    "windows": len(w.label),
                    "usable": int(w.usable.sum()),
                    "usable_uav": int((w.usable & w.label).sum()),
                    "first_uav_us": first_uav_us(rec.cut.starts(plan.end_us), w),
                }
            )
            splits = [s for s in chosen if j in chosen[s]]
            if not splits:
                continue
            windows, labels, n_events, raw = next(simulated)
            rec.records[rec_id]["events"] = n_events
            for split in splits:
                keep = np.zeros(len(windows), dtype=bool)
                keep[np.searchsorted(needed[j], chosen[split][j])] = True
                if not np.all(labels.usable[keep]):
                    raise DatasetError(
                        f"clip {plan.clip.name} decodes to fewer frames than its container and box "
                        f"file promised; windows drawn from it are no longer usable"
                    )
                pools[split].add(rec_id, windows, labels, keep, raw=raw)
            rec.progress(f"real: {plan.clip.name}")
    finally:
        simulated.close()
    return {split: rec.mark_used(pool.take()) for split, pool in pools.items()}
