"""Boxes of sensor pixels, and the events inside one.

A box here is half-open ``(x0, y0, x1, y1)``: the pixels with ``x0 <= x < x1`` and
``y0 <= y < y1``, as the network's causal boxes and the objects merged from them
(:func:`uavsnn.grouping.merge_boxes`) give it. The rotor estimators of :mod:`uavsnn.signature`
take a box as ``(x0, y0, width, height)`` instead (:func:`xywh`).

    >>> inside = in_box(events, (10, 20, 34, 36))      # the events of that 24x16 box
"""

from __future__ import annotations

from typing import Any

import numpy as np

from uavsnn._validate import whole
from uavsnn.errors import EventError, ParameterError

__all__ = ["box_mask", "in_box", "xywh"]


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
