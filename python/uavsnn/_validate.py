"""Checks of parameters shared by the package's modules (internal: import from here, not from
the modules that use them). Each failure is a :class:`~uavsnn.ParameterError` that names the
parameter and the value."""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Callable
from typing import Any

import numpy as np

from uavsnn.errors import ParameterError, ShapeError

U64_MAX = (1 << 64) - 1
#: The latest event time and the longest window the engine takes (its ``MAX_TIME_US``, 2^62 µs),
#: so that no sum of two times overflows a u64.
MAX_TIME_US = 1 << 62


def check_int(name: str, value: Any, low: int = 0, high: int | None = None) -> int:
    """An integer (``bool`` refused) in ``[low, high]`` (no upper bound when ``high`` is None),
    as ``int``."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ParameterError(f"{name} must be an integer, got {value!r}")
    result = int(value)
    if high is None and result < low:
        raise ParameterError(f"{name} must be an integer >= {low}, got {_shown(result)}")
    if high is not None and not low <= result <= high:
        raise ParameterError(f"{name} must be in [{low}, {high}], got {_shown(result)}")
    return result


def _shown(value: int) -> str:
    """An integer for a message: in full up to 30 digits, else by its size (2**2000 printed
    603 digits)."""
    return str(value) if abs(value) < 10**30 else f"an integer of {value.bit_length()} bits"


def check_real(
    name: str,
    value: Any,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
) -> float:
    """A finite real in the given range, as ``float``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ParameterError(f"{name} must be a number, got {value!r}")
    try:
        v = float(value)
    except OverflowError:  # an integer beyond a float's range
        v = math.inf
    if not math.isfinite(v):
        raise ParameterError(f"{name} must be finite, got {v}")
    if low is not None and (v < low or (low_open and v == low)):
        raise ParameterError(f"{name} must be {'>' if low_open else '>='} {low}, got {v}")
    if high is not None and (v > high or (high_open and v == high)):
        raise ParameterError(f"{name} must be {'<' if high_open else '<='} {high}, got {v}")
    return v


def int_param(name: str, value: Any, minimum: int, maximum: int = U64_MAX) -> int:
    """An integer parameter (an integral float is accepted), or :class:`ParameterError`."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ParameterError(f"{name} must be an integer, got {value!r}")
    result = whole(value)
    if result is None:
        raise ParameterError(f"{name} must be a whole number, got {value!r}")
    if not minimum <= result <= maximum:
        raise ParameterError(f"{name} must be in [{minimum}, {maximum}], got {_shown(result)}")
    return result


def check_sensor_size(sensor_size: Any) -> tuple[int, int]:
    """A sensor size ``(width, height)``, each a whole number (an integral float is accepted)
    in ``[1, 65535]``; a fraction, a ``bool`` or a string is refused, not truncated. tonic's
    ``(width, height, channels)``, with 1 or 2 (polarity) channels, gives its first two."""
    try:
        sides = () if isinstance(sensor_size, (str, bytes)) else tuple(sensor_size)
    except TypeError:
        sides = ()
    values = [v for v in map(whole, sides) if v is not None]
    if len(sides) == 3 and len(values) == 3 and values[2] in (1, 2):
        sides, values = sides[:2], values[:2]
    if len(sides) != 2 or len(values) != 2:
        raise ParameterError(
            "sensor_size must be (width, height) in whole pixels (or tonic's (width, height, "
            f"channels) with 1 or 2 channels), got {sensor_size!r}"
        )
    width, height = values
    if not (0 < width <= 65535 and 0 < height <= 65535):
        raise ParameterError(f"sensor_size must be positive and < 65536, got {width}x{height}")
    return width, height


def whole(value: Any) -> int | None:
    """``value`` as an ``int`` if it is a whole number (an integer, not ``bool``, or an integral
    float: ``64.0`` is 64), else ``None`` (a fraction is not truncated)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        return None
    if isinstance(value, numbers.Integral):
        return int(value)
    v = float(value)
    return int(v) if math.isfinite(v) and v.is_integer() else None


def check_path(path: Any) -> str:
    """A file path as ``str``: a ``str`` or an ``os.PathLike[str]`` (bytes are refused)."""
    try:
        name = os.fspath(path)
    except TypeError:
        name = None
    if not isinstance(name, str):
        raise ParameterError(f"path must be a str or os.PathLike[str], got {path!r}")
    return name


def listed(parts: Any, what: str) -> list[Any]:
    """``parts`` (any iterable: a list, a generator) as a list, or a :class:`ParameterError`
    saying it should be an iterable of ``what``."""
    try:
        return list(parts)
    except TypeError as exc:
        raise ParameterError(
            f"parts must be an iterable of {what}, got {type(parts).__name__}"
        ) from exc


def check_bools(name: str, values: Any) -> np.ndarray:
    """``values`` as a 1-D boolean array (one flag a window), refused otherwise: a
    :class:`~uavsnn.ShapeError` for another shape, a ParameterError for another dtype (strings,
    NaN or numbers are not read as flags). An empty list is no flags (NumPy reads ``[]`` as
    float64)."""
    array = np.asarray(values)
    if array.ndim != 1:
        raise ShapeError(f"{name} must be 1-D, got shape {array.shape}")
    if array.size == 0:
        return np.zeros(0, dtype=np.bool_)
    if array.dtype != np.bool_:
        raise ParameterError(f"{name} must be boolean, got dtype {array.dtype}")
    return array


def check_numbers(name: str, values: Any) -> np.ndarray:
    """``values`` as a float64 array, or a ParameterError naming ``name`` (strings, a ragged
    list)."""
    try:
        return np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be numbers ({exc})") from exc


def fields_once(what: str) -> Callable[[list[tuple[str, Any]]], dict[str, Any]]:
    """A :func:`json.loads` ``object_pairs_hook`` that refuses an object giving a field twice
    (JSON keeps the last one silently), with a ParameterError naming ``what`` and the field."""

    def once(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        fields: dict[str, Any] = {}
        for key, value in pairs:
            if key in fields:
                raise ParameterError(f"{what}: the field {key!r} is given twice in one object")
            fields[key] = value
        return fields

    return once
