"""One scene in, what the event camera gives out: :func:`record`.

The scene is rendered one frame at a time at its frame rate, the fast parts (rotors, wings) in
small patches between frames as well (:func:`uavsnn.scenes.renderer.frames`), and each frame
goes straight to the DVS emulator with its patches, so memory stays bounded by a frame and its
patches whatever the scene's length.
"""

from __future__ import annotations

import dataclasses
from typing import Any, NamedTuple

import numpy as np

from uavsnn.errors import ParameterError, SimulationError
from uavsnn.events import EVENT_DTYPE, Recording
from uavsnn.scenes.renderer import LABEL_DTYPE, SAMPLES_PER_PASS, frames
from uavsnn.scenes.spec import (
    MAX_OBJECTS,
    Background,
    Lighting,
    ObjectSpec,
    PathSpec,
    SceneSpec,
)
from uavsnn.sim.checks import check_seed, check_size
from uavsnn.sim.dvs import SCENE_PARAMS, DvsEmulator, DvsParams

__all__ = ["Recorded", "record", "spec_from_dict", "spec_to_dict"]


class Recorded(NamedTuple):
    """A recorded scene: the events, the frames' times and their labels."""

    recording: Recording
    timestamps_us: np.ndarray
    labels: np.ndarray


def record(
    spec: SceneSpec,
    *,
    sensor: Any = (240, 180),
    seed: int,
    params: DvsParams | None = None,
    samples_per_pass: int = SAMPLES_PER_PASS,
) -> Recorded:
    """Render ``spec`` (a "dvs" scene: linear gray frames at the sensor's size) and turn it
    into events as an event camera would.

    Args:
        spec: the scene; its size must be the sensor's.
        sensor: ``(width, height)`` (or ``"240x180"``).
        seed: one seed for everything random — textures, thresholds, noise.
        params: the sensor (default :data:`uavsnn.sim.SCENE_PARAMS`: the photoreceptor's
            bandwidth proportional to the light).
        samples_per_pass: sub-frame samples per blade passage or wing beat (0: whole frames
            only, so rotors alias at the frame rate).

    Returns:
        :class:`Recorded`: a :class:`~uavsnn.Recording` of the events (its metadata names the
        spec's objects and the seeds), the frames' ``timestamps_us`` and their labels
        (:data:`LABEL_DTYPE`).

    Raises:
        ParameterError: a sensor that is not the spec's size, a spec that is not gray32f, a
            bad seed or parameters.
        SimulationError: a bad spec.
    """
    width, height = check_size(sensor, "sensor")
    seed = check_seed(seed)
    if not isinstance(spec, SceneSpec):
        raise ParameterError(f"spec must be a SceneSpec, got {type(spec).__name__}")
    if (spec.width, spec.height) != (width, height):
        raise ParameterError(
            f"the scene is {spec.width}x{spec.height}, the sensor {width}x{height}: render "
            "the scene at the sensor's size (sample_spec(..., size=sensor))"
        )
    if spec.frame_format != "gray32f":
        raise ParameterError(
            f"record needs linear gray frames (a 'dvs' scene), got {spec.frame_format!r}"
        )
    render_seq, sensor_seq = np.random.SeedSequence(seed).spawn(2)
    render_seed = int(render_seq.generate_state(1)[0])
    sensor_seed = int(sensor_seq.generate_state(1)[0])
    params = params if params is not None else SCENE_PARAMS
    emulator = DvsEmulator((width, height), params=params, seed=sensor_seed)
    chunks: list[np.ndarray] = []
    times = np.empty(spec.n_frames, dtype=np.uint64)
    labels = np.zeros(spec.n_frames, dtype=LABEL_DTYPE)
    for f in frames(spec, seed=render_seed, samples_per_pass=samples_per_pass):
        times[f.k] = f.t_us
        labels[f.k] = f.label
        chunks.append(emulator.process_frame(f.image, f.t_us, f.patches))
    events = np.concatenate(chunks) if chunks else np.zeros(0, dtype=EVENT_DTYPE)
    meta = {
        "source": "uavsnn.scenes.record",
        "seed": seed,
        "samples_per_pass": int(samples_per_pass),
        "objects": [
            {"kind": o.kind, "size_m": o.size_m, "rate_hz": o.rate_hz} for o in spec.objects
        ],
        "fps": spec.fps,
        "lighting": spec.lighting.level,
    }
    return Recorded(Recording(events, (width, height), meta), times, labels)


def spec_to_dict(spec: SceneSpec) -> dict[str, Any]:
    """A scene as plain JSON-ready data (:func:`spec_from_dict` reads it back)."""
    return json_ready(dataclasses.asdict(spec))


def json_ready(value: Any) -> Any:
    """Tuples as lists, NumPy scalars as Python numbers, recursively."""
    if isinstance(value, dict):
        return {k: json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


#: A field of a scene nests lists this deep at most (a path's amplitudes: a list of lists).
_MAX_DEPTH = 2


def _tuples(value: Any, where: str, depth: int = 0) -> Any:
    """Lists as tuples, refusing lists nested deeper than any field's."""
    if isinstance(value, list):
        if depth >= _MAX_DEPTH:
            raise SimulationError(f"{where}: lists nested deeper than {_MAX_DEPTH} levels")
        return tuple(_tuples(v, where, depth + 1) for v in value)
    return value


def _build(cls: Any, data: Any, where: str) -> Any:
    if not isinstance(data, dict):
        raise SimulationError(f"{where} must be an object, got {type(data).__name__}")
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - names)
    if unknown:
        raise SimulationError(f"{where}: unknown field(s) {', '.join(unknown)}")
    missing = sorted(
        f.name
        for f in dataclasses.fields(cls)
        if f.name not in data
        and f.default is dataclasses.MISSING
        and f.default_factory is dataclasses.MISSING
    )
    if missing:
        raise SimulationError(f"{where}: missing field(s) {', '.join(missing)}")
    fields = {k: _tuples(v, k if where == "scene" else f"{where}.{k}") for k, v in data.items()}
    try:
        return cls(**fields)
    except TypeError as exc:
        raise SimulationError(f"{where}: {exc}") from exc


def spec_from_dict(data: Any) -> SceneSpec:
    """A :class:`SceneSpec` from the JSON form :func:`spec_to_dict` writes: the spec's fields,
    ``background`` and ``lighting`` as objects of their fields, ``objects`` a list of objects
    whose ``path`` is an object of :class:`PathSpec`'s fields. Missing fields take their
    defaults. Raises :class:`~uavsnn.SimulationError` naming what is wrong."""
    if not isinstance(data, dict):
        raise SimulationError(f"a scene must be a JSON object, got {type(data).__name__}")
    fields = dict(data)
    if "background" in fields:
        fields["background"] = _build(Background, fields["background"], "background")
    if "lighting" in fields:
        fields["lighting"] = _build(Lighting, fields["lighting"], "lighting")
    objects = fields.get("objects", [])
    if not isinstance(objects, list):
        raise SimulationError("objects must be a list")
    if len(objects) > MAX_OBJECTS:  # refused before any is built
        raise SimulationError(
            f"a scene has at most {MAX_OBJECTS} objects (MAX_OBJECTS), got {len(objects)}"
        )
    built = []
    for i, o in enumerate(objects):
        if not isinstance(o, dict) or "path" not in o:
            raise SimulationError(f"objects[{i}] must be an object with a path")
        o = dict(o)
        o["path"] = _build(PathSpec, o["path"], f"objects[{i}].path")
        built.append(_build(ObjectSpec, o, f"objects[{i}]"))
    fields["objects"] = tuple(built)
    spec: SceneSpec = _build(SceneSpec, fields, "scene")
    return spec
