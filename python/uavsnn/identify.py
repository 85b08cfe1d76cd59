"""Identification: after the any-spike rule finds a moving object, is it a UAV? (SPEC §3)

Each object of a window is described by :data:`FEATURES` (rotor, shape, activity and track;
:mod:`uavsnn.features`, whose names this module re-exports). A light model on standardised
features gives each object a UAV score in ``[0, 1]``; a window's score is its objects' largest
(0 without one). The model is a logistic regression (:func:`fit_logistic`: Newton's method
with an L2 penalty, in NumPy) or boosted oblivious trees (:func:`uavsnn.trees.fit_trees`),
whichever ranks the tuning objects better (:func:`fit`'s ``model``).

A class guess comes beside the score (:meth:`Identifier.guess`): ``"uav"`` where the score
reaches the threshold, else the most probable of the other classes the training windows name
(``"bird"``, ``"insect"``, ``"ball"``, ``"airplane"``, ``"helicopter"``, ``"leaf"``...; an object
of a window without a labelled object is ``"clutter"``) under a multinomial logistic regression
on the same features (:func:`fit_softmax`; classes weighted equally, so that a rare class is not
drowned by the common ones). Without that part (a model of version 1) the guess is ``"other"``.

The model (:class:`Identifier`, :mod:`uavsnn.identifier`, re-exported here) is stored in the
model file beside the network as plain arrays
(``identify.version``, ``identify.coef``, ``identify.mean``, ``identify.scale``,
``identify.features``, ``identify.threshold``, ``identify.l2``, and from version 2
``identify.classes``, ``identify.class_coef``, ``identify.class_l2``, and when tuned on windows
``identify.alarm_rates`` and ``identify.alarm_thresholds``, when tuned on streamed recording
``identify.track_alarm_rates``, ``identify.track_alarm_thresholds``,
``identify.track_alarm_minutes`` and ``identify.track_alarm_confirm``; version 3 adds the
trees, ``identify.tree_feature``, ``identify.tree_threshold``, ``identify.tree_leaf`` and
``identify.tree_base``; and ``identify.gate_px``, the tracker gate the track features were
built with, when recorded; no pickle), see :meth:`uavsnn.network.Network.save`.

::

    ident = identify.fit(train_features, tune_features)     # WindowFeatures of two datasets
    scores = ident.window_scores(identify.window_features(network, test))
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from uavsnn._validate import check_bools, check_numbers, check_real
from uavsnn.errors import DatasetError, ParameterError, ShapeError
from uavsnn.features import (
    CLUTTER_CLASS,
    FEATURES,
    MAX_MEASURED_WINDOW_US,
    RATE_BIN_US,
    TRACK_ACTIVITY,
    TRACK_FEATURES,
    UAV_CLASS,
    WindowFeatures,
    activity,
    object_features,
    rate_bins,
    rate_swing,
    raw_noise_events,
    track_features,
    window_features,
    window_steps,
)
from uavsnn.identifier import VERSION, Identifier
from uavsnn.linear import (
    fit_logistic,
    fit_softmax,
    labelled,
    predict_logistic,
    predict_softmax,
    sigmoid,
)
from uavsnn.track_eval import Confirm
from uavsnn.trees import Trees, fit_trees

if TYPE_CHECKING:
    from uavsnn.dataset import LabelledWindows
    from uavsnn.network import Network

__all__ = [
    "CLUTTER_CLASS",
    "FEATURES",
    "GROUPS",
    "MAX_MEASURED_WINDOW_US",
    "MIN_CLASS_OBJECTS",
    "MODELS",
    "RATE_BIN_US",
    "THRESHOLD_WITHIN",
    "TRACK_ACTIVITY",
    "TRACK_FEATURES",
    "TREE_COUNT",
    "TREE_GRID",
    "TREE_RATE",
    "UAV_CLASS",
    "VERSION",
    "Identifier",
    "WindowFeatures",
    "ablation",
    "activity",
    "alarm_note",
    "alarm_threshold",
    "best_threshold",
    "class_figures",
    "feature_auc",
    "fit",
    "fit_logistic",
    "fit_network",
    "fit_score",
    "fit_softmax",
    "fit_tree_score",
    "labelled",
    "missing_classes",
    "model_name",
    "object_features",
    "predict_logistic",
    "predict_softmax",
    "rate_bins",
    "rate_swing",
    "raw_noise_events",
    "rotor_coverage",
    "sigmoid",
    "split_by_recording",
    "threshold_accuracies",
    "track_features",
    "window_features",
    "window_steps",
]

#: The UAV score models :func:`fit` may choose (its ``model``; ``"auto"``: the one whose scores
#: rank the tuning objects better, by their ROC area).
MODELS = ("auto", "logistic", "trees")

#: The tree settings :func:`fit` tries (``(depth, l2)``; each with up to :data:`TREE_COUNT`
#: trees at a learning rate of :data:`TREE_RATE`, the count chosen on the tuning objects).
TREE_GRID: tuple[tuple[int, float], ...] = ((2, 1.0), (3, 1.0), (4, 1.0))
TREE_COUNT = 300
TREE_RATE = 0.1

#: Feature groups of the ablation.
GROUPS: dict[str, tuple[str, ...]] = {
    "rotor": FEATURES[:4],
    "shape": FEATURES[4:9],
    "track": TRACK_FEATURES,
    "no_track": tuple(f for f in FEATURES if f not in TRACK_FEATURES),
    "no_activity_history": tuple(f for f in FEATURES if f not in TRACK_ACTIVITY),
    "all": FEATURES,
}

_L2_GRID = (1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0)

#: What :func:`fit_network`'s summary says it was tuned on (its ``"tune"``).
HELD_OUT_TUNING = "held-out training recordings"
SEPARATE_TUNING = "a separate tuning set"


def _standardise(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    mean = x.mean(axis=0)
    scale = x.std(axis=0)
    return mean, np.where(scale > 1e-12, scale, 1.0)


def _log_loss(p: np.ndarray, y: np.ndarray) -> float:
    p = np.clip(p, 1e-12, 1 - 1e-12)
    return float(-np.mean(np.where(y, np.log(p), np.log(1 - p))))


def fit(
    train: WindowFeatures,
    tune: WindowFeatures,
    *,
    tune_detected: np.ndarray | None = None,
    tune_label: np.ndarray | None = None,
    features: Sequence[str] = FEATURES,
    l2_grid: Sequence[float] = _L2_GRID,
    classes: bool = True,
    model: str = "auto",
) -> Identifier:
    """Fit an :class:`Identifier` on ``train``'s usable objects; choose the L2 weight (the
    smallest log loss on ``tune``'s usable objects); with ``model`` ``"trees"`` or ``"auto"``
    also fit boosted trees (:func:`fit_tree_score`), kept with ``"trees"`` and with
    ``"auto"`` when they keep at least one tree and their scores have the larger ROC area on
    ``tune``'s usable objects (a ranking, not a calibration: every threshold is set on the
    tuning windows afterwards); and, when
    ``tune_detected`` (the any-spike rule's calls) and ``tune_label`` (the windows' truth) are
    given, the threshold on the window score of :func:`best_threshold`: the highest whose
    balanced accuracy on ``tune`` is the best (within :data:`THRESHOLD_WITHIN`; the mean of
    the combined rule's accuracy on UAV and on UAV-free windows, so that the tuning set's share
    of UAV windows, which is not the test set's, does not move it; else 0.5), and the
    thresholds at
    which at most :data:`uavsnn.evaluation.FALSE_ALARM_RATES` of ``tune``'s UAV-free windows
    alarm (:attr:`Identifier.alarm_thresholds`).
    ``tune`` must come from other recordings than ``train`` and never from the test set.
    ``"auto"`` keeps the logistic score, without fitting trees, when ``tune``'s usable objects
    lack a class ``train``'s name (:func:`missing_classes`): a tuning set cannot judge how a
    model scores a class it does not hold, and the trees extrapolate to an unseen class worse
    than the logistic score (measured at 640×480, docs/identification.md).

    With ``classes`` (and objects of at least two classes in ``train``'s ``cls``, each class
    with :data:`MIN_CLASS_OBJECTS` or more), also the class model of the class guess
    (:func:`fit_softmax` on the same standardised features, each class weighted by the inverse
    of its share so that every class weighs the same; the L2 weight with the smallest weighted
    log loss on ``tune``'s objects of those classes).

    The model records the tracker gate ``train``'s track features were built with
    (:attr:`Identifier.gate_px` from :attr:`WindowFeatures.gate_px`), which ``tune``'s must
    share.

    Raises:
        DatasetError: too few objects of either kind to fit, or ``"trees"`` without usable
            tuning objects (their count is chosen on them).
        ParameterError: ``model`` not one of :data:`MODELS`, ``train`` and ``tune`` built
            with two tracker gates, ``features`` naming one not in :data:`FEATURES`,
            ``tune_detected`` or ``tune_label`` not boolean, or as :func:`fit_score`.
        ShapeError: ``tune_detected`` or ``tune_label`` not one flag a window of ``tune``.
    """
    if model not in MODELS:
        raise ParameterError(f"model must be one of {MODELS}, got {model!r}")
    names = tuple(features)
    unknown = [f for f in names if f not in FEATURES]
    if unknown:
        raise ParameterError(f"features must be names of FEATURES, got unknown {unknown}")
    l2_grid = tuple(l2_grid)  # read twice: by fit_score and by the class model
    tuning = None
    if tune_detected is not None and tune_label is not None:
        tuning = check_bools("tune_detected", tune_detected), check_bools("tune_label", tune_label)
        if tuning[0].shape != (tune.windows,) or tuning[1].shape != (tune.windows,):
            raise ShapeError(
                f"tune_detected and tune_label must hold one flag a window of tune "
                f"({tune.windows}), got {len(tuning[0])} and {len(tuning[1])}"
            )
    gates = (train.gate_px, tune.gate_px)
    if gates[0] is not None and gates[1] is not None and gates[0] != gates[1]:
        raise ParameterError(
            f"the training features were tracked with a {gates[0]:g} px gate, the tuning "
            f"features with {gates[1]:g} px: a model is fitted and tuned at one gate"
        )
    tr, tu = train.columns(names), tune.columns(names)
    xs, ys = tr.x[tr.usable], tr.label[tr.usable]
    if ys.sum() < 2 or (~ys).sum() < 2:
        raise DatasetError(
            f"identification needs at least 2 UAV and 2 other objects to fit, got "
            f"{int(ys.sum())} and {int((~ys).sum())}"
        )
    xt, yt = tu.x[tu.usable], tu.label[tu.usable]
    mean, scale, coef, l2 = fit_score(xs, ys, xt, yt, l2_grid)
    trees = None
    if model == "trees" and len(yt) == 0:
        raise DatasetError("boosted trees need usable tuning objects to choose their count")
    if model == "auto" and missing_classes(tr, tu):
        model = "logistic"
    if model != "logistic" and len(yt):
        zt = (xt - mean) / scale
        trees, _ = fit_tree_score((xs - mean) / scale, ys, zt, yt)
        if model == "auto" and not _ranks_better(trees, coef, zt, yt):
            trees = None
    ident = Identifier(names, coef, mean, scale, 0.5, l2, trees=trees, gate_px=train.gate_px)
    if tuning is not None:
        from uavsnn.evaluation import FALSE_ALARM_RATES

        detected, label = tuning
        score = np.where(detected, ident.window_scores(tune), -1.0)
        alarms: tuple[tuple[float, float], ...] = ()
        if (~label).any():
            alarms = tuple(
                (rate, alarm_threshold(score, label, rate)) for rate in FALSE_ALARM_RATES
            )
        ident = replace(ident, threshold=best_threshold(score, label), alarm_thresholds=alarms)
    if classes:
        found = _fit_classes(tr, tu, mean, scale, l2_grid)
        if found is not None:
            ident = replace(ident, classes=found[0], class_coef=found[1], class_l2=found[2])
    return ident


def missing_classes(train: WindowFeatures, tune: WindowFeatures) -> tuple[str, ...]:
    """The classes of other objects (``cls``, UAV and unnamed objects aside) that at least
    :data:`MIN_CLASS_OBJECTS` of ``train``'s usable objects have and none of ``tune``'s usable
    objects has, sorted: what a tuning set cannot judge. Empty when either has no classes."""
    if len(train.cls) != len(train.x) or len(tune.cls) != len(tune.x):
        return ()
    names, counts = np.unique(train.cls[train.usable], return_counts=True)
    have = set(tune.cls[tune.usable].tolist())
    return tuple(
        str(c)
        for c, m in zip(names, counts, strict=True)
        if c not in ("", UAV_CLASS) and m >= MIN_CLASS_OBJECTS and c not in have
    )


def fit_score(
    x: np.ndarray,
    y: np.ndarray,
    x_tune: np.ndarray,
    y_tune: np.ndarray,
    l2_grid: Sequence[float] = _L2_GRID,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The UAV score's fit of :func:`fit` on plain arrays: the features ``x`` ``(m, d)`` are
    standardised (their mean and scale), a logistic regression (:func:`fit_logistic`) is fitted
    to ``y`` for each L2 weight of ``l2_grid``, and the one with the smallest log loss on
    ``(x_tune, y_tune)`` is kept. Returns ``(mean, scale, coef, l2)``.

    Raises:
        ShapeError: ``x`` not ``(m, d)`` with ``y`` ``(m,)``, or ``x_tune`` not ``(n, d)``
            with ``y_tune`` ``(n,)``.
        ParameterError: ``x`` without a row, features that are not finite numbers, labels
            that are not boolean, or ``l2_grid`` empty or holding other than numbers >= 0.
    """
    x, y = labelled(check_numbers("x", x), y)
    if len(x) == 0:
        raise ParameterError("x must hold at least one row")
    xt, yt = check_numbers("x_tune", x_tune), check_bools("y_tune", y_tune)
    if xt.ndim != 2 or xt.shape[1] != x.shape[1] or len(xt) != len(yt):
        raise ShapeError(
            f"x_tune must be (n, {x.shape[1]}) and y_tune (n,), got {xt.shape} and {yt.shape}"
        )
    if not np.isfinite(xt).all():
        raise ParameterError("x_tune holds NaN or infinite values")
    grid = [check_real("an L2 weight of l2_grid", l2, low=0.0) for l2 in l2_grid]
    if not grid:
        raise ParameterError("l2_grid must hold at least one L2 weight, got none")
    mean, scale = _standardise(x)
    z = (x - mean) / scale
    zt = (xt - mean) / scale
    best = None
    for l2 in grid:
        coef = fit_logistic(z, y, l2=l2)
        loss = _log_loss(predict_logistic(coef, zt), yt) if len(yt) else 0.0
        if best is None or loss < best[0]:
            best = (loss, l2, coef)
    assert best is not None
    return mean, scale, best[2], best[1]


def _ranks_better(trees: Trees, coef: np.ndarray, z: np.ndarray, y: np.ndarray) -> bool:
    """Whether ``trees`` (at least one) rank the objects ``z`` by ``y`` better than the
    logistic fit ``coef``: the larger ROC area (:func:`uavsnn.evaluation.roc_area`)."""
    from uavsnn.evaluation import roc_area

    if len(trees.feature) == 0:
        return False
    area_trees, area_logistic = (
        roc_area(trees.predict(z), y),
        roc_area(predict_logistic(coef, z), y),
    )
    return area_trees is not None and area_logistic is not None and area_trees > area_logistic


def fit_tree_score(
    z: np.ndarray,
    y: np.ndarray,
    z_tune: np.ndarray,
    y_tune: np.ndarray,
    grid: Sequence[tuple[int, float]] = TREE_GRID,
) -> tuple[Trees, float]:
    """Boosted trees for the UAV score on standardised features ``z`` and labels ``y``: for
    each ``(depth, l2)`` of ``grid``, up to :data:`TREE_COUNT` trees at :data:`TREE_RATE`, as
    many kept as give the smallest log loss on ``(z_tune, y_tune)``; returns the setting with
    the smallest such loss and that loss."""
    best: tuple[float, Trees] | None = None
    for depth, l2 in grid:
        model = fit_trees(
            z,
            y,
            x_tune=z_tune,
            y_tune=y_tune,
            depth=depth,
            trees=TREE_COUNT,
            learning_rate=TREE_RATE,
            l2=l2,
        )
        loss = _log_loss(model.predict(z_tune), np.asarray(y_tune, bool))
        if best is None or loss < best[0]:
            best = (loss, model)
    if best is None:
        raise ParameterError("the tree grid is empty")
    return best[1], best[0]


def alarm_threshold(score: npt.ArrayLike, label: npt.ArrayLike, rate: float) -> float:
    """The operating point of :func:`fit` on window scores (``score``; -1 for windows the
    any-spike rule does not call UAV): the threshold at which at most ``rate`` of the UAV-free
    windows of ``label`` alarm. A window the rule misses never alarms; where the share would
    need more windows than the rule calls, the point is 0.0 and every detection alarms."""
    from uavsnn.evaluation import threshold_at_false_alarm

    return max(threshold_at_false_alarm(score, label, rate), 0.0)


def alarm_note(
    tune_label: np.ndarray, alarm_thresholds: Sequence[tuple[float, float]]
) -> str | None:
    """Why the operating points :func:`fit` set on tuning windows of truth ``tune_label``
    (its :attr:`Identifier.alarm_thresholds`) are missing or do not measure their shares, in
    one sentence; ``None`` when they do. None is set without a UAV-free tuning window. A share
    ``r`` of ``n`` UAV-free windows allows one of them to alarm only when ``n × r ≥ 1`` (100
    windows for 1 %, 20 for 5 %); with fewer the point is the threshold at which none of them
    alarms, which says nothing of ``r``: the point is kept (it is the strictest the windows
    allow) and the note says so.

    Raises:
        ParameterError, ShapeError: ``tune_label`` not a 1-D boolean array.
    """
    label = check_bools("tune_label", tune_label)
    free = int((~label).sum())
    if free == 0:
        return (
            f"the {label.size} tuning windows hold no UAV-free window: no false-alarm point is "
            "set (`uavsnn detect --false-alarm` has none to take) and the threshold was chosen "
            "on UAV windows alone; tune on a set with UAV-free windows (`uavsnn dataset build "
            "TUNE --seed OTHER --stratify`, then --tune TUNE)"
        )
    thin = [
        (rate, math.ceil(1 / rate - 1e-9)) for rate, _ in alarm_thresholds if free * rate < 1 - 1e-9
    ]
    if not thin:
        return None
    shares = " and ".join(f"{100 * rate:g} %" for rate, _ in thin)
    needs = " and ".join(str(need) for _, need in thin)
    one = len(thin) == 1
    return (
        f"the tuning windows hold {free} UAV-free window{'' if free == 1 else 's'}, fewer "
        f"than the {needs} that {shares} false alarms need for one of "
        f"them to alarm: at {'that point' if one else 'those points'} none alarms, which "
        f"does not measure {'the share' if one else 'those shares'} (`uavsnn detect "
        "--false-alarm` may alarm more often there); tune on more UAV-free windows"
    )


def threshold_accuracies(
    score: npt.ArrayLike, label: npt.ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """The thresholds :func:`best_threshold` chooses among (0.5 and each non-negative score,
    ascending) and the balanced accuracy against ``label`` of calling UAV the windows whose
    ``score`` reaches each.

    Raises:
        ShapeError, ParameterError: as :func:`uavsnn.roc.check_scores` (NaN scores), or
            ``label`` not a 1-D boolean array.
    """
    from uavsnn.roc import check_scores

    score, label = check_scores(score, check_bools("label", label))
    candidates = np.unique(np.concatenate([[0.5], score[score >= 0]]))
    acc = np.array([_balanced_accuracy(score >= c, label) for c in candidates])
    return candidates, acc


#: How far below the best balanced accuracy on the tuning windows a threshold may fall and still
#: count as one of the best (:func:`best_threshold`): none, so the threshold is the highest of
#: the best. The tuning set's balanced accuracy is flat near its best (within a point over a
#: span of 0.3 in the score), but a point was not free elsewhere: on the test sets of six other
#: seeds the combined network's accuracy fell 1.2 points with it (docs/identification.md, "The
#: tuned threshold on six draws"). Fewer false alarms are the operating points' to give
#: (:attr:`Identifier.alarm_thresholds`).
THRESHOLD_WITHIN = 0.0


def best_threshold(
    score: npt.ArrayLike, label: npt.ArrayLike, within: float = THRESHOLD_WITHIN
) -> float:
    """The threshold of :func:`fit` on window scores (``score``; negative for windows the
    any-spike rule does not call UAV): of the candidates of :func:`threshold_accuracies` (0.5
    and each non-negative score) whose balanced accuracy against ``label`` is within
    ``within`` of the best, the highest — the one that raises the fewest false alarms among
    those the tuning windows cannot tell apart (``within`` 0: the highest of the best); 0.5
    for no windows.

    Raises:
        ParameterError: ``within`` not a number in [0, 1), NaN scores, or labels that are not
            boolean.
        ShapeError: not one score and one label a window.
    """
    within = check_real("within", within)
    if not 0 <= within < 1:
        raise ParameterError(f"within must be in [0, 1), got {within!r}")
    if np.asarray(label).size == 0 and np.asarray(score).size == 0:
        return 0.5
    candidates, acc = threshold_accuracies(score, label)
    return float(candidates[acc >= acc.max() - within].max())


#: Objects a class needs in the training windows to enter the class model.
MIN_CLASS_OBJECTS = 5


def _balanced_weights(y: np.ndarray, k: int) -> np.ndarray:
    counts = np.bincount(y, minlength=k).astype(np.float64)
    return (len(y) / (k * np.maximum(counts, 1)))[y]


def _fit_classes(
    train: WindowFeatures,
    tune: WindowFeatures,
    mean: np.ndarray,
    scale: np.ndarray,
    l2_grid: Sequence[float],
) -> tuple[tuple[str, ...], np.ndarray, float] | None:
    """The class model of :func:`fit`: ``(classes, coef, l2)``, or ``None`` when ``train``
    names fewer than two classes with :data:`MIN_CLASS_OBJECTS` objects each."""
    if len(train.cls) != len(train.x):
        return None
    names, counts = np.unique(train.cls[train.cls != ""], return_counts=True)
    kept = [str(c) for c, m in zip(names, counts, strict=True) if m >= MIN_CLASS_OBJECTS]
    kept.sort(key=lambda c: (c != UAV_CLASS, c))
    if len(kept) < 2:
        return None
    index = {c: i for i, c in enumerate(kept)}
    k = len(kept)

    def part(feats: WindowFeatures) -> tuple[np.ndarray, np.ndarray]:
        if len(feats.cls) != len(feats.x):
            return np.zeros((0, feats.x.shape[1])), np.zeros(0, dtype=np.int64)
        rows = np.isin(feats.cls, kept)
        y = np.array([index[str(c)] for c in feats.cls[rows]], dtype=np.int64)
        return (feats.x[rows] - mean) / scale, y

    z, y = part(train)
    zt, yt = part(tune)
    weights, tune_weights = _balanced_weights(y, k), _balanced_weights(yt, k)
    best = None
    for l2 in l2_grid:
        coef = fit_softmax(z, y, k, l2=float(l2), weights=weights)
        loss = 0.0
        if len(yt):
            p = np.clip(predict_softmax(coef, zt)[np.arange(len(yt)), yt], 1e-12, 1.0)
            loss = float(-np.sum(tune_weights * np.log(p)) / tune_weights.sum())
        if best is None or loss < best[0]:
            best = (loss, float(l2), coef)
    assert best is not None
    return tuple(kept), best[2], best[1]


def class_figures(ident: Identifier, feats: WindowFeatures) -> dict[str, Any]:
    """How the class guess (:meth:`Identifier.guess`) fares on the objects of ``feats`` whose
    class is known (``feats.cls``): ``confusion`` (true class -> guess -> objects), per true
    class its objects and the share guessed right (``recall``), the share of all of them
    guessed right (``accuracy``) and the mean of the per-class shares over the classes the
    model knows (``balanced_accuracy``); ``classes``: the model's classes (empty without a
    class model: every guess is then ``"uav"`` or ``"other"``)."""
    labelled = len(feats.cls) == len(feats.x)
    known = feats.cls != "" if labelled else np.zeros(len(feats.x), bool)
    truth = [str(c) for c in feats.cls[known]] if labelled else []
    guesses = ident.guess(feats.x[known]) if truth else []
    confusion: dict[str, dict[str, int]] = {}
    for t, g in zip(truth, guesses, strict=True):
        row = confusion.setdefault(t, {})
        row[g] = row.get(g, 0) + 1
    per_class = {
        t: {"objects": sum(row.values()), "recall": row.get(t, 0) / sum(row.values())}
        for t, row in sorted(confusion.items())
    }
    modelled = [v["recall"] for c, v in per_class.items() if c in ident.classes]
    right = sum(row.get(t, 0) for t, row in confusion.items())
    return {
        "classes": list(ident.classes),
        "objects": len(truth),
        "accuracy": right / len(truth) if truth else None,
        "balanced_accuracy": float(np.mean(modelled)) if modelled else None,
        "per_class": per_class,
        "confusion": {t: dict(sorted(row.items())) for t, row in sorted(confusion.items())},
    }


def _balanced_accuracy(pred: np.ndarray, label: np.ndarray) -> float:
    """The mean of the accuracy on the positives and on the negatives (plain accuracy when
    ``label`` holds one kind only)."""
    kinds = [k for k in (label, ~label) if k.any()]
    return float(np.mean([np.mean(pred[k] == label[k]) for k in kinds]))


def ablation(
    train: WindowFeatures,
    tune: WindowFeatures,
    test: WindowFeatures,
    *,
    tune_detected: np.ndarray,
    tune_label: np.ndarray,
    test_detected: np.ndarray,
    test_label: np.ndarray,
    test_data: LabelledWindows | None = None,
    track_score: str = "mean",
    confirm: Confirm | None = None,
    model: str = "auto",
) -> dict[str, dict[str, Any]]:
    """For each feature group of :data:`GROUPS` (rotor alone, shape alone, track alone, all
    but the track, all), a model fitted as :func:`fit` does (train, then tune) and scored on
    ``test``: the combined rule's accuracy at the tuned threshold and its detection rate where
    1 % and 5 % of the UAV-free test windows alarm. With ``test_data`` (the windows ``test``
    was made from), each row also holds ``tracks``: the track-level figures of the rule with
    identification (:func:`uavsnn.track_eval.identified_track_figures` with ``track_score`` and
    ``confirm``, as the main figures use them). ``model``: :func:`fit`'s."""
    from uavsnn.evaluation import FALSE_ALARM_RATES, detection_at_false_alarm
    from uavsnn.track_eval import identified_track_figures

    label = np.asarray(test_label, dtype=bool)
    out = {}
    for name, names in GROUPS.items():
        ident = fit(
            train,
            tune,
            tune_detected=tune_detected,
            tune_label=tune_label,
            features=names,
            classes=False,
            model=model,
        )
        score = ident.combined_scores(test, test_detected)
        row: dict[str, Any] = {
            "features": len(names),
            "l2": ident.l2,
            "threshold": ident.threshold,
            "accuracy": float(np.mean((score >= ident.threshold) == label)),
        }
        for rate in FALSE_ALARM_RATES:
            row[f"detection_at_{rate:g}"] = detection_at_false_alarm(score, label, rate)
        if test_data is not None:
            figures = identified_track_figures(
                test_data,
                test,
                ident,
                track_score=track_score,
                confirm=confirm,
                operating_points=False,
            )
            row["tracks"] = figures["rules"]["identified"]
        out[name] = row
    return out


def feature_auc(feats: WindowFeatures) -> dict[str, float | None]:
    """How well each feature of :data:`FEATURES` alone tells the usable UAV objects of
    ``feats`` from the others: the area under its ROC (the Mann-Whitney statistic, ties
    counted half). 0.5: no separation; above: UAV objects have the larger values; below: the
    smaller. ``None`` without objects of both kinds. A feature whose area lies on opposite
    sides of 0.5 on two sets tells them apart in opposite directions."""
    from uavsnn.evaluation import roc_area

    x, y = feats.x[feats.usable], np.asarray(feats.label[feats.usable], dtype=bool)
    return {name: roc_area(x[:, i], y) for i, name in enumerate(FEATURES)}


def split_by_recording(
    data: LabelledWindows, every: int = 4
) -> tuple[LabelledWindows, LabelledWindows]:
    """Split ``data`` by recording: every ``every``-th of its recordings (sorted by id) goes to
    the second part (a tuning set), the rest to the first."""
    ids = np.unique(data.recording)
    held = np.isin(data.recording, ids[::every][: max(1, len(ids) // every)])
    if held.all() or not held.any():
        raise DatasetError(f"cannot hold out recordings from {len(ids)} recording(s)")
    return data.select(np.flatnonzero(~held)), data.select(np.flatnonzero(held))


def fit_network(
    network: Network,
    train: LabelledWindows,
    tune: LabelledWindows | None = None,
    *,
    model: str = "auto",
) -> tuple[Identifier, dict[str, Any]]:
    """Fit ``network``'s identification on ``train`` (a training split), tuned on ``tune``
    (windows of other recordings; default: a quarter of ``train``'s recordings held out, see
    :func:`split_by_recording`), with :func:`fit`'s ``model``. The track features are built
    with the tracker of ``network``'s sensor (:meth:`uavsnn.tracks.Tracker.for_sensor`, whatever
    gate an identification it already has records), and the model records that gate. Returns
    the model and a summary; does not attach it."""
    from uavsnn.tracks import Tracker

    held_out = tune is None
    if tune is None:
        train, tune = split_by_recording(train)
    tracker = Tracker.for_sensor(int(network.config["width"]))
    tune_inference = network.infer(tune.windows)
    train_feats = window_features(network, train, tracker=tracker)
    tune_feats = window_features(network, tune, tune_inference, tracker=tracker)
    fitted = fit(
        train_feats,
        tune_feats,
        tune_detected=tune_inference.detected,
        tune_label=np.asarray(tune.label, dtype=bool),
        model=model,
    )
    # The classes of the training windows' labelled objects the class guess cannot give:
    # fewer than MIN_CLASS_OBJECTS of their objects were detected and met their box.
    named = {
        UAV_CLASS if uav else str(c)
        for c, uav in zip(train.cls.tolist(), train.label.tolist(), strict=True)
        if str(c) not in ("", "none")
    }
    summary = {
        "train_windows": len(train),
        "tune_windows": len(tune),
        "classes": list(fitted.classes),
        "classes_left_out": sorted(named - set(fitted.classes)),
        "tune": HELD_OUT_TUNING if held_out else SEPARATE_TUNING,
        "tune_lacks": list(missing_classes(train_feats, tune_feats)),
        "model": model_name(fitted),
        "l2": fitted.l2,
        "threshold": fitted.threshold,
        "alarm_thresholds": [list(pair) for pair in fitted.alarm_thresholds],
        "alarm_note": alarm_note(np.asarray(tune.label, dtype=bool), fitted.alarm_thresholds),
        "features": list(fitted.features),
        "gate_px": fitted.gate_px,
    }
    return fitted, summary


def model_name(ident: Identifier) -> str:
    """What gives ``ident``'s UAV score, in words: ``"logistic"`` or ``"trees (T of depth
    D)"``."""
    if ident.trees is None:
        return "logistic"
    count, depth = ident.trees.feature.shape
    return f"trees ({count} of depth {depth})"


def rotor_coverage(feats: WindowFeatures, data: LabelledWindows) -> list[dict[str, Any]]:
    """What the rotor cue can reach, by the UAV's size (``data.size_px``, bins of
    :data:`uavsnn.evaluation.SIZE_BINS_PX`): UAV windows, those with an object meeting the
    labelled box (the any-spike rule found it there), those where such an object's rotor
    estimate had any vote, and those where it passed the rotor detection rule."""
    import itertools

    from uavsnn.evaluation import SIZE_BINS_PX

    uav = np.asarray(data.label, dtype=bool)
    hz = feats.x[:, FEATURES.index("rotor_log_hz")] > 0
    found = feats.x[:, FEATURES.index("rotor_detected")] == 1
    n = len(data)
    met, voted, rotor = (np.zeros(n, bool) for _ in range(3))
    met[feats.window[feats.label]] = True
    voted[feats.window[feats.label & hz]] = True
    rotor[feats.window[feats.label & found]] = True
    size = np.asarray(data.size_px, dtype=np.float64)
    out = []
    for low, high in itertools.pairwise(SIZE_BINS_PX):
        inside = uav & np.isfinite(size) & (size >= low) & (size < high)
        if inside.any():
            out.append(
                {
                    "low_px": float(low),
                    "high_px": None if np.isinf(high) else float(high),
                    "uav_windows": int(inside.sum()),
                    "object_on_uav": int(met[inside].sum()),
                    "rotor_votes": int(voted[inside].sum()),
                    "rotor_detected": int(rotor[inside].sum()),
                }
            )
    return out
