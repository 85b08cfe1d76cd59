"""Checking and normalising the frames and timestamps given to the simulators.

Frames may be an array ``(n, h, w)`` of gray or ``(n, h, w, 3)`` of BGR (OpenCV's channel
order), or a sequence of such frames. ``uint8`` passes to the engine untouched (no copy, strided
views included); every other real dtype becomes ``float32`` on the same 0–255 scale, BGR being
turned into BT.601 luma first (integer frames with a value above 255, a 16-bit sensor's, are
refused rather than taken as brighter). Float frames are intensities on that scale, 255 being a
video's white, and may go past it: light brighter than white, as the "dvs" renderer's flickering
light makes, is taken as it is, not clipped. So float frames on another scale are taken on this
one (0–1 as nearly black, 0–1000 as up to four times white): scale them first. NaN, infinite or
negative values (a negative channel of a BGR pixel too) are refused.
Timestamps are integer microseconds, one per frame, strictly increasing, at most 2^62 µs (the
engine's latest time).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from uavsnn._validate import MAX_TIME_US
from uavsnn.errors import SimulationError
from uavsnn.events import EVENT_DTYPE

__all__ = ["FrameBatch", "as_frame_batch", "as_timestamps", "push_frames"]

#: BT.601 luma weights in OpenCV's B, G, R order.
BT601_BGR = np.array([0.114, 0.587, 0.299], dtype=np.float32)


@dataclass(frozen=True)
class FrameBatch:
    """Frames ready for a kernel: ``kind`` says which ``push_*`` method takes ``array``."""

    kind: Literal["gray", "bgr", "float"]
    array: np.ndarray

    @property
    def size(self) -> tuple[int, int]:
        """``(width, height)`` of the frames."""
        return int(self.array.shape[2]), int(self.array.shape[1])

    def __len__(self) -> int:
        return int(self.array.shape[0])


def _stack(frames: Sequence[Any]) -> np.ndarray:
    arrays = [np.asarray(f) for f in frames]
    if not arrays:
        raise SimulationError("no frames given")
    first = arrays[0].shape
    for i, a in enumerate(arrays):
        if a.shape != first:
            raise SimulationError(
                f"frame {i} has shape {a.shape}, expected {first} like frame 0; "
                "frames of mixed sizes cannot make one recording (resize them first)"
            )
    return np.stack(arrays)


def as_frame_batch(frames: Any) -> FrameBatch:
    """Check ``frames`` and return them as a :class:`FrameBatch`.

    Raises :class:`~uavsnn.SimulationError` for no frames, frames of mixed sizes, a shape that
    is neither ``(n, h, w)`` nor ``(n, h, w, 3)``, a non-numeric dtype, integer intensities above
    255, or non-finite or negative intensities (of a BGR pixel's luma or of any of its channels).
    """
    if isinstance(frames, np.ndarray):
        array = frames
    elif isinstance(frames, Sequence) and not isinstance(frames, (str, bytes)):
        array = _stack(frames)
    else:
        raise SimulationError(
            f"frames must be a NumPy array or a sequence of frames, got {type(frames).__name__}"
        )
    if array.ndim == 4 and array.shape[3] == 1:
        array = array[..., 0]
    if not (array.ndim == 3 or (array.ndim == 4 and array.shape[3] == 3)):
        raise SimulationError(
            f"frames must have shape (n, h, w) or (n, h, w, 3), got {array.shape}"
        )
    n, h, w = array.shape[:3]
    if n == 0:
        raise SimulationError("no frames given")
    if h == 0 or w == 0:
        raise SimulationError(f"frames are empty ({w}x{h} pixels)")
    if array.dtype == np.uint8:
        return FrameBatch("bgr" if array.ndim == 4 else "gray", array)
    if array.dtype == np.bool_ or not np.issubdtype(array.dtype, np.number):
        raise SimulationError(f"frames must be numeric intensities, got dtype {array.dtype}")
    if np.issubdtype(array.dtype, np.complexfloating):
        raise SimulationError(f"frames must be real intensities, got dtype {array.dtype}")
    if array.dtype != np.uint8 and np.issubdtype(array.dtype, np.integer) and array.size:
        # Integer frames are taken on the 0-255 scale as they are: a 16-bit sensor's values
        # above it would be taken as that much brighter, so they are refused, not guessed at.
        top = int(array.max())
        if top > 255:
            raise SimulationError(
                f"frames of dtype {array.dtype} must be on the 0-255 scale, got a value of "
                f"{top}: scale 16-bit frames to it first (frames / 257.0)"
            )
    gray = array.astype(np.float32) @ BT601_BGR if array.ndim == 4 else array
    gray = np.ascontiguousarray(gray, dtype=np.float32)
    bad = ~np.isfinite(gray) | (gray < 0)
    if array.ndim == 4:
        bad |= (array < 0).any(axis=3)  # a negative channel under a luma >= 0
    if bad.any():
        k, y, x = (int(v) for v in np.argwhere(bad)[0])
        value = gray[k, y, x] if array.ndim == 3 else f"(B, G, R) {tuple(array[k, y, x].tolist())}"
        raise SimulationError(
            f"frame {k}: pixel (x={x}, y={y}) has intensity {value}, expected a finite value >= 0"
        )
    return FrameBatch("float", gray)


def as_timestamps(timestamps_us: Any, n: int) -> np.ndarray:
    """Check timestamps (µs, one per frame, strictly increasing, in ``[0, 2^62]``) and return
    them as ``uint64``. Raises :class:`~uavsnn.SimulationError` naming the first bad one."""
    t = np.asarray(timestamps_us)
    if t.ndim != 1 or t.shape[0] != n:
        raise SimulationError(f"expected {n} timestamps (one per frame), got shape {t.shape}")
    if n == 0:
        return t.astype(np.uint64)
    if t.dtype == np.bool_ or not np.issubdtype(t.dtype, np.number):
        raise SimulationError(f"timestamps must be integer microseconds, got dtype {t.dtype}")
    t = whole_microseconds(t, lambda i: f"timestamp {i} ({t[i]})")
    if n > 1:
        # Compared as unsigned: a difference through int64 wraps across 2^63.
        back = t[1:] <= t[:-1]
        if back.any():
            i = int(np.argmax(back)) + 1
            raise SimulationError(
                f"timestamp {i} ({t[i]} us) is not after timestamp {i - 1} ({t[i - 1]} us); "
                "frame times must increase strictly"
            )
    return t


def whole_microseconds(t: np.ndarray, label: Callable[[int], str]) -> np.ndarray:
    """A 1-D array of real numbers ``t`` as ``uint64``, if each is a whole number of
    microseconds in ``[0, 2^62]`` (the engine's latest time, ``MAX_TIME_US``); else
    :class:`~uavsnn.SimulationError` naming the first bad one by ``label(i)``."""
    floating = np.issubdtype(t.dtype, np.floating)
    if floating:
        bad = ~np.isfinite(t) | (t != np.round(t))
        if bad.any():
            i = int(np.argmax(bad))
            raise SimulationError(f"{label(i)} is not a whole number of microseconds")
    # Both compared before the cast, which would wrap them.
    for bad, what in (
        (t < 0, "is negative"),
        (t >= 2.0**64 if floating else np.zeros(t.shape, bool), "is beyond 2^64 - 1 microseconds"),
    ):
        if bad.any():
            raise SimulationError(f"{label(int(np.argmax(bad)))} {what}")
    out = t.astype(np.uint64)
    late = out > np.uint64(MAX_TIME_US)
    if late.any():
        raise SimulationError(
            f"{label(int(np.argmax(late)))} is beyond the latest time the engine takes "
            f"(2^62 = {MAX_TIME_US} microseconds)"
        )
    return out


def push_frames(
    kernel: Any, frames: Any, timestamps_us: Any, size: tuple[int, int], takes: str
) -> np.ndarray:
    """The ``process`` of the simulators: check ``frames`` and ``timestamps_us`` (see above)
    against the frame ``size`` ``(width, height)`` that ``kernel`` takes, feed them to its
    ``push_gray``, ``push_bgr`` or ``push_float``, and return the events they made, sorted by
    time. ``takes`` words the wrong-size error (``"this sensor is"``)."""
    batch = frames if isinstance(frames, FrameBatch) else as_frame_batch(frames)
    times = as_timestamps(timestamps_us, len(batch))
    if batch.size != size:
        raise SimulationError(
            f"frames are {batch.size[0]}x{batch.size[1]}, {takes} {size[0]}x{size[1]}"
        )
    push = getattr(kernel, f"push_{batch.kind}")
    return np.asarray(push(batch.array, times)).view(EVENT_DTYPE)
