"""The light models identification learns with (SPEC §3): logistic and multinomial logistic
regression, fitted by Newton's method with an L2 penalty, in NumPy. :mod:`uavsnn.identify`
fits them on an object's features (and re-exports them).

::

    coef = fit_logistic(x, y, l2=1.0)            # y bool: coefficients, the intercept last
    p = predict_logistic(coef, x)
    coef = fit_softmax(x, y, 3, l2=1.0)          # y in [0, 3): (3, d + 1)
    p = predict_softmax(coef, x)                 # (n, 3), rows summing to 1
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from uavsnn.errors import ParameterError, ShapeError

__all__ = [
    "fit_logistic",
    "fit_softmax",
    "labelled",
    "predict_logistic",
    "predict_softmax",
    "sigmoid",
]


def fit_logistic(
    x: npt.ArrayLike, y: npt.ArrayLike, *, l2: float = 1.0, iterations: int = 50
) -> np.ndarray:
    """Logistic regression by Newton's method: coefficients ``(d + 1,)``, the intercept last,
    minimising the log loss plus ``l2 / 2 * |w|²`` (the intercept is not penalised). ``x``
    ``(n, d)`` float, ``y`` ``(n,)`` bool.

    Raises:
        ShapeError, ParameterError: mismatched shapes, a negative ``l2``, non-finite features.
    """
    x, y = labelled(x, y)
    if not (l2 >= 0 and math.isfinite(l2)):
        raise ParameterError(f"l2 must be a finite number >= 0, got {l2}")
    a = np.hstack([x, np.ones((len(x), 1))])
    target = y.astype(np.float64)
    penalty = np.full(a.shape[1], float(l2))
    penalty[-1] = 1e-9  # the intercept: only enough to keep the system solvable
    w = np.zeros(a.shape[1])
    for _ in range(iterations):
        p = sigmoid(a @ w)
        grad = a.T @ (p - target) + penalty * w
        hess = (a * (p * (1 - p))[:, None]).T @ a + np.diag(penalty)
        step = np.linalg.solve(hess + 1e-12 * np.eye(len(w)), grad)
        w -= step
        if np.max(np.abs(step)) < 1e-10:
            break
    return w


def labelled(x: npt.ArrayLike, y: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """``x`` as float64 ``(n, d)`` and ``y`` as given, checked for a binary fit: ``y`` ``(n,)``
    boolean, ``x`` finite.

    Raises:
        ShapeError, ParameterError: mismatched shapes, non-boolean ``y``, non-finite ``x``.
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y)
    if x.ndim != 2 or y.shape != (len(x),):
        raise ShapeError(f"x must be (n, d) and y (n,), got {x.shape} and {y.shape}")
    if y.dtype != np.bool_:
        raise ParameterError(f"y must be boolean, got dtype {y.dtype}")
    if not np.isfinite(x).all():
        raise ParameterError("x holds NaN or infinite values")
    return x, y


def predict_logistic(coef: npt.ArrayLike, x: npt.ArrayLike) -> np.ndarray:
    """``sigmoid(x @ coef[:-1] + coef[-1])``.

    Raises:
        ShapeError: ``coef`` not ``(d + 1,)`` for ``x`` ``(n, d)``.
    """
    coef = np.asarray(coef, dtype=np.float64)
    x = _rows(x, coef.shape[-1] - 1 if coef.ndim == 1 else -1, "(d + 1,)", coef.shape)
    return sigmoid(x @ coef[:-1] + coef[-1])


def _rows(x: npt.ArrayLike, d: int, expected: str, shape: tuple[int, ...]) -> np.ndarray:
    """``x`` as float64 ``(n, d)``; ``d`` < 0 when the coefficients' ``shape`` is not the
    ``expected`` one.

    Raises:
        ShapeError: either shape wrong.
    """
    x = np.asarray(x, dtype=np.float64)
    if d < 0 or x.ndim != 2 or x.shape[1] != d:
        raise ShapeError(
            f"coefficients {expected} take x (n, d): got coefficients {shape} and x {x.shape}"
        )
    return x


def sigmoid(z: np.ndarray) -> np.ndarray:
    """The logistic function ``1 / (1 + e^-z)``, stable for large ``|z|``."""
    return 0.5 * (1.0 + np.tanh(0.5 * z))


def fit_softmax(
    x: npt.ArrayLike,
    y: npt.ArrayLike,
    classes: int,
    *,
    l2: float = 1.0,
    weights: npt.ArrayLike | None = None,
    iterations: int = 50,
) -> np.ndarray:
    """Multinomial logistic regression by Newton's method: coefficients ``(classes, d + 1)``,
    the intercepts last, minimising the weighted log loss plus ``l2 / 2 * |W|²`` (the
    intercepts carry only a tiny penalty, enough to fix the one direction all classes share).
    ``x`` ``(n, d)`` float, ``y`` ``(n,)`` int in ``[0, classes)``, ``weights`` ``(n,)``
    (default: ones).

    Raises:
        ShapeError, ParameterError: mismatched shapes, a class out of range, a negative ``l2``
            or weight, non-finite features.
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y)
    if x.ndim != 2 or y.shape != (len(x),):
        raise ShapeError(f"x must be (n, d) and y (n,), got {x.shape} and {y.shape}")
    if not np.issubdtype(y.dtype, np.integer):
        raise ParameterError(f"y must hold class indices (integers), got dtype {y.dtype}")
    if classes < 2 or (len(y) and (y.min() < 0 or y.max() >= classes)):
        raise ParameterError(f"y must lie in [0, {classes}) with at least 2 classes")
    if not np.isfinite(x).all():
        raise ParameterError("x holds NaN or infinite values")
    if not (l2 >= 0 and math.isfinite(l2)):
        raise ParameterError(f"l2 must be a finite number >= 0, got {l2}")
    w = np.ones(len(x)) if weights is None else np.asarray(weights, dtype=np.float64)
    if w.shape != (len(x),) or not (np.isfinite(w).all() and (w >= 0).all()):
        raise ParameterError("weights must be (n,), finite and >= 0")
    n, d1, k = len(x), x.shape[1] + 1, int(classes)
    a = np.hstack([x, np.ones((n, 1))])
    target = np.zeros((n, k))
    target[np.arange(n), y] = 1.0
    penalty = np.tile(np.r_[np.full(d1 - 1, float(l2)), 1e-6], k)
    coef = np.zeros(k * d1)
    hess = np.empty((k * d1, k * d1))
    for _ in range(iterations):
        p = predict_softmax(coef.reshape(k, d1), x)
        grad = ((p - target) * w[:, None]).T @ a
        grad = grad.ravel() + penalty * coef
        # The Hessian's (class i, class j) block: A^T diag(w p_i (δ_ij - p_j)) A, block by
        # block so that memory stays O(n d) whatever the classes.
        for i in range(k):
            for j in range(i, k):
                c = w * p[:, i] * ((i == j) - p[:, j])
                block = a.T @ (a * c[:, None])
                hess[i * d1 : (i + 1) * d1, j * d1 : (j + 1) * d1] = block
                hess[j * d1 : (j + 1) * d1, i * d1 : (i + 1) * d1] = block.T
        step = np.linalg.solve(hess + np.diag(penalty + 1e-12), grad)
        coef -= step
        if np.max(np.abs(step)) < 1e-10:
            break
    return coef.reshape(k, d1)


def predict_softmax(coef: npt.ArrayLike, x: npt.ArrayLike) -> np.ndarray:
    """Class probabilities ``(m, classes)``: ``softmax(x @ coef[:, :-1].T + coef[:, -1])``.

    Raises:
        ShapeError: ``coef`` not ``(classes, d + 1)`` for ``x`` ``(m, d)``.
    """
    coef = np.asarray(coef, dtype=np.float64)
    d = coef.shape[1] - 1 if coef.ndim == 2 else -1
    z = _rows(x, d, "(classes, d + 1)", coef.shape) @ coef[:, :-1].T + coef[:, -1]
    z -= z.max(axis=1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(axis=1, keepdims=True)
