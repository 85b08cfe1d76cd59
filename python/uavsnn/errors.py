"""The one exception hierarchy of uavsnn.

Every error raised by uavsnn, from Python or from the Rust engine, is an instance of
:class:`UavsnnError`. Errors about bad input values also subclass :class:`ValueError`, so code
that already catches ``ValueError`` keeps working.
"""

from __future__ import annotations

__all__ = [
    "DatasetError",
    "EventError",
    "InternalError",
    "ModelFileError",
    "ParameterError",
    "RecordingFileError",
    "ShapeError",
    "SimulationError",
    "StreamError",
    "UavsnnError",
]


class UavsnnError(Exception):
    """Base class of every uavsnn error."""


class EventError(UavsnnError, ValueError):
    """An event is malformed: wrong dtype, out of the sensor, or time going backwards."""


class ParameterError(UavsnnError, ValueError):
    """A parameter is outside its valid range (NaN, zero, negative, absurd)."""


class ShapeError(UavsnnError, ValueError):
    """Array shapes disagree with each other or with a configuration."""


class RecordingFileError(UavsnnError, OSError):
    """A recording file is missing, truncated, corrupt or of an unknown format."""


class ModelFileError(UavsnnError, ValueError):
    """A model file is corrupt, of another version, or inconsistent with its configuration."""


class StreamError(UavsnnError, ValueError):
    """A stream was fed out of order or in a state that does not allow the call."""


class SimulationError(UavsnnError, ValueError):
    """Simulation input (video, frames, scene parameters) is unusable."""


class DatasetError(UavsnnError, ValueError):
    """A dataset is malformed, empty, unbalanced, or does not fit the model."""


class InternalError(UavsnnError, RuntimeError):
    """An invariant of the engine does not hold: a bug, reported instead of a crash."""
