"""Arithmetic whose results are the same bits on every CPU, for the scene renderer.

NumPy chooses its kernels by processor. A float product (``@``) goes to OpenBLAS, whose kernel
is picked for the CPU it runs on (Haswell's on AVX2, SkylakeX's on AVX-512), and ``np.exp``,
``np.sin``, ``np.arctan`` ... run SIMD code picked the same way (Intel's SVML on AVX-512;
NumPy's own float32 loops on AVX2; the C library elsewhere). Each rounds the last bits in its
own way. A frame rendered to 8 bits, or a polygon edge on a sixteenth-pixel grid, can turn
such a bit into another pixel value, and a synthetic dataset built on one machine then
differed from the same build on another (docs/dataset.md, "The same data on every CPU").

Here a product is summed term by term in a fixed order with NumPy's elementwise ``*`` and
``+`` (each one IEEE-rounded and never fused, whatever the SIMD width), and the transcendental
functions run the ``libm`` crate's software implementations in the engine. Each takes array
likes and returns ``float64`` (the products: the operands' type), computed in ``float64``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from uavsnn import _core
from uavsnn.errors import ParameterError

__all__ = ["arctan", "arctan2", "cos", "exp", "matmul", "norm", "power", "sin"]

FloatArray = npt.NDArray[np.float64]


def _unary(op: str, x: Any) -> FloatArray:
    a = np.asarray(x, dtype=np.float64)
    flat = np.ascontiguousarray(a).reshape(-1)
    return np.asarray(_core.portable_unary(op, flat)).reshape(a.shape)


def _binary(op: str, x: Any, y: Any) -> FloatArray:
    a, b = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    flat_a = np.ascontiguousarray(a).reshape(-1)
    flat_b = np.ascontiguousarray(b).reshape(-1)
    return np.asarray(_core.portable_binary(op, flat_a, flat_b)).reshape(a.shape)


def exp(x: Any) -> FloatArray:
    """``e**x`` elementwise."""
    return _unary("exp", x)


def sin(x: Any) -> FloatArray:
    """Sine (radians) elementwise."""
    return _unary("sin", x)


def cos(x: Any) -> FloatArray:
    """Cosine (radians) elementwise."""
    return _unary("cos", x)


def arctan(x: Any) -> FloatArray:
    """Arc tangent (radians, in ``[-pi/2, pi/2]``) elementwise."""
    return _unary("arctan", x)


def arctan2(y: Any, x: Any) -> FloatArray:
    """The angle of ``(x, y)`` (radians, in ``[-pi, pi]``), broadcast as NumPy's."""
    return _binary("arctan2", y, x)


def power(x: Any, p: Any) -> FloatArray:
    """``x**p`` elementwise, broadcast as NumPy's."""
    return _binary("power", x, p)


def matmul(a: Any, b: Any) -> np.ndarray:
    """``a @ b`` for ``b`` of shape ``(k,)`` or ``(k, m)`` and ``a`` of shape ``(..., k)``:
    the ``k`` products added one after another, from the first."""
    a, b = np.asarray(a), np.asarray(b)
    if b.ndim not in (1, 2) or a.ndim < 1 or a.shape[-1] != b.shape[0] or b.shape[0] == 0:
        raise ParameterError(
            f"matmul takes (..., k) @ (k,) or (k, m) with k >= 1, got {a.shape} @ {b.shape}"
        )
    if b.ndim == 1:
        out = a[..., 0] * b[0]
        for j in range(1, b.shape[0]):
            out = out + a[..., j] * b[j]
        return np.asarray(out)
    out = a[..., 0, None] * b[0]
    for j in range(1, b.shape[0]):
        out = out + a[..., j, None] * b[j]
    return np.asarray(out)


def norm(v: Any) -> float:
    """The Euclidean length of a vector: its squares added from the first, then the root."""
    total = 0.0
    for x in np.asarray(v, dtype=np.float64).reshape(-1).tolist():
        total += x * x
    return math.sqrt(total)
