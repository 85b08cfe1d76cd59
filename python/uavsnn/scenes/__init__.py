"""Labelled scenes for training and testing: UAVs and other flying things, rendered.

``record(spec, *, sensor, seed)`` gives a scene's events as an event camera would (fast parts
rendered between frames too) with its labels;
``render(spec, *, seed) -> (frames, timestamps_us, labels)`` draws a :class:`SceneSpec` with
OpenCV and NumPy; ``sample_spec(domain, kind, rng)`` draws varied specs: Phantom- and
Tello-sized quadcopters with spinning rotors, birds with beating wings, aircraft, helicopters,
balls, insects and leaves, in front of sky with drifting clouds, a field with trees or a sports
hall, in light from bright to very dark; seen through a pinhole, or through a :class:`Lens`
that blurs what is near. See ``docs/dataset.md``.
"""

from __future__ import annotations

from uavsnn.scenes.camera import PIXEL_PITCH_UM, Lens
from uavsnn.scenes.preview import contact_sheet, sheet_frames, write_png
from uavsnn.scenes.record import Recorded, record, spec_from_dict, spec_to_dict
from uavsnn.scenes.renderer import LABEL_DTYPE, render, scene_labels
from uavsnn.scenes.sampler import SCENE_KINDS, default_format, object_shares, sample_spec
from uavsnn.scenes.spec import (
    BACKGROUNDS,
    CLASS_OF_KIND,
    DOMAINS,
    OBJECT_KINDS,
    UAV_CLASS,
    Background,
    Lighting,
    ObjectSpec,
    PathSpec,
    SceneSpec,
)

__all__ = [
    "BACKGROUNDS",
    "CLASS_OF_KIND",
    "DOMAINS",
    "LABEL_DTYPE",
    "OBJECT_KINDS",
    "PIXEL_PITCH_UM",
    "SCENE_KINDS",
    "UAV_CLASS",
    "Background",
    "Lens",
    "Lighting",
    "ObjectSpec",
    "PathSpec",
    "Recorded",
    "SceneSpec",
    "contact_sheet",
    "default_format",
    "object_shares",
    "record",
    "render",
    "sample_spec",
    "scene_labels",
    "sheet_frames",
    "spec_from_dict",
    "spec_to_dict",
    "write_png",
]
