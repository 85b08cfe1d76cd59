"""Validation of simulation parameters: each failure is a :class:`~uavsnn.ParameterError` that
names the parameter and the value."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from uavsnn.errors import ParameterError

__all__ = ["check_choice", "check_int", "check_real", "check_seed", "check_size"]


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
    v = float(value)
    if not math.isfinite(v):
        raise ParameterError(f"{name} must be finite, got {v}")
    if low is not None and (v < low or (low_open and v == low)):
        raise ParameterError(f"{name} must be {'>' if low_open else '>='} {low}, got {v}")
    if high is not None and (v > high or (high_open and v == high)):
        raise ParameterError(f"{name} must be {'<' if high_open else '<='} {high}, got {v}")
    return v


def check_int(name: str, value: Any, *, low: int, high: int) -> int:
    """An integer in ``[low, high]``, as ``int``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ParameterError(f"{name} must be an integer, got {value!r}")
    if not low <= int(value) <= high:
        raise ParameterError(f"{name} must be in [{low}, {high}], got {value}")
    return int(value)


def check_choice(name: str, value: Any, choices: tuple[str, ...]) -> str:
    """One of ``choices``."""
    if value not in choices:
        options = ", ".join(repr(c) for c in choices)
        raise ParameterError(f"{name} must be one of {options}, got {value!r}")
    return str(value)


def check_seed(seed: Any) -> int:
    """A seed in ``[0, 2**64)``."""
    return check_int("seed", seed, low=0, high=2**64 - 1)


def check_size(size: Any, name: str = "size") -> tuple[int, int]:
    """A ``(width, height)`` pair of positive integers below 65536; also parses ``"240x180"``."""
    if isinstance(size, str):
        parts = size.lower().split("x")
        try:
            size = tuple(int(p) for p in parts)
        except ValueError as exc:
            raise ParameterError(f"{name} must look like 240x180, got {size!r}") from exc
    try:
        width, height = size
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be (width, height), got {size!r}") from exc
    return (
        check_int(f"{name} width", width, low=1, high=65535),
        check_int(f"{name} height", height, low=1, high=65535),
    )
