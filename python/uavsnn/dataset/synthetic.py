"""Synthetic labelled recordings — a sampled scene, rendered, turned into events — and the
splits made of them.

- "dvs": :func:`uavsnn.scenes.record` renders the scene at the sensor's size (240×180 by
  default) at a high frame rate (500 fps by default) as linear intensity, its fast parts
  (rotors, wings) also between frames, and :class:`uavsnn.sim.DvsEmulator` makes the events.
- "sim": the scene is rendered as 8-bit colour video (30 or 60 fps; by default at the sensor's
  aspect ratio and at least 480 pixels wide: 480×360 for 240×180 — the 4:3 centre of a 640×360
  camera — and the sensor's own size from 480 pixels up, see :func:`sim_render_size`), and
  PIX2NVS (:class:`uavsnn.sim.Pix2NvsSimulator`) makes events at that size and pools them
  onto the sensor, as the paper did with its 1080p footage.

Scenes are sampled with the field of view in degrees (see :func:`uavsnn.scenes.sample_spec`),
so recording ``i`` of a split is the same scene on every sensor of one aspect ratio, its
objects covering more pixels on the larger sensors.

Labels follow the frames onto the sensor (the same crop and scale as the frames). A split is
made of recordings rendered for it alone (:func:`synthetic_split`).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from uavsnn.dataset.format import LabelledWindows, RawEvents
from uavsnn.dataset.labels import WindowLabels
from uavsnn.dataset.real import boxes_to_sensor, crop_box
from uavsnn.dataset.splits import (
    DOMAIN_KEY,
    POOL_FACTOR,
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
from uavsnn.errors import DatasetError, ParameterError, SimulationError
from uavsnn.events import Recording
from uavsnn.scenes import Lens, SceneSpec, object_shares, record, render, sample_spec
from uavsnn.scenes.sampler import fov_range
from uavsnn.sim import SCENE_PARAMS, DvsParams, Pix2NvsParams, Pix2NvsSimulator, crop_to_aspect
from uavsnn.windows import Windows

__all__ = [
    "MAX_FRAME_BYTES",
    "LabelledRecording",
    "SceneSource",
    "default_source",
    "scene_spec",
    "sim_render_size",
    "stratified_object",
    "synthetic_recording",
    "synthetic_split",
    "synthetic_windows",
]

#: Give up when this many recordings in a row add nothing that a split still needs.
STALL = 25
#: A sim recording's frames are rendered in memory at once; a source whose frames would take
#: more than this is refused (the dvs domain streams its frames through
#: :func:`uavsnn.scenes.record` and is not bound by it).
MAX_FRAME_BYTES = 2 * 1024**3
#: The sim domain renders at least this many pixels wide.
SIM_MIN_WIDTH = 480


def sim_render_size(sensor: tuple[int, int]) -> tuple[int, int]:
    """The sim domain's default frame size for ``sensor``: its aspect ratio, at least
    :data:`SIM_MIN_WIDTH` wide (240×180 → 480×360, 346×260 → 480×361, 640×480 → 640×480)."""
    w, h = sensor
    if w >= SIM_MIN_WIDTH:
        return w, h
    return SIM_MIN_WIDTH, max(h, round(h * SIM_MIN_WIDTH / w))


def default_source(domain: str, sensor: tuple[int, int] = (240, 180)) -> SceneSource:
    """How ``domain`` ("dvs" or "sim") recordings are made by default for ``sensor``: dvs 1 s at
    500 fps at the sensor's size; sim 3 s at 30 or 60 fps at :func:`sim_render_size`."""
    size = (int(sensor[0]), int(sensor[1]))
    if domain == "dvs":
        return SceneSource("dvs", size, 500.0, 1.0, sensor=size)
    return SceneSource("sim", sim_render_size(size), None, 3.0, sensor=size)


@dataclass(frozen=True)
class SceneSource:
    """How recordings of one synthetic domain are made: render ``size``, frame rate (``None``:
    the domain's default), clip ``duration_s``, the sensor size, the simulator's parameters
    (``None``: its defaults), the camera's ``lens`` (dvs only; ``None``: a pinhole, every
    range sharp; :class:`uavsnn.scenes.Lens`) and the range ``fov_deg`` its horizontal field
    of view is drawn from (``None``: the domain's, :func:`uavsnn.scenes.sample_spec`). The lens
    changes no draw of the scene: the same seed gives the same objects, light and paths with or
    without it."""

    domain: str
    size: tuple[int, int]
    fps: float | None
    duration_s: float
    sensor: tuple[int, int] = (240, 180)
    dvs_params: DvsParams | None = None
    pix2nvs_params: Pix2NvsParams | None = None
    lens: Lens | None = None
    fov_deg: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.domain not in ("dvs", "sim"):
            raise ParameterError(f"a scene source's domain is 'dvs' or 'sim', got {self.domain!r}")
        if self.lens is not None:
            if not isinstance(self.lens, Lens):
                raise ParameterError(f"lens must be a uavsnn.scenes.Lens, got {self.lens!r}")
            if self.domain != "dvs":
                raise ParameterError(
                    "a lens is for the dvs domain (the sim domain renders video frames, whose "
                    "pixels are not the sensor's)"
                )
            try:
                self.lens.pitch_um(self.sensor)
            except SimulationError as exc:
                raise ParameterError(str(exc)) from exc
        if self.fov_deg is not None:
            object.__setattr__(self, "fov_deg", fov_range(self.domain, self.fov_deg))
        if self.domain == "dvs" and tuple(self.size) != tuple(self.sensor):
            raise ParameterError(
                f"the dvs domain renders at the sensor's size {self.sensor}, got {self.size}"
            )
        crop = crop_box(self.size, self.sensor)
        if self.domain == "sim" and (crop[2] < self.sensor[0] or crop[3] < self.sensor[1]):
            raise ParameterError(
                f"sim frames of {self.size[0]}x{self.size[1]} crop to {crop[2]}x{crop[3]}, "
                f"smaller than the {self.sensor[0]}x{self.sensor[1]} sensor"
            )
        fps = self.fps if self.fps is not None else 60.0
        frames = math.ceil(self.duration_s * fps - 1e-9)
        nbytes = frames * self.size[0] * self.size[1] * (4 if self.domain == "dvs" else 3)
        if self.domain == "sim" and nbytes > MAX_FRAME_BYTES:
            raise ParameterError(
                f"{self.domain} recordings of {frames} frames of {self.size[0]}x{self.size[1]} "
                f"would take {nbytes / 1e9:.1f} GB in memory, more than the "
                f"{MAX_FRAME_BYTES / 1e9:.1f} GB allowed: shorten them or lower the frame rate"
            )

    def describe(self) -> dict[str, Any]:
        """The source's settings, for a manifest."""
        out: dict[str, Any] = {
            "domain": self.domain,
            "render_size": list(self.size),
            "fps": self.fps
            if self.fps is not None
            else "30 or 60"
            if self.domain == "sim"
            else None,
            "duration_s": self.duration_s,
            "sensor_size": list(self.sensor),
        }
        if self.domain == "dvs":
            out["simulator"] = "uavsnn.scenes.record (uavsnn.sim.DvsEmulator, sub-frame samples)"
            out["simulator_params"] = _params(self.dvs_params or SCENE_PARAMS)
            if self.lens is not None:
                out["lens"] = {
                    **self.lens.describe(),
                    "pixel_um": self.lens.pitch_um(self.sensor),
                }
        else:
            out["simulator"] = "uavsnn.sim.Pix2NvsSimulator (events pooled onto the sensor)"
            out["simulator_params"] = _params(self.pix2nvs_params or Pix2NvsParams())
        if self.fov_deg is not None:
            out["fov_deg"] = list(self.fov_deg)
        return out


def _params(p: Any) -> dict[str, Any]:
    return {k: getattr(p, k) for k in p.__dataclass_fields__}


@dataclass
class LabelledRecording:
    """Events with the labels of the frames they came from (in sensor pixels): frame times,
    labels, which frames are labelled, and a description for the manifest."""

    recording: Recording
    timestamps_us: np.ndarray
    labels: np.ndarray
    labelled: np.ndarray
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def end_us(self) -> int:
        """One frame interval after the last frame: the end of the recorded time."""
        t = self.timestamps_us
        return int(t[-1]) + int(t[-1] - t[-2])


def _seeds(seed: int) -> tuple[np.random.SeedSequence, np.random.SeedSequence]:
    """The streams a recording's ``seed`` splits into: its scene's, and its rendering's."""
    spec_seq, render_seq, _ = np.random.SeedSequence(seed).spawn(3)
    return spec_seq, render_seq


def scene_spec(
    source: SceneSource, kind: str, seed: int, object_kind: str | None = None
) -> SceneSpec:
    """The scene :func:`synthetic_recording` renders for these arguments, without rendering it:
    its objects as drawn (kind, size, path, wing beat or rotor rate, ...), its light and
    background, and the source's lens."""
    spec = sample_spec(
        source.domain,
        kind,
        np.random.default_rng(_seeds(seed)[0]),
        size=source.size,
        fps=source.fps,
        duration_s=source.duration_s,
        object_kind=object_kind,
        fov_deg=source.fov_deg,
    )
    return spec if source.lens is None else source.lens.on(spec, source.sensor)


def synthetic_recording(
    source: SceneSource, kind: str, seed: int, object_kind: str | None = None
) -> LabelledRecording:
    """Sample a scene of ``kind`` (and ``object_kind``; see :func:`uavsnn.scenes.sample_spec`),
    render it and simulate its events, all from ``seed``."""
    spec = scene_spec(source, kind, seed, object_kind)
    render_seed = int(_seeds(seed)[1].generate_state(1)[0])
    if source.domain == "dvs":
        # Fast parts sampled between frames, frame by frame into the emulator.
        recorded = record(spec, sensor=source.sensor, seed=render_seed, params=source.dvs_params)
        events, ts, labels = recorded.recording.events, recorded.timestamps_us, recorded.labels
    else:
        frames, ts, labels = render(spec, seed=render_seed)
        crop = crop_to_aspect(frames[0], source.sensor[0] / source.sensor[1]).shape
        size = (crop[1], crop[0])
        if size == tuple(source.sensor):
            sim = Pix2NvsSimulator(size, params=source.pix2nvs_params)
        else:
            sim = Pix2NvsSimulator(
                size, params=source.pix2nvs_params, output_size=source.sensor, pooling="strongest"
            )
        x0, y0, cw, ch = crop_box(source.size, source.sensor)
        events = sim.process(np.ascontiguousarray(frames[:, y0 : y0 + ch, x0 : x0 + cw]), ts)
        del frames
    info = {
        "kind": kind,
        "seed": int(seed),
        "background": spec.background.kind,
        "lighting": round(spec.lighting.level, 4),
        "objects": [
            {
                "kind": o.kind,
                "size_m": round(o.size_m, 4),
                "range_m": round(o.path.start[2], 2),
                "path": o.path.kind,
            }
            for o in spec.objects
        ],
        "fps": spec.fps,
        "frames": spec.n_frames,
        "events": len(events),
    }
    sensor_labels = boxes_to_sensor(labels, source.size, source.sensor)
    return LabelledRecording(
        Recording(events, source.sensor, {"source": "uavsnn.scenes", **info}),
        ts,
        sensor_labels,
        np.ones(len(ts), dtype=bool),
        info,
    )


def synthetic_windows(
    source: SceneSource, cut: WindowCut, kind: str, seed: int, object_kind: str | None = None
) -> tuple[dict[str, Any], Windows, WindowLabels, RawEvents]:
    """One recording of a synthetic split, as its pool takes it: the manifest entry, the
    usable windows with their labels, and the raw events behind those windows (the unit of
    work a build runs, here or as a Ray task)."""
    lr = synthetic_recording(source, kind, seed, object_kind)
    windows = cut.cut(lr.recording, lr.end_us)
    labels = cut.label(windows.t0, lr.timestamps_us, lr.labels, lr.labelled)
    entry = {
        **lr.info,
        "windows": len(windows),
        "usable": int(labels.usable.sum()),
        "usable_uav": int((labels.usable & labels.label).sum()),
        "first_uav_us": first_uav_us(windows.t0, labels),
    }
    keep = np.flatnonzero(labels.usable)
    kept = windows.select(keep)
    length = windows.length_us
    raw = RawEvents.of_recording(lr.recording.events, kept.t0, length, length)
    return entry, kept, take_labels(labels, keep), raw


def _next_kind(
    positives: float, negatives: float, need_pos: int, need_neg: int, kinds: np.random.Generator
) -> str:
    if need_pos and positives / need_pos <= negatives / max(need_neg, 1):
        return "uav"
    return "object" if kinds.random() < 0.7 else "empty"


def stratified_object(shares: dict[str, float], j: int) -> str:
    """The object kind of the ``j``-th object scene (from 0) of a stratified split, by
    Balinski and Young's quota method: among the kinds still below their share of the first
    ``j + 1`` scenes, the one with the largest share per scene it would then have (ties to the
    first in ``shares``). After any number of scenes every kind's count is within one of its
    share: a helicopter of 7.7 % comes once in every 13 scenes, not when chance allows."""
    if j < 0:
        raise ParameterError(f"j must be >= 0, got {j}")
    names = list(shares)
    p = np.array([shares[n] for n in names], dtype=np.float64)
    if len(p) == 0 or not (np.isfinite(p).all() and (p >= 0).all() and p.sum() > 0):
        raise ParameterError(f"shares must be finite, >= 0 and not all 0, got {shares!r}")
    p = p / p.sum()
    count = np.zeros(len(p))
    for n in range(1, j + 2):
        # The shares below quota sum to one scene, so at least one kind is eligible.
        eligible = count < n * p - 1e-12
        pick = int(np.argmax(np.where(eligible, p / (count + 1), -1.0)))
        count[pick] += 1
    return names[pick]


#: A recording's scene: its kind and, for a stratified split's object scenes, its object.
Scene = tuple[str, str | None]


class _Ahead:
    """Recordings started before the build knows it needs them, so that a cluster has work.

    Which kind of scene recording ``i`` is depends on the windows of recordings ``0..i-1``;
    its seed does not. The build decides each kind as on one machine, from the real pool;
    meanwhile the next ``runner.ahead`` recordings are started with the kinds a guess of the
    pool (mean windows per kind so far) gives. A guess that turns out wrong costs only the
    time of that recording: it is dropped and the right kind made, so the result is the
    serial build's whatever the guesses."""

    def __init__(
        self,
        rec: Recorder,
        source: SceneSource,
        seed_of: Callable[[int], int],
        need: tuple[int, int],
        object_of: Callable[[int], str | None],
    ) -> None:
        self.rec, self.source, self.seed_of, self.need = rec, source, seed_of, need
        self.object_of = object_of
        self.pending: dict[tuple[int, Scene], Any] = {}
        n = len(rec.cut.starts(round(source.duration_s * 1e6)))
        # Windows (UAV, other) a recording of each kind adds: priors until one is seen.
        self.gain: dict[str, list[float]] = {
            "uav": [n / 2, n / 2, 0],
            "object": [0.0, float(n), 0],
            "empty": [0.0, float(n), 0],
        }

    def _start(self, i: int, scene: Scene) -> None:
        if (i, scene) not in self.pending:
            self.pending[(i, scene)] = self.rec.runner.submit(
                synthetic_windows, self.source, self.rec.cut, scene[0], self.seed_of(i), scene[1]
            )

    def scene(self, kind: str, objects: int) -> Scene:
        """The scene of a ``kind`` recording after ``objects`` object scenes."""
        return (kind, self.object_of(objects) if kind == "object" else None)

    def get(
        self, i: int, kind: str, objects: int, pos: int, neg: int, kinds: np.random.Generator
    ) -> tuple[dict[str, Any], Windows, WindowLabels, RawEvents]:
        runner = self.rec.runner
        want = (i, self.scene(kind, objects))
        self._start(*want)
        if runner.ahead:
            guess = copy.deepcopy(kinds)
            p, q = float(pos), float(neg)
            for j in range(i + 1, i + 1 + runner.ahead):
                g = self.gain[kind]
                p, q = p + g[0], q + g[1]
                objects += int(kind == "object")
                if p >= self.need[0] and q >= self.need[1]:
                    break
                kind_j = _next_kind(p, q, *self.need, guess)
                if len(self.pending) <= runner.ahead:
                    self._start(j, self.scene(kind_j, objects))
                kind = kind_j
        out = runner.result(self.pending.pop(want))
        stale = [key for key in self.pending if key[0] <= i]
        runner.cancel([self.pending.pop(key) for key in stale])
        entry, _, labels, _ = out
        g = self.gain[entry["kind"]]
        uav = int(labels.label.sum())
        count = g[2] + 1 if g[2] else 1
        g[0] = (g[0] * (count - 1) + uav) / count
        g[1] = (g[1] * (count - 1) + len(labels.label) - uav) / count
        g[2] = count
        return out

    def close(self) -> None:
        self.rec.runner.cancel(self.pending.values())
        self.pending.clear()


def synthetic_split(rec: Recorder, source: SceneSource, split: str, n: int) -> LabelledWindows:
    """Render recordings for ``split`` until its pools hold ``POOL_FACTOR`` times the ``n / 2``
    UAV and ``n / 2`` other windows it needs, then draw them.

    The next recording is a ``"uav"`` scene while UAV windows are the scarcer, else an
    ``"object"`` (70 %) or ``"empty"`` (30 %) scene. Recording ``i`` of a split is seeded by
    ``(seed, domain, split, i)`` alone. With ``rec.stratify``, the object scenes take their
    object's kind in turn by :func:`uavsnn.scenes.object_shares` (:func:`stratified_object`)
    instead of drawing it, so that a small split (a tuning set) holds every kind in its share.

    Raises:
        DatasetError: ``STALL`` recordings in a row added nothing that was needed.
    """
    need_pos = math.ceil(POOL_FACTOR * (n // 2))
    need_neg = math.ceil(POOL_FACTOR * (n - n // 2))
    dkey, skey = DOMAIN_KEY[source.domain], SPLIT_KEY[split]
    kinds = keyed_rng(rec.seed, dkey, skey, 0)
    pool = Pool()
    shares = object_shares(source.domain)
    ahead = _Ahead(
        rec,
        source,
        lambda i: keyed_seed(rec.seed, dkey, skey, 1, i),
        (need_pos, need_neg),
        (lambda j: stratified_object(shares, j)) if rec.stratify else (lambda j: None),
    )
    stall, i, objects = 0, 0, 0
    try:
        while pool.positives < need_pos or pool.negatives < need_neg:
            kind = _next_kind(pool.positives, pool.negatives, need_pos, need_neg, kinds)
            entry, windows, labels, raw = ahead.get(
                i, kind, objects, pool.positives, pool.negatives, kinds
            )
            objects += int(kind == "object")
            rec_id = rec.record(
                {
                    "name": f"{source.domain}-{split}-{i:05d}",
                    "domain": source.domain,
                    "split": split,
                    **entry,
                }
            )
            before = (pool.positives, pool.negatives)
            pool.add(rec_id, windows, labels, raw=raw)
            gained = (before[0] < pool.positives and before[0] < need_pos) or (
                before[1] < pool.negatives and before[1] < need_neg
            )
            stall = 0 if gained else stall + 1
            if stall >= STALL:
                raise DatasetError(
                    f"the {source.domain} {split} split stalled: {STALL} recordings in a row "
                    f"added no needed window ({pool.positives}/{need_pos} UAV, "
                    f"{pool.negatives}/{need_neg} non-UAV windows)"
                )
            i += 1
            rec.progress(
                f"{source.domain} {split}: {i} recording{'' if i == 1 else 's'}, "
                f"{pool.positives} UAV and "
                f"{pool.negatives} non-UAV windows"
            )
    finally:
        ahead.close()
    pick = balanced(
        pool.labels(), n, keyed_rng(rec.seed, dkey, skey, 2), f"{source.domain} {split} pool"
    )
    return rec.mark_used(pool.take(pick))
