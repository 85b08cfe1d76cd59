"""Events and recordings (SPEC §1).

The canonical event layout is the one faery and aedat use::

    EVENT_DTYPE = [("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("p", "?")]

``t`` is in microseconds, ``x``/``y`` are pixel coordinates with the origin at the top left and
``p`` is the polarity (``True`` = ON). A :class:`Recording` is events sorted by time plus the
sensor size; it is validated when built, and a bad event is reported by index and reason.
faery's own functions check the field's title too (``on``): hand them
``events.view(faery.EVENTS_DTYPE)``, the same bytes.

:func:`convert` turns the layouts users hold into the canonical one, explicitly:

========== ======================================= ==========================================
layout     fields (or columns of a plain 2-D array) source
========== ======================================= ==========================================
canonical  ``t, x, y, p``                          faery, aedat (``p`` titled ``on`` in faery)
aedat      ``t, x, y, on``                         the ``aedat`` package
tonic      ``x, y, t, p``                          tonic
aestream   ``timestamp, x, y, polarity``           aestream
openeb     ``x, y, p, t``                          OpenEB / Metavision ``EventCD``
========== ======================================= ==========================================

Polarity may be boolean, ``0``/``1`` or ``-1``/``+1`` (a stream holding any ``-1`` is read as
``±1``, otherwise as ``0``/``1``); ``1`` is ON. Any other value is an error naming the event.
Timestamps must be integer microseconds: floating-point times are refused rather than guessed at.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from uavsnn import _core
from uavsnn._validate import MAX_TIME_US, check_sensor_size
from uavsnn.errors import EventError, ParameterError

__all__ = ["EVENT_DTYPE", "LAYOUTS", "Recording", "SensorSizeLike", "convert", "packed_bytes"]

#: What a ``sensor_size`` parameter takes: ``(width, height)``, or tonic's ``(width, height,
#: channels)`` with 1 or 2 channels (its first two are kept). A sensor size the package gives
#: back is always ``(width, height)``.
SensorSizeLike = tuple[int, int] | tuple[int, int, int]

EVENT_DTYPE = np.dtype([("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("p", "?")])

#: The known layouts: their field names in column order (the order a plain ``(N, 4)`` array of
#: that layout must follow). Structured arrays are matched by field name, in any order.
LAYOUTS: dict[str, tuple[str, str, str, str]] = {
    "canonical": ("t", "x", "y", "p"),
    "aedat": ("t", "x", "y", "on"),
    "tonic": ("x", "y", "t", "p"),
    "aestream": ("timestamp", "x", "y", "polarity"),
    "openeb": ("x", "y", "p", "t"),
}

# Field names playing the roles t, x, y, p in each layout.
_ROLES: dict[str, tuple[str, str, str, str]] = {
    "canonical": ("t", "x", "y", "p"),
    "aedat": ("t", "x", "y", "on"),
    "tonic": ("t", "x", "y", "p"),
    "aestream": ("timestamp", "x", "y", "polarity"),
    "openeb": ("t", "x", "y", "p"),
}


def packed_bytes(events: np.ndarray) -> np.ndarray:
    """View canonical events as the contiguous ``uint8`` buffer the engine reads (no copy when
    the array is already contiguous)."""
    if not isinstance(events, np.ndarray) or events.dtype != EVENT_DTYPE:
        got = getattr(events, "dtype", type(events).__name__)
        raise EventError(f"events must have dtype {EVENT_DTYPE.descr}, got {got}")
    if events.ndim != 1:
        raise EventError(f"events must be a 1-D array, got shape {events.shape}")
    return np.ascontiguousarray(events).view(np.uint8)


@dataclass(frozen=True)
class Recording:
    """Events sorted by time, the sensor size ``(width, height)``, and free-form metadata.

    Building one validates every event: a wrong dtype, an event outside the sensor, a time
    going backwards or a time past the engine's latest, 2^62 µs, raises
    :class:`~uavsnn.EventError` naming the event. ``metadata`` must be a
    mapping (it is kept as a new ``dict`` of its items); anything else, ``None`` included, is a
    :class:`~uavsnn.ParameterError`.
    """

    events: np.ndarray
    sensor_size: tuple[int, int]
    metadata: dict[str, Any] = field(default_factory=dict)

    if TYPE_CHECKING:  # what the constructor takes: it keeps (width, height) and a new dict

        def __init__(
            self,
            events: np.ndarray,
            sensor_size: SensorSizeLike,
            metadata: Mapping[str, Any] = ...,
        ) -> None: ...

    def __post_init__(self) -> None:
        if not isinstance(self.metadata, Mapping):
            raise ParameterError(
                f"metadata must be a mapping (a dict), got {type(self.metadata).__name__}"
            )
        size = check_sensor_size(self.sensor_size)
        buf = packed_bytes(self.events)
        _core.validate_events(buf, size[0], size[1])
        t = self.events["t"]
        if len(t) and t[-1] > MAX_TIME_US:  # in time order: the last is the latest
            i = int(np.searchsorted(t, np.uint64(MAX_TIME_US), side="right"))
            raise EventError(
                f"event {i}: t={int(t[i])} is beyond the latest time the engine takes "
                f"(2^62 = {MAX_TIME_US} µs)"
            )
        object.__setattr__(self, "sensor_size", size)
        object.__setattr__(self, "metadata", dict(self.metadata))

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


def recording_from_engine(
    events: np.ndarray, sensor_size: tuple[int, int], metadata: dict[str, Any]
) -> Recording:
    """A :class:`Recording` of events the engine has just produced valid (sorted, on the
    sensor), without validating them a second time. Internal to the package (not in
    ``__all__``): only for arrays the engine returned."""
    rec = object.__new__(Recording)
    object.__setattr__(rec, "events", events)
    object.__setattr__(rec, "sensor_size", sensor_size)
    object.__setattr__(rec, "metadata", metadata)
    return rec


def _first_bad(mask: np.ndarray) -> int:
    return int(np.argmax(mask))


def _integer_column(name: str, values: np.ndarray, upper: int | None) -> np.ndarray:
    """Check a column of integers in ``[0, upper]``."""
    if values.dtype.kind == "f":
        raise EventError(
            f"{name} must be integers, got {values.dtype}; convert explicitly "
            f"(for times in seconds: np.round(t * 1e6).astype(np.uint64))"
        )
    if values.dtype.kind not in "iu":
        raise EventError(f"{name} must be integers, got {values.dtype}")
    if values.dtype.kind == "i" and values.size and (values < 0).any():
        i = _first_bad(values < 0)
        raise EventError(f"event {i}: {name}={values[i]} is negative")
    if upper is not None and values.size and values.max() > upper:
        i = _first_bad(values > upper)
        raise EventError(f"event {i}: {name}={values[i]} exceeds {upper}")
    return values


def _polarity(values: np.ndarray) -> np.ndarray:
    """Polarity as ON booleans from bool, 0/1 or ±1 values."""
    if values.dtype.kind == "b":
        return values.astype(bool)
    if values.dtype.kind not in "iuf":
        raise EventError(f"polarity must be boolean or numeric, got {values.dtype}")
    plus_minus = values.dtype.kind != "u" and bool((values == -1).any())
    allowed = (-1, 1) if plus_minus else (0, 1)
    bad = ~np.isin(values, allowed)
    if bad.any():
        i = _first_bad(bad)
        encoding = "-1/+1" if plus_minus else "0/1"
        raise EventError(
            f"event {i}: polarity {values[i]} is not {allowed[0]} or {allowed[1]} "
            f"(the stream uses the {encoding} encoding)"
        )
    return values == 1


def _guess_layout(names: tuple[str, ...]) -> str:
    for layout in ("canonical", "aedat", "aestream"):
        if set(_ROLES[layout]) <= set(names):
            return layout
    raise EventError(
        f"cannot tell the layout of fields {list(names)}; expected the fields of one of "
        f"{ {k: list(v) for k, v in LAYOUTS.items()} } (or name it with layout=...)"
    )


def convert(
    array: Any,
    layout: str = "auto",
    sensor_size: SensorSizeLike | None = None,
) -> np.ndarray:
    """Convert events of another layout to a new array of the canonical :data:`EVENT_DTYPE`.

    Args:
        array: a structured array (fields named as in :data:`LAYOUTS`), or a plain ``(N, 4)``
            integer array whose columns follow ``layout``.
        layout: ``"auto"`` (structured arrays only: chosen from the field names), or one of
            :data:`LAYOUTS` to name the source explicitly.
        sensor_size: ``(width, height)``; when given, every event must lie on it.

    Returns:
        a new, contiguous array of :data:`EVENT_DTYPE`, in the input's order (sorting is not
        this function's business: :class:`Recording` checks it).

    Raises:
        EventError: unknown fields, float or negative times and coordinates, polarity other
            than bool/0/1/±1, or an event off the sensor, naming the first bad event.
        ParameterError: an unknown layout (or one that is not a string) or a bad
            ``sensor_size``.
    """
    if not isinstance(layout, str) or (layout != "auto" and layout not in LAYOUTS):
        raise ParameterError(
            f"unknown layout {layout!r}; expected 'auto' or one of {list(LAYOUTS)}"
        )
    arr = np.asarray(array)
    if arr.dtype.names is not None:
        if arr.ndim != 1:
            raise EventError(f"events must be a 1-D structured array, got shape {arr.shape}")
        names = tuple(arr.dtype.names)
        if layout == "auto":
            layout = _guess_layout(names)
        missing = [n for n in _ROLES[layout] if n not in names]
        if missing:
            raise EventError(f"layout {layout!r} needs fields {missing}, got {list(names)}")
        columns = [arr[n] for n in _ROLES[layout]]
        for name, column in zip(_ROLES[layout], columns, strict=True):
            if column.shape != arr.shape:  # a sub-array field, such as ('y', '<u2', (2,))
                raise EventError(
                    f"field {name!r} must hold one number per event, got {column.dtype} of "
                    f"shape {column.shape[1:]} per event"
                )
    else:
        if layout == "auto":
            raise EventError(
                f"a plain {arr.dtype} array of shape {arr.shape} has no field names: "
                f"name its column order with layout= (one of {list(LAYOUTS)})"
            )
        if arr.ndim != 2 or arr.shape[1] != 4:
            raise EventError(f"a plain event array must have shape (N, 4), got {arr.shape}")
        order = LAYOUTS[layout]
        columns = [arr[:, order.index(n)] for n in _ROLES[layout]]
    t, x, y, p = columns
    t = _integer_column("t", t, None)
    x = _integer_column("x", x, 65535)
    y = _integer_column("y", y, 65535)
    out = np.empty(len(arr), EVENT_DTYPE)
    out["t"] = t
    out["x"] = x
    out["y"] = y
    out["p"] = _polarity(p)
    if sensor_size is not None:
        width, height = check_sensor_size(sensor_size)
        off = (out["x"] >= width) | (out["y"] >= height)
        if off.any():
            i = _first_bad(off)
            raise EventError(
                f"event {i}: (x={out['x'][i]}, y={out['y'][i]}) is outside the "
                f"{width}x{height} sensor"
            )
    return out
