"""Labelled datasets of windows: building, the file format, real labelled footage.

- :func:`build` makes ``train``/``test`` splits for the "dvs", "sim", "real" and "combined"
  domains, split by recording, with balanced test sets and a manifest; :func:`build_demo` the
  small set that ``uavsnn demo`` uses.
- :func:`load` reads a split back as :class:`LabelledWindows`.
- :func:`find_clips`, :func:`read_boxes`, :func:`clip_labels` read folders of labelled videos
  laid out like the Svanström drone-detection dataset.

The format and every labelling rule are in ``docs/dataset.md``.
"""

from __future__ import annotations

from uavsnn.dataset.build import (
    DATASET_DOMAINS,
    SENSOR_SIZES,
    TEST_FRACTION,
    DatasetPaths,
    build,
    build_demo,
    parse_sensor,
)
from uavsnn.dataset.format import (
    FORMAT_VERSION,
    LabelledWindows,
    RawEvents,
    load,
    read_manifest,
    save_split,
)
from uavsnn.dataset.labels import WindowLabels, label_windows
from uavsnn.dataset.real import Clip, boxes_to_sensor, clip_labels, find_clips, read_boxes
from uavsnn.dataset.synthetic import (
    LabelledRecording,
    SceneSource,
    default_source,
    scene_spec,
    synthetic_recording,
    synthetic_split,
)
from uavsnn.errors import DatasetError

__all__ = [
    "DATASET_DOMAINS",
    "FORMAT_VERSION",
    "SENSOR_SIZES",
    "TEST_FRACTION",
    "Clip",
    "DatasetError",
    "DatasetPaths",
    "LabelledRecording",
    "LabelledWindows",
    "RawEvents",
    "SceneSource",
    "WindowLabels",
    "boxes_to_sensor",
    "build",
    "build_demo",
    "clip_labels",
    "default_source",
    "find_clips",
    "label_windows",
    "load",
    "parse_sensor",
    "read_boxes",
    "read_manifest",
    "save_split",
    "scene_spec",
    "synthetic_recording",
    "synthetic_split",
]
