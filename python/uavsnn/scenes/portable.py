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
functions run the ``libm`` crate's software implementations in the engine (they take array
likes and return ``float64``). OpenCV's float32 interpolation rounds differently in its SIMD
and its scalar code, so the textures are interpolated here too, in their own type, with
OpenCV's geometry and weights (:func:`resize_cubic`, :func:`shift_linear`,
:func:`remap_linear`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from uavsnn import _core
from uavsnn.errors import ParameterError

__all__ = [
    "arctan",
    "arctan2",
    "cos",
    "exp",
    "matmul",
    "norm",
    "power",
    "remap_linear",
    "resize_cubic",
    "shift_linear",
    "sin",
]

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
    rows = b if b.ndim == 2 else b[:, None]  # a vector as one column
    out = a[..., 0, None] * rows[0]
    for j in range(1, rows.shape[0]):
        out = out + a[..., j, None] * rows[j]
    return np.asarray(out if b.ndim == 2 else out[..., 0])


def norm(v: Any) -> float:
    """The Euclidean length of a vector: its squares added from the first, then the root."""
    total = 0.0
    for x in np.asarray(v, dtype=np.float64).reshape(-1).tolist():
        total += x * x
    return math.sqrt(total)


# -- interpolation -------------------------------------------------------------------------------
#
# OpenCV's float32 interpolation (``resize`` with INTER_CUBIC, ``remap`` and ``warpAffine``
# with INTER_LINEAR) rounds differently in its SIMD and its scalar code, so the renderer does
# its own: the same weights wherever it runs, applied with elementwise operations in a fixed
# order. Pixel centres are on integers, as OpenCV's.

#: Keys' cubic kernel parameter, OpenCV's for INTER_CUBIC.
CUBIC_A = -0.75


def _cubic_taps(out: int, full: int, src: int) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """For the first ``out`` of ``full`` samples across a line of ``src``: each of the four taps'
    source index (edges replicated) and ``float32`` weight."""
    pos = (np.arange(out, dtype=np.float64) + 0.5) * (src / full) - 0.5
    base = np.floor(pos)
    t = pos - base
    a = CUBIC_A
    u = t + 1.0
    w0 = ((a * u - 5.0 * a) * u + 8.0 * a) * u - 4.0 * a
    w1 = ((a + 2.0) * t - (a + 3.0)) * t * t + 1.0
    v = 1.0 - t
    w2 = ((a + 2.0) * v - (a + 3.0)) * v * v + 1.0
    w3 = 1.0 - w0 - w1 - w2
    index = [np.clip(base.astype(np.int64) + k - 1, 0, src - 1) for k in range(4)]
    return index, [w.astype(np.float32) for w in (w0, w1, w2, w3)]


def resize_cubic(grid: np.ndarray, size: tuple[int, int], crop: tuple[int, int]) -> np.ndarray:
    """The top-left ``crop`` ``(width, height)`` of a 2-D ``float32`` ``grid`` resized to
    ``size`` ``(width, height)`` with Keys' cubic (OpenCV's INTER_CUBIC geometry)."""
    grid = np.asarray(grid, dtype=np.float32)
    (full_w, full_h), (w, h) = size, crop
    xi, xw = _cubic_taps(w, full_w, grid.shape[1])
    yi, yw = _cubic_taps(h, full_h, grid.shape[0])
    rows = grid[:, xi[0]] * xw[0]
    for k in range(1, 4):
        rows = rows + grid[:, xi[k]] * xw[k]
    out = rows[yi[0]] * yw[0][:, None]
    for k in range(1, 4):
        out = out + rows[yi[k]] * yw[k][:, None]
    return out


def shift_linear(tex: np.ndarray, ox: float, oy: float, width: int, height: int) -> np.ndarray:
    """``tex`` (``(H, W)`` or ``(H, W, C)``) sampled at ``(i + ox, j + oy)`` for
    ``i < width``, ``j < height`` by bilinear interpolation, edges replicated (OpenCV's
    ``warpAffine`` of a shift, INTER_LINEAR, BORDER_REPLICATE): ``(height, width[, C])``."""
    x0, y0 = math.floor(ox), math.floor(oy)
    th, tw = tex.shape[:2]
    if 0 <= x0 and x0 + width < tw and 0 <= y0 and y0 + height < th:
        sub = tex[y0 : y0 + height + 1, x0 : x0 + width + 1]
    else:
        rows = np.clip(np.arange(y0, y0 + height + 1), 0, th - 1)
        cols = np.clip(np.arange(x0, x0 + width + 1), 0, tw - 1)
        sub = tex[rows[:, None], cols[None, :]]
    kind = tex.dtype.type
    fx, fy = kind(ox - x0), kind(oy - y0)
    # A whole-pixel step leaves a weight of 0 and one of 1: the sums below without those
    # terms, bit for bit.
    if fy == 0:
        top = sub[:-1]
        return np.array(top[:, :-1]) if fx == 0 else _lerp(top[:, :-1], top[:, 1:], fx)
    if fx == 0:
        return _lerp(sub[:-1, :-1], sub[1:, :-1], fy)
    top = _lerp(sub[:-1, :-1], sub[:-1, 1:], fx)
    return _lerp(top, _lerp(sub[1:, :-1], sub[1:, 1:], fx), fy)


def _lerp(a: np.ndarray, b: np.ndarray, f: np.floating[Any]) -> np.ndarray:
    """``a * (1 - f) + b * f`` in ``a``'s type, in that order, with one temporary."""
    out = np.multiply(a, a.dtype.type(1) - f)
    out += np.multiply(b, f)
    return out


def remap_linear(tex: np.ndarray, map_x: Any, map_y: Any, *, wrap: bool) -> np.ndarray:
    """``tex`` (``(H, W)`` or ``(H, W, C)``) sampled at ``(map_x, map_y)`` (broadcast together)
    by bilinear interpolation, the edges wrapped round (``wrap``) or replicated (OpenCV's
    ``remap``, INTER_LINEAR, BORDER_WRAP or BORDER_REPLICATE)."""
    mx, my = np.broadcast_arrays(np.asarray(map_x), np.asarray(map_y))
    th, tw = tex.shape[:2]
    kind = tex.dtype.type
    x0, y0 = np.floor(mx), np.floor(my)
    fx, fy = (mx - x0).astype(kind), (my - y0).astype(kind)
    xa, ya = x0.astype(np.int64), y0.astype(np.int64)
    if wrap:
        xa, ya = xa % tw, ya % th
        xb, yb = (xa + 1) % tw, (ya + 1) % th
    else:
        xb, yb = np.clip(xa + 1, 0, tw - 1), np.clip(ya + 1, 0, th - 1)
        xa, ya = np.clip(xa, 0, tw - 1), np.clip(ya, 0, th - 1)
    flat = tex.reshape(th * tw, -1)  # one gather of whole pixels for each corner

    def at(y: np.ndarray, x: np.ndarray) -> np.ndarray:
        return np.take(flat, y * tw + x, axis=0).reshape(*y.shape, *tex.shape[2:])

    if tex.ndim == 3:
        fx, fy = fx[..., None], fy[..., None]
    gx = kind(1) - fx
    top = at(ya, xa) * gx + at(ya, xb) * fx
    if not fy.any():  # on whole rows: the sum below without its terms of weight 0 and 1
        return np.asarray(top)
    bottom = at(yb, xa) * gx + at(yb, xb) * fx
    return np.asarray(top * (kind(1) - fy) + bottom * fy)
