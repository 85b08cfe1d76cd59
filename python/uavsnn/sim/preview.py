"""Pictures of events for a person to look at: a strip of event frames, written as a PNG.

Each panel accumulates the events of one time slice: ON events red, OFF events blue, both
(within the slice) magenta, silent pixels dark grey. Panels are spread evenly over the
recording and labelled with their start time.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from uavsnn._files import write_image
from uavsnn._validate import check_sensor_size
from uavsnn.errors import EventError, SimulationError
from uavsnn.events import Recording, SensorSizeLike, packed_bytes
from uavsnn.sim.checks import check_int

__all__ = ["event_frame", "event_strip", "write_preview"]

BACKGROUND = (32, 32, 32)
"""The colour (BGR) of silent pixels, shared with the pictures of uavsnn.pictures."""
_ON = (40, 40, 255)
_OFF = (255, 150, 40)
_BOTH = (255, 60, 255)


def event_frame(events: np.ndarray, sensor_size: SensorSizeLike) -> np.ndarray:
    """A BGR ``uint8`` image ``(h, w, 3)`` of ``events`` (ON red, OFF blue, both magenta).

    Raises:
        ParameterError: a bad ``sensor_size`` (``(width, height)``, or tonic's ``(width,
            height, channels)``).
        EventError: ``events`` not a 1-D array of :data:`~uavsnn.events.EVENT_DTYPE`, or an
            event off the sensor, naming the first.
    """
    w, h = check_sensor_size(sensor_size)
    packed_bytes(events)  # the dtype and shape
    off = (events["x"] >= w) | (events["y"] >= h)
    if off.any():
        i = int(np.argmax(off))
        raise EventError(
            f"event {i}: (x={events['x'][i]}, y={events['y'][i]}) is outside the {w}x{h} sensor"
        )
    on = np.zeros((h, w), dtype=bool)
    off = np.zeros((h, w), dtype=bool)
    polarity = events["p"]
    on[events["y"][polarity], events["x"][polarity]] = True
    off[events["y"][~polarity], events["x"][~polarity]] = True
    img = np.empty((h, w, 3), dtype=np.uint8)
    img[:] = BACKGROUND
    img[on & ~off] = _ON
    img[off & ~on] = _OFF
    img[on & off] = _BOTH
    return img


def event_strip(
    recording: Recording,
    *,
    panels: int = 6,
    slice_us: int = 33_333,
    scale: int = 2,
) -> np.ndarray:
    """A BGR image of ``panels`` event frames side by side, each ``slice_us`` long, spread
    evenly over the recording, scaled up ``scale`` times (nearest neighbour)."""
    panels = check_int("panels", panels, low=1, high=64)
    slice_us = check_int("slice_us", slice_us, low=1, high=2**62)
    scale = check_int("scale", scale, low=1, high=16)
    ev = recording.events
    t = ev["t"]
    t0 = int(t[0]) if len(ev) else 0
    t1 = int(t[-1]) if len(ev) else 0
    starts = np.linspace(t0, max(t0, t1 - slice_us), panels).astype(np.int64)
    images = []
    for start in starts:
        lo, hi = np.searchsorted(t, [start, start + slice_us])
        img = event_frame(ev[lo:hi], recording.sensor_size)
        img = cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
        label = f"{(start - t0) / 1e3:.0f} ms  {hi - lo} ev"
        cv2.putText(
            img, label, (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (220, 220, 220), 1, cv2.LINE_AA
        )
        images.append(img)
        images.append(np.full((img.shape[0], 2, 3), 255, dtype=np.uint8))
    return np.hstack(images[:-1])


def write_preview(
    recording: Recording,
    path: str | Path,
    *,
    panels: int = 6,
    slice_us: int = 33_333,
    scale: int = 2,
) -> Path:
    """Write :func:`event_strip` to ``path`` (PNG); returns the path."""
    p = Path(path)
    if p.suffix.lower() != ".png":
        raise SimulationError(f"preview must be a .png file, got {str(p)!r}")
    img = event_strip(recording, panels=panels, slice_us=slice_us, scale=scale)
    if not p.parent.is_dir() or not write_image(p, img):
        raise SimulationError(f"could not write the preview to {str(p)!r}")
    return p
