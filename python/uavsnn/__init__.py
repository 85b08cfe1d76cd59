"""uavsnn: drone detection on event-camera streams with an STDP-trained spiking network.

An implementation, and extension, of Kirkland et al., "UAV Detection: A STDP trained Deep
Convolutional Spiking Neural Network Retina-Neuromorphic Approach" (ICANN 2019).
"""

from __future__ import annotations

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
