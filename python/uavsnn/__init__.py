"""uavsnn: drone detection on event-camera streams with an STDP-trained spiking network.

An implementation, and extension, of Kirkland et al., "UAV Detection: A STDP trained Deep
Convolutional Spiking Neural Network Retina-Neuromorphic Approach" (ICANN 2019).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from uavsnn._core import __version__
from uavsnn.detector import Detector
from uavsnn.errors import (
    DatasetError,
    EventError,
    InternalError,
    ModelFileError,
    ParameterError,
    RecordingFileError,
    ShapeError,
    SimulationError,
    StreamError,
    UavsnnError,
)
from uavsnn.events import EVENT_DTYPE, Recording
from uavsnn.network import Network
from uavsnn.signature import RotorEstimate, RotorSignature, rotor_signature
from uavsnn.tracks import Track, Tracker, track_windows

__all__ = [
    "EVENT_DTYPE",
    "DatasetError",
    "Detector",
    "EventError",
    "InternalError",
    "ModelFileError",
    "Network",
    "ParameterError",
    "Recording",
    "RecordingFileError",
    "RotorEstimate",
    "RotorSignature",
    "ShapeError",
    "SimulationError",
    "StreamError",
    "Track",
    "Tracker",
    "UavsnnError",
    "__version__",
    "rotor_signature",
    "track_windows",
]

#: The package's public submodules, reachable as attributes after ``import uavsnn`` as the docs
#: write them (``uavsnn.io.read(...)``, ``uavsnn.sim.pix2nvs(...)``): each is imported on first
#: use, so ``import uavsnn`` stays as light as the names above need.
SUBMODULES = frozenset(
    {
        "bench", "boxes", "cli", "clips", "dataset", "detector", "distributed", "driver", "errors",
        "evaluation", "events", "experiments", "false_alarms", "features", "filters", "grouping",
        "identifier", "identify", "io", "linear", "network", "outputs", "pictures", "progress",
        "provenance", "report", "report_pictures", "roc", "scenes", "signature", "sim", "sources",
        "track_eval", "tracks", "training", "trees", "windows",
    }
)  # fmt: skip

if TYPE_CHECKING:  # the submodules as attributes, to a type checker as at run time
    from uavsnn import bench as bench
    from uavsnn import boxes as boxes
    from uavsnn import cli as cli
    from uavsnn import clips as clips
    from uavsnn import dataset as dataset
    from uavsnn import detector as detector
    from uavsnn import distributed as distributed
    from uavsnn import driver as driver
    from uavsnn import errors as errors
    from uavsnn import evaluation as evaluation
    from uavsnn import events as events
    from uavsnn import experiments as experiments
    from uavsnn import false_alarms as false_alarms
    from uavsnn import features as features
    from uavsnn import filters as filters
    from uavsnn import grouping as grouping
    from uavsnn import identifier as identifier
    from uavsnn import identify as identify
    from uavsnn import io as io
    from uavsnn import linear as linear
    from uavsnn import network as network
    from uavsnn import outputs as outputs
    from uavsnn import pictures as pictures
    from uavsnn import progress as progress
    from uavsnn import provenance as provenance
    from uavsnn import report as report
    from uavsnn import report_pictures as report_pictures
    from uavsnn import roc as roc
    from uavsnn import scenes as scenes
    from uavsnn import signature as signature
    from uavsnn import sim as sim
    from uavsnn import sources as sources
    from uavsnn import track_eval as track_eval
    from uavsnn import tracks as tracks
    from uavsnn import training as training
    from uavsnn import trees as trees
    from uavsnn import windows as windows
else:  # each imported on first use

    def __getattr__(name: str) -> object:
        if name in SUBMODULES:
            return importlib.import_module(f"{__name__}.{name}")
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted({*globals(), *SUBMODULES})
