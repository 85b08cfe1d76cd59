"""Boosted oblivious trees: the second light model identification may learn with (SPEC §3).

A sum of small decision trees fitted by Newton boosting on the log loss, in NumPy. Each tree
is *oblivious* (as in CatBoost): all nodes of one level split on the same feature at the same
threshold, so a tree of depth ``D`` is ``D`` (feature, threshold) pairs and ``2^D`` leaf
values, and a prediction is ``D`` comparisons that build the leaf's index bit by bit. Unlike a
logistic regression it can learn that a feature matters only together with another one (a
flicker line that means a rotor on a small, slow object and a wing beat on a fast, near one).

Fitting: the features are cut at up to ``bins - 1`` quantiles of the training values (the
only thresholds a split may take); each level chooses the (feature, threshold) with the
largest Newton gain summed over the level's nodes; leaf values are ``-G / (H + l2)`` times
``learning_rate``. With tuning data, the number of trees kept is the one with the smallest
log loss on it (early stopping), so that the tuning set, not the training set, says when to
stop.

::

    model = fit_trees(x, y, x_tune=xt, y_tune=yt, depth=3)   # y bool
    p = model.predict(x)                                     # probabilities, (n,)

:class:`Trees` is plain arrays (``feature``, ``threshold``, ``leaf``, ``base``), stored in a
model file without pickle (:meth:`uavsnn.identify.Identifier.to_arrays`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
import numpy.typing as npt

from uavsnn.errors import ParameterError, ShapeError
from uavsnn.linear import labelled, sigmoid

__all__ = ["MAX_DEPTH", "MAX_TREES", "Trees", "fit_trees"]

#: Deepest tree :func:`fit_trees` grows (a tree has ``2^depth`` leaves).
MAX_DEPTH = 8

#: Most trees :func:`fit_trees` grows.
MAX_TREES = 10_000

#: Rows :meth:`Trees.raw` compares at once: ``(rows, trees, depth)`` booleans, a few MB.
_ROWS = 1024


@dataclass(frozen=True, eq=False)
class Trees:
    """A fitted sum of oblivious trees. ``feature`` ``(T, D)`` int64: the column each level
    of each tree splits on; ``threshold`` ``(T, D)`` float64: a row goes right at that level
    when its value is above it; ``leaf`` ``(T, 2^D)`` float64: the value each leaf adds;
    ``base``: the raw score before any tree. The probability is ``sigmoid(base + sum of
    leaves)``. ``width``: the columns of the rows :func:`fit_trees` fitted it on, which every
    row scored must have (``None`` where not known, as in a model file: a row then needs the
    columns the trees split on, :attr:`columns`). Two are equal when every field is, the
    arrays element by element (and of one shape); they cannot be hashed (they hold arrays).

    Raises:
        ShapeError: arrays that do not fit together.
        ParameterError: non-finite values or a negative column.
    """

    feature: np.ndarray
    threshold: np.ndarray
    leaf: np.ndarray
    base: float
    width: int | None = None

    def __post_init__(self) -> None:
        f, t, v = self.feature, self.threshold, self.leaf
        if f.ndim != 2 or t.shape != f.shape or v.shape != (f.shape[0], 1 << f.shape[1]):
            raise ShapeError(
                f"trees need feature and threshold (T, D) and leaf (T, 2^D), got {f.shape}, "
                f"{t.shape} and {v.shape}"
            )
        if f.shape[1] > MAX_DEPTH or f.shape[0] > MAX_TREES:
            raise ParameterError(
                f"at most {MAX_TREES} trees of depth {MAX_DEPTH}, got {f.shape[0]} of {f.shape[1]}"
            )
        if not np.issubdtype(f.dtype, np.integer) or (f.size and f.min() < 0):
            raise ParameterError("tree features must be column indices >= 0")
        if not (np.isfinite(t).all() and np.isfinite(v).all() and math.isfinite(self.base)):
            raise ParameterError("tree thresholds, leaves and base must be finite")
        if self.width is not None and not (
            isinstance(self.width, int) and self.width >= max(self.columns, 1)
        ):
            raise ParameterError(
                f"width must be an integer >= {max(self.columns, 1)} (the columns split on), "
                f"got {self.width!r}"
            )

    def __eq__(self, other: object) -> bool:
        """Every field equal, the arrays element by element."""
        if other.__class__ is not self.__class__:
            return NotImplemented
        for f in fields(self):
            a, b = getattr(self, f.name), getattr(other, f.name)
            if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
                if not np.array_equal(a, b):
                    return False
            elif not (a is b or a == b):
                return False
        return True

    __hash__ = None  # type: ignore[assignment]  # holds arrays

    @property
    def columns(self) -> int:
        """The fewest columns a row must have (the largest column split on, plus one)."""
        return int(self.feature.max()) + 1 if self.feature.size else 0

    def raw(self, x: np.ndarray) -> np.ndarray:
        """The raw score (log odds) of each row of ``x`` ``(n, d)``."""
        x = np.asarray(x, dtype=np.float64)
        if self.width is not None and (x.ndim != 2 or x.shape[1] != self.width):
            raise ShapeError(f"x must be (n, {self.width}), the rows fitted on, got {x.shape}")
        if x.ndim != 2 or x.shape[1] < self.columns:
            raise ShapeError(f"x must be (n, >= {self.columns}), got {x.shape}")
        count, depth = self.feature.shape
        out = np.full(len(x), self.base)
        if count == 0:
            return out
        place = 1 << np.arange(depth - 1, -1, -1)  # the first level is the leaf index's top bit
        trees = np.arange(count)
        for start in range(0, len(x), _ROWS):  # (rows, trees, depth) comparisons at a time
            rows = x[start : start + _ROWS]
            index = (rows[:, self.feature] > self.threshold) @ place
            out[start : start + len(rows)] += self.leaf[trees, index].sum(axis=1)
        return out

    def predict(self, x: np.ndarray) -> np.ndarray:
        """The probability of each row of ``x`` ``(n, d)``."""
        return sigmoid(self.raw(x))


def _cuts(column: np.ndarray, bins: int) -> np.ndarray:
    """Up to ``bins - 1`` thresholds of one column: the distinct inner quantiles, each a value
    below which some rows fall and above which others lie."""
    q = np.quantile(column, np.arange(1, bins) / bins, method="lower")
    cuts = np.unique(q)
    return cuts[cuts < column.max()]


def _log_loss(raw: np.ndarray, y: np.ndarray) -> float:
    # log(1 + e^-z) for y, log(1 + e^z) otherwise, stable for large |z|
    z = np.where(y, raw, -raw)
    return float(np.mean(np.logaddexp(0.0, -z)))


def fit_trees(
    x: npt.ArrayLike,
    y: npt.ArrayLike,
    *,
    x_tune: npt.ArrayLike | None = None,
    y_tune: npt.ArrayLike | None = None,
    depth: int = 3,
    trees: int = 200,
    learning_rate: float = 0.1,
    l2: float = 1.0,
    bins: int = 32,
) -> Trees:
    """Fit :class:`Trees` to ``x`` ``(n, d)`` float and ``y`` ``(n,)`` bool: up to ``trees``
    oblivious trees of ``depth`` levels by Newton boosting on the log loss (see the module).
    With ``x_tune`` and ``y_tune``, only the first trees up to the smallest log loss on them
    are kept (possibly none: the base rate alone).

    Raises:
        ShapeError, ParameterError: mismatched shapes, non-boolean ``y``, non-finite features,
            or settings out of range.
    """
    x, y = labelled(x, y)
    if len(x) == 0:
        raise ParameterError("x must hold at least one row")
    if not (isinstance(depth, int) and 1 <= depth <= MAX_DEPTH):
        raise ParameterError(f"depth must be an integer in [1, {MAX_DEPTH}], got {depth!r}")
    if not (isinstance(trees, int) and 0 <= trees <= MAX_TREES):
        raise ParameterError(f"trees must be an integer in [0, {MAX_TREES}], got {trees!r}")
    if not (isinstance(bins, int) and 2 <= bins <= 256):
        raise ParameterError(f"bins must be an integer in [2, 256], got {bins!r}")
    if not (0 < learning_rate <= 1 and math.isfinite(learning_rate)):
        raise ParameterError(f"learning_rate must be in (0, 1], got {learning_rate}")
    if not (l2 > 0 and math.isfinite(l2)):
        raise ParameterError(f"l2 must be a finite number > 0, got {l2}")
    tune = None
    if x_tune is not None or y_tune is not None:
        xt, yt = np.asarray(x_tune, dtype=np.float64), np.asarray(y_tune)
        if xt.ndim != 2 or xt.shape[1] != x.shape[1] or yt.shape != (len(xt),):
            raise ShapeError(
                f"x_tune must be (m, {x.shape[1]}) and y_tune (m,), got {xt.shape} and {yt.shape}"
            )
        tune = labelled(xt, yt)

    n, d = x.shape
    cuts = [_cuts(x[:, j], bins) for j in range(d)]
    width = max(len(c) for c in cuts) + 1
    # binned[i, j]: how many of column j's cuts lie below x[i, j], so "x > cut k" is "bin > k"
    binned = np.stack(
        [np.searchsorted(cuts[j], x[:, j], side="left") for j in range(d)], axis=1
    ).astype(np.int64)
    valid = np.zeros((d, width), dtype=bool)  # cut k of column j exists
    for j, c in enumerate(cuts):
        valid[j, : len(c)] = True
    flat = binned + np.arange(d)[None, :] * width  # (n, d) into a (d * width) histogram

    target = y.astype(np.float64)
    share = min(max(target.mean(), 1e-6), 1 - 1e-6)
    base = math.log(share / (1 - share))
    raw = np.full(n, base)
    raw_tune = np.full(len(tune[0]), base) if tune is not None else np.zeros(0)
    best_loss = _log_loss(raw_tune, tune[1]) if tune is not None else math.inf
    kept = 0
    feats = np.zeros((trees, depth), dtype=np.int64)
    thresholds = np.zeros((trees, depth))
    leaves = np.zeros((trees, 1 << depth))
    for t in range(trees):
        p = sigmoid(raw)
        g, h = p - target, np.maximum(p * (1 - p), 1e-12)
        g_each, h_each = np.repeat(g, d), np.repeat(h, d)  # one weight per (row, column)
        node = np.zeros(n, dtype=np.int64)
        for level in range(depth):
            nodes = 1 << level
            index = (node[:, None] * (d * width) + flat).ravel()
            size = nodes * d * width
            gh = np.bincount(index, g_each, minlength=size).reshape(nodes, d, width)
            hh = np.bincount(index, h_each, minlength=size).reshape(nodes, d, width)
            gl, hl = np.cumsum(gh, axis=2), np.cumsum(hh, axis=2)
            gt, ht = gl[:, :, -1:], hl[:, :, -1:]
            gain = (gl**2 / (hl + l2) + (gt - gl) ** 2 / (ht - hl + l2)).sum(axis=0)
            gain = np.where(valid, gain, -np.inf)
            if np.isfinite(gain).any():
                j, k = (int(i) for i in np.unravel_index(int(np.argmax(gain)), gain.shape))
                threshold = float(cuts[j][k])
            else:  # every column constant: a split that sends every row left
                j, threshold = 0, float(x[:, 0].max())
            feats[t, level], thresholds[t, level] = j, threshold
            node = 2 * node + (x[:, j] > threshold)
        gs = np.bincount(node, g, minlength=1 << depth)
        hs = np.bincount(node, h, minlength=1 << depth)
        leaves[t] = -learning_rate * gs / (hs + l2)
        raw += leaves[t, node]
        if tune is not None:
            one = Trees(feats[t : t + 1], thresholds[t : t + 1], leaves[t : t + 1], 0.0)
            raw_tune += one.raw(tune[0])
            loss = _log_loss(raw_tune, tune[1])
            if loss < best_loss:
                best_loss, kept = loss, t + 1
        else:
            kept = t + 1
    return Trees(feats[:kept].copy(), thresholds[:kept].copy(), leaves[:kept].copy(), base, d)
