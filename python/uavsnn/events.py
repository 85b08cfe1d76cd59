"""Events and recordings (SPEC §1).

The canonical event layout is the one faery and aedat use::

    EVENT_DTYPE = [("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("p", "?")]

``t`` is in microseconds, ``x``/``y`` are pixel coordinates with the origin at the top left and
``p`` is the polarity (``True`` = ON). A :class:`Recording` is events sorted by time plus the
sensor size; it is validated when built, and a bad event is reported by index and reason.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from uavsnn import _core
from uavsnn.errors import EventError, ParameterError

__all__ = ["EVENT_DTYPE", "Recording", "packed_bytes"]

EVENT_DTYPE = np.dtype([("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("p", "?")])


def packed_bytes(events: np.ndarray) -> np.ndarray:
    """View canonical events as the contiguous ``uint8`` buffer the engine reads (no copy when
    the array is already contiguous)."""
    if not isinstance(events, np.ndarray) or events.dtype != EVENT_DTYPE:
        got = getattr(events, "dtype", type(events).__name__)
        raise EventError(f"events must have dtype {EVENT_DTYPE.descr}, got {got}")
    if events.ndim != 1:
        raise EventError(f"events must be a 1-D array, got shape {events.shape}")
    return np.ascontiguousarray(events).view(np.uint8)


def _check_sensor_size(sensor_size: Any) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in sensor_size)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"sensor_size must be (width, height), got {sensor_size!r}") from exc
    if not (0 < width <= 65535 and 0 < height <= 65535):
        raise ParameterError(f"sensor_size must be positive and < 65536, got {width}x{height}")
    return width, height


@dataclass(frozen=True)
class Recording:
    """Events sorted by time, the sensor size ``(width, height)``, and free-form metadata.

    Building one validates every event: a wrong dtype, an event outside the sensor or a time
    going backwards raises :class:`~uavsnn.EventError` naming the event.
    """

    events: np.ndarray
    sensor_size: tuple[int, int]
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        size = _check_sensor_size(self.sensor_size)
        object.__setattr__(self, "sensor_size", size)
        buf = packed_bytes(self.events)
        _core.validate_events(buf, size[0], size[1])

    @property
    def width(self) -> int:
        """Sensor width in pixels."""
        return self.sensor_size[0]

    @property
    def height(self) -> int:
        """Sensor height in pixels."""
        return self.sensor_size[1]

    def __len__(self) -> int:
        return len(self.events)

    @property
    def duration_us(self) -> int:
        """Time from the first to the last event, in microseconds (0 when empty)."""
        if len(self.events) == 0:
            return 0
        return int(self.events["t"][-1]) - int(self.events["t"][0])
