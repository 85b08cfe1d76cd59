"""Boxes of sensor pixels, the events inside one, and the boxes of detections.

A box here is half-open ``(x0, y0, x1, y1)``: the pixels with ``x0 <= x < x1`` and
``y0 <= y < y1``, as the network's causal boxes and the objects merged from them
(:func:`uavsnn.grouping.merge_boxes`) give it. The rotor estimators of :mod:`uavsnn.signature`
take a box as ``(x0, y0, width, height)`` instead (:func:`xywh`). Arrays of boxes, one row a
box, are compared row by row (:func:`box_iou`, :func:`centre_distance`); a detection's box is
where the input spikes that caused it lie (docs/model.md §5), which :mod:`uavsnn.evaluation`
sets against the labelled box (:func:`first_detection_boxes`, :func:`first_detection_on_box`).

    >>> inside = in_box(events, (10, 20, 34, 36))      # the events of that 24x16 box
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from uavsnn._validate import check_int, check_numbers, whole
from uavsnn.errors import EventError, ParameterError, ShapeError

if TYPE_CHECKING:
    from uavsnn.network import Inference

__all__ = [
    "box_iou",
    "box_mask",
    "centre_distance",
    "first_detection_boxes",
    "first_detection_on_box",
    "first_spike_in_box",
    "in_box",
    "xywh",
]


def corners(box: Any) -> tuple[int, int, int, int]:
    """``box`` as four ints ``(x0, y0, x1, y1)``: whole numbers (``5.0`` is 5; a fraction is
    refused, not truncated).

    Raises:
        ParameterError: ``box`` is not four whole numbers.
    """
    try:
        sides = () if isinstance(box, (str, bytes)) else tuple(box)
    except TypeError:
        sides = ()
    values = [v for v in map(whole, sides) if v is not None]
    if len(sides) != 4 or len(values) != 4:
        raise ParameterError(f"box must be (x0, y0, x1, y1), four whole numbers, got {box!r}")
    x0, y0, x1, y1 = values
    return x0, y0, x1, y1


def xywh(box: tuple[int, int, int, int]) -> tuple[int, int, int, int]:
    """``(x0, y0, x1, y1)`` as ``(x0, y0, width, height)``.

    Raises:
        ParameterError: ``box`` is not four whole numbers.
    """
    x0, y0, x1, y1 = corners(box)
    return x0, y0, x1 - x0, y1 - y0


def box_mask(events: np.ndarray, box: tuple[int, int, int, int]) -> np.ndarray:
    """Which of ``events`` (a structured array with ``x`` and ``y`` fields, e.g. of
    :data:`uavsnn.EVENT_DTYPE`) lie in ``box`` ``(x0, y0, x1, y1)``: a boolean array of their
    length. An empty box (``x1 <= x0`` or ``y1 <= y0``) holds none.

    Raises:
        EventError: ``events`` has no ``x`` and ``y`` fields.
        ParameterError: ``box`` is not four whole numbers.
    """
    x0, y0, x1, y1 = corners(box)
    names = getattr(getattr(events, "dtype", None), "names", None) or ()
    if "x" not in names or "y" not in names:
        got = getattr(events, "dtype", type(events).__name__)
        raise EventError(f"events must have x and y fields, got {got!r}")
    x, y = events["x"], events["y"]
    return (x >= x0) & (x < x1) & (y >= y0) & (y < y1)


def in_box(events: np.ndarray, box: tuple[int, int, int, int]) -> np.ndarray:
    """The events in ``box`` ``(x0, y0, x1, y1)``, in their order (a copy): ``events`` where
    :func:`box_mask` holds.

    Raises:
        EventError, ParameterError: as :func:`box_mask`.
    """
    return events[box_mask(events, box)]


def first_detection_boxes(inference: Inference, windows: int) -> np.ndarray:
    """Per window of the ``windows`` (a count) ``inference`` ran, the box ``x0, y0, x1, y1``
    (float64) of its first detection (the earliest, then the first reported), NaN where it has
    none.

    Raises:
        ParameterError: ``windows`` not a count.
    """
    windows = check_int("windows", windows, 0)
    out = np.full((windows, 4), np.nan)
    found = inference.detections
    if len(found):
        # Detections come by window, then time: a window's first row is its first detection.
        which, first = np.unique(found["window"], return_index=True)
        rows = found[first]
        out[which] = np.stack([rows[k] for k in ("x0", "y0", "x1", "y1")], axis=1)
    return out


def first_detection_on_box(
    inference: Inference, boxes: npt.ArrayLike, first_in_box: npt.ArrayLike
) -> np.ndarray:
    """Per window ``inference`` ran, the time (int64 µs) of its first detection that the object
    in its labelled box ``x0, y0, x1, y1`` can have caused: one at or after the window's first
    input spike in the box (``first_in_box``, :func:`first_spike_in_box`) whose box (the input
    spikes that caused it, docs/model.md §5) overlaps the labelled box by some area. −1 where
    none is, or where no input spike is in the box (``first_in_box`` −1).

    Raises:
        ShapeError: ``boxes`` not ``(n, 4)`` or ``first_in_box`` not ``(n,)``, for ``n``
            windows.
    """
    n = len(inference)
    box = check_numbers("boxes", boxes)
    start = np.asarray(first_in_box, dtype=np.int64)
    if box.shape != (n, 4) or start.shape != (n,):
        raise ShapeError(
            f"boxes must have shape ({n}, 4) and first_in_box ({n},), got {box.shape} and "
            f"{start.shape}"
        )
    out = np.full(n, -1, dtype=np.int64)
    found = inference.detections
    which = np.asarray(found["window"], dtype=np.int64)
    t = np.asarray(found["t"], dtype=np.int64)
    after = (start[which] >= 0) & (t >= start[which])
    which, t, rows = which[after], t[after], found[after]
    if not len(rows):
        return out
    own = np.stack([rows[k] for k in ("x0", "y0", "x1", "y1")], axis=1).astype(np.float64)
    overlaps = box_iou(own, box[which]) > 0  # by some area (a window without a box: none)
    big = np.iinfo(np.int64).max
    first = np.full(n, big, dtype=np.int64)
    np.minimum.at(first, which[overlaps], t[overlaps])
    out[first != big] = first[first != big]
    return out


def _box_pairs(a: npt.ArrayLike, b: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Two ``(n, 4)`` float64 arrays of boxes to compare row by row, or a ShapeError (a
    ParameterError for boxes that are not numbers)."""
    a, b = check_numbers("boxes", a), check_numbers("boxes", b)
    if a.shape != b.shape or a.ndim != 2 or a.shape[1] != 4:
        raise ShapeError(f"boxes must be (n, 4) alike, got {a.shape} and {b.shape}")
    return a, b


def box_iou(a: npt.ArrayLike, b: npt.ArrayLike) -> np.ndarray:
    """Intersection over union of boxes ``x0, y0, x1, y1`` (half-open), row by row."""
    a, b = _box_pairs(a, b)
    iw = np.clip(np.minimum(a[:, 2], b[:, 2]) - np.maximum(a[:, 0], b[:, 0]), 0, None)
    ih = np.clip(np.minimum(a[:, 3], b[:, 3]) - np.maximum(a[:, 1], b[:, 1]), 0, None)
    inter = iw * ih
    area = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1]) + (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(area - inter > 0, inter / (area - inter), 0.0)


def centre_distance(a: npt.ArrayLike, b: npt.ArrayLike) -> np.ndarray:
    """Distance (pixels) between the centres of boxes ``x0, y0, x1, y1``, row by row."""
    a, b = _box_pairs(a, b)
    dx = (a[:, 0] + a[:, 2] - b[:, 0] - b[:, 2]) / 2
    dy = (a[:, 1] + a[:, 3] - b[:, 1] - b[:, 3]) / 2
    return np.hypot(dx, dy)


def first_spike_in_box(windows: Any, boxes: npt.ArrayLike) -> np.ndarray:
    """Per window, the time (int64 µs) of its first input spike inside its box
    ``x0, y0, x1, y1`` (pixel ``(x, y)`` counts when its centre ``x + ½, y + ½`` is inside), or
    −1 when none is (or the box is NaN)."""
    box = np.asarray(boxes, dtype=np.float64)
    n = len(windows.t0)
    if box.shape != (n, 4):
        raise ShapeError(f"boxes must have shape ({n}, 4), got {box.shape}")
    offsets = np.asarray(windows.offsets, dtype=np.int64)
    counts = np.diff(offsets)
    per_spike = np.repeat(box, counts, axis=0)
    cx = np.asarray(windows.x, dtype=np.float64) + 0.5
    cy = np.asarray(windows.y, dtype=np.float64) + 0.5
    with np.errstate(invalid="ignore"):
        inside = (
            (cx >= per_spike[:, 0])
            & (cx < per_spike[:, 2])
            & (cy >= per_spike[:, 1])
            & (cy < per_spike[:, 3])
        )
    t = np.asarray(windows.t, dtype=np.int64)
    big = np.iinfo(np.int64).max
    masked = np.where(inside, t, big)
    out = np.full(n, -1, dtype=np.int64)
    nonempty = np.flatnonzero(counts > 0)
    if nonempty.size:
        firsts = np.minimum.reduceat(masked, offsets[nonempty])
        out[nonempty] = np.where(firsts == big, -1, firsts)
    return out
