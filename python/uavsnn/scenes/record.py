"""One scene in, what the event camera gives out: :func:`record`.

The scene is rendered one frame at a time at its frame rate, the fast parts (rotors, wings) in
small patches between frames as well (:func:`uavsnn.scenes.renderer.frames`), and each frame
goes straight to the DVS emulator with its patches, so memory stays bounded by a frame and its
patches whatever the scene's length.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from uavsnn.errors import ParameterError
from uavsnn.events import EVENT_DTYPE, Recording
from uavsnn.scenes.renderer import LABEL_DTYPE, SAMPLES_PER_PASS, frames
from uavsnn.scenes.spec import SceneSpec
from uavsnn.sim.checks import check_seed, check_size
from uavsnn.sim.dvs import SCENE_PARAMS, DvsEmulator, DvsParams

__all__ = ["Recorded", "record"]


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
