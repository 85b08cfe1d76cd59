"""Operating points of a score against labels: its ROC, the threshold where a share of the
UAV-free windows alarm, the detection there, and how well such figures are known when the
test recordings are drawn again (percentile bootstraps over recordings, not windows: windows
of one recording alarm together).

The figures :mod:`uavsnn.evaluation` reports are read with these; it re-exports each name.

    >>> threshold = threshold_at_false_alarm(scores, actual, 0.01)
    >>> lo, hi = roc_point_interval(scores, actual, recording, 0.01)
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from uavsnn._validate import check_bools, check_int, check_numbers, check_real
from uavsnn.errors import DatasetError, ParameterError, ShapeError

__all__ = [
    "INTERVAL_RESAMPLES",
    "check_scores",
    "detection_at_false_alarm",
    "recording_interval",
    "roc_area",
    "roc_curve",
    "roc_point_draws",
    "roc_point_interval",
    "threshold_at_false_alarm",
]


def check_scores(scores: npt.ArrayLike, actual: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """``scores`` as float64 and ``actual`` as bool, one of each a window.

    Raises:
        ShapeError: not one of each a window.
        ParameterError: NaN scores (``-inf``, never an alarm, is a score), scores that are not
            numbers or ``actual`` not boolean.
    """
    s = check_numbers("scores", scores)
    a = check_bools("actual", actual)
    if s.shape != a.shape or s.ndim != 1:
        raise ShapeError(f"scores and actual must be one a window: got {s.shape} and {a.shape}")
    if np.isnan(s).any():
        raise ParameterError("scores hold NaN")
    return s, a


def roc_curve(scores: npt.ArrayLike, actual: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """The ROC of a score (higher: more UAV-like; ``-inf``: never an alarm): false-alarm rates
    and detection rates (float64), from the strictest threshold to the loosest, starting at
    ``(0, 0)`` and ending where every window with a finite score alarms."""
    s, a = check_scores(scores, actual)
    pos, neg = int(a.sum()), int((~a).sum())
    if pos == 0 or neg == 0:
        raise DatasetError("a ROC needs UAV and UAV-free windows")
    finite = np.isfinite(s)
    levels = np.unique(s[finite])[::-1]
    tp = np.array([np.sum(a & finite & (s >= t)) for t in levels], dtype=np.float64)
    fp = np.array([np.sum(~a & finite & (s >= t)) for t in levels], dtype=np.float64)
    return np.concatenate([[0.0], fp / neg]), np.concatenate([[0.0], tp / pos])


def roc_area(scores: npt.ArrayLike, actual: npt.ArrayLike) -> float | None:
    """The area under the ROC of ``scores`` against ``actual``: the Mann-Whitney statistic, the
    chance that a UAV scores above a UAV-free one, ties counted half. ``None`` without both
    kinds."""
    s, a = check_scores(scores, actual)
    pos, neg = int(a.sum()), int((~a).sum())
    if pos == 0 or neg == 0:
        return None
    _, inverse, counts = np.unique(s, return_inverse=True, return_counts=True)
    # Mid-ranks: the values' ranks, a tie sharing the mean of its ranks.
    ranks = (np.cumsum(counts) - (counts - 1) / 2)[inverse.ravel()]
    return float((ranks[a].sum() - pos * (pos + 1) / 2) / (pos * neg))


def detection_at_false_alarm(scores: npt.ArrayLike, actual: npt.ArrayLike, rate: float) -> float:
    """The share of the UAV windows scoring at or above :func:`threshold_at_false_alarm`."""
    s, a = check_scores(scores, actual)
    return float(np.mean(s[a] >= threshold_at_false_alarm(s, a, rate)))


def threshold_at_false_alarm(scores: npt.ArrayLike, actual: npt.ArrayLike, rate: float) -> float:
    """The lowest threshold at which at most ``rate`` of the UAV-free windows score at or above
    it (windows scoring ``-inf`` never alarm).

    Raises:
        ShapeError, ParameterError: as :func:`check_scores`; ``rate`` outside [0, 1].
        DatasetError: no UAV-free window.
    """
    rate = check_real("rate", rate)
    if not 0 <= rate <= 1:
        raise ParameterError(f"rate must be in [0, 1], got {rate}")
    s, a = check_scores(scores, actual)
    neg = np.sort(s[~a])[::-1]
    if len(neg) == 0:
        raise DatasetError("no UAV-free windows to set a false-alarm rate on")
    k = int(np.floor(rate * len(neg) + 1e-9))
    if k >= len(neg):
        return float(np.nextafter(-np.inf, 0))
    return float(np.nextafter(neg[k], np.inf))


#: Resamples of :func:`recording_interval`, and how many are drawn at once (memory bound).
INTERVAL_RESAMPLES = 2000
_RESAMPLE_CHUNK = 100
# The most window weights roc_point_interval holds at once (float64: 32 MiB an array).
_DRAW_ELEMENTS = 1 << 22


def recording_interval(
    hit: npt.ArrayLike,
    recording: npt.ArrayLike,
    *,
    against: npt.ArrayLike | None = None,
    strata: npt.ArrayLike | None = None,
    level: float = 0.95,
    resamples: int = INTERVAL_RESAMPLES,
    seed: int = 0,
) -> tuple[float, float]:
    """The ``level`` interval of the share of ``hit`` windows when the recordings are drawn
    again: whole recordings with replacement, as many as there are (a percentile bootstrap
    over recordings). Windows of one recording are not independent — a recording of a
    helicopter alarms in most of its windows or in none — so the recordings, not the windows,
    set how well a share is known. ``(nan, nan)`` for no windows. The same inputs and ``seed``
    give the same interval.

    Where no window hits (or every one does), every resample gives 0 (or 1), and the bootstrap
    would say the share is known exactly: the interval is then Clopper-Pearson's for no
    recording of ``r`` hitting (``(0, 1 - ((1 - level) / 2) ** (1 / r))``; the mirror for all),
    a bound on the share of recordings that hit at all, so on the share of windows. Near such
    shares (a few alarms in a few dozen recordings) the bootstrap covers less than ``level``:
    read its interval as a lower bound on the uncertainty. Where every resample gives the same
    share between 0 and 1 (one recording, recordings that each hit in the same share, or with
    ``strata`` groups of such recordings: every UAV window decided right and every UAV-free
    one wrong), the bootstrap would again say the share is known exactly: the interval is then
    Clopper-Pearson's for the hits among the windows taken as independent, which they are not
    (windows of one recording alarm together), so again a lower bound on the uncertainty.

    ``against``: other hits of the same windows (another model's, or another rule's); the
    interval is then that of the difference, ``hit``'s share minus ``against``'s, both on the
    same draws of recordings: whether one's lead is more than the draw (an accuracy lead, with
    ``hit`` the windows one decides right). ``strata``: a group per window (the windows'
    labels, for a set balanced by design); the recordings of each group's windows are then drawn
    apart, each as many as there are, as :func:`roc_point_interval` draws the UAV and the
    UAV-free windows, so every draw keeps the groups' sizes near the set's.

    Raises:
        ShapeError: the arrays differ in length.
        ParameterError: ``hit`` or ``against`` not boolean, ``level`` not a number in (0, 1),
            ``resamples`` not an integer >= 1 or ``seed`` not one >= 0.
    """
    h = check_bools("hit", hit)
    rec = np.asarray(recording)
    other = None if against is None else check_bools("against", against)
    group = np.zeros(h.shape, np.int64) if strata is None else np.asarray(strata)
    if not h.shape == rec.shape == group.shape or (other is not None and other.shape != h.shape):
        theirs = "" if other is None else f", against {other.size}"
        named = "" if strata is None else f", strata {group.size}"
        raise ShapeError(f"hit has {h.size} windows, recording {rec.size}{theirs}{named}")
    level = _level(level)
    resamples = check_int("resamples", resamples, 1)
    seed = check_int("seed", seed, 0)
    if h.size == 0:
        return (math.nan, math.nan)
    if other is None and (not h.any() or h.all()):
        r = len(np.unique(rec))
        bound = ((1 - level) / 2) ** (1 / r)
        return (0.0, float(1 - bound)) if not h.any() else (float(bound), 1.0)
    # The units drawn: each group's recordings; per unit its windows, its hits and the other
    # hits (zero without against).
    _, stratum = np.unique(group, return_inverse=True)
    stratum = stratum.ravel()
    units = []
    for k in range(int(stratum.max()) + 1):
        inside = stratum == k
        which = np.unique(rec[inside], return_inverse=True)[1].ravel()
        their_hits = np.zeros(which.size) if other is None else other[inside]
        units.append(
            (
                np.bincount(which).astype(np.float64),
                np.bincount(which, weights=h[inside]) - np.bincount(which, weights=their_hits),
            )
        )
    rng = np.random.default_rng(seed)
    shares = []
    for start in range(0, resamples, _RESAMPLE_CHUNK):
        draws = min(_RESAMPLE_CHUNK, resamples - start)
        lead = np.zeros(draws)
        windows = np.zeros(draws)
        for count, net in units:
            pick = rng.integers(0, len(count), size=(draws, len(count)))
            windows += count[pick].sum(axis=1)
            lead += net[pick].sum(axis=1)
        shares.append(lead / windows)
    drawn = np.concatenate(shares)
    if other is None and np.all(drawn == drawn[0]):  # every draw alike, between 0 and 1
        return _clopper_pearson(int(h.sum()), h.size, level)
    lo, hi = np.percentile(drawn, [50 * (1 - level), 50 * (1 + level)])
    return (float(lo), float(hi))


def _level(level: float) -> float:
    """An interval's ``level``, a number in (0, 1), as float."""
    level = check_real("level", level)
    if not 0 < level < 1:
        raise ParameterError(f"level must be in (0, 1), got {level}")
    return level


def _clopper_pearson(hits: int, trials: int, level: float) -> tuple[float, float]:
    """Clopper-Pearson's ``level`` interval of a share of ``hits`` of ``trials`` independent
    trials, ``0 < hits < trials``: the shares at which ``hits`` or more (or ``hits`` or fewer)
    have probability ``(1 - level) / 2``, found by bisection."""
    tail = (1 - level) / 2
    k = np.arange(trials + 1, dtype=np.float64)
    # log C(trials, k), summed term by term: the terms underflow for many trials, their logs not.
    log_choose = np.concatenate([[0.0], np.cumsum(np.log(trials - k[:-1]) - np.log(k[1:]))])

    def chance(share: float, upper: bool) -> float:
        """P(X >= hits) (``upper``) or P(X <= hits) for X ~ Binomial(trials, share)."""
        pick = k >= hits if upper else k <= hits
        terms = (
            log_choose[pick] + k[pick] * math.log(share) + (trials - k[pick]) * math.log1p(-share)
        )
        top = float(terms.max())
        return math.exp(top) * float(np.exp(terms - top).sum())

    bounds = []
    for upper in (True, False):
        lo, hi = 0.0, 1.0
        for _ in range(100):
            mid = (lo + hi) / 2
            # P(X >= hits) grows with the share, P(X <= hits) falls.
            if (chance(mid, upper) < tail) == upper:
                lo = mid
            else:
                hi = mid
        bounds.append((lo + hi) / 2)
    return (bounds[0], bounds[1])


def _draw_counts(rng: np.random.Generator, groups: int, draws: int) -> np.ndarray:
    """``draws`` rows of how often each of ``groups`` recordings is drawn when ``groups`` are
    drawn with replacement (float64, shape ``(draws, groups)``)."""
    pick = rng.integers(0, groups, size=(draws, groups))
    counts = np.zeros((draws, groups))
    np.add.at(counts, (np.arange(draws)[:, None], pick), 1.0)
    return counts


def roc_point_draws(
    scores: npt.ArrayLike,
    actual: npt.ArrayLike,
    recording: npt.ArrayLike,
    rate: float,
    *,
    against: npt.ArrayLike | None = None,
    resamples: int = INTERVAL_RESAMPLES,
    seed: int = 0,
) -> np.ndarray:
    """:func:`detection_at_false_alarm` at ``rate`` on each of ``resamples`` draws of the
    recordings (the bootstrap distribution :func:`roc_point_interval` reads its interval off):
    the recordings of the UAV-free windows and those of the UAV windows, each drawn with
    replacement as many as there are, the threshold read again off each draw's UAV-free
    windows and the detection measured on its UAV windows. ``against``: another score of the
    same windows; each draw then gives ``scores``' detection minus ``against``'s, each at its
    own threshold. The same inputs and ``seed`` give the same draws.

    Raises:
        ShapeError: the arrays differ in length.
        ParameterError: NaN scores (or scores that are not numbers, ``actual`` not boolean),
            ``rate`` not a number in [0, 1], ``resamples`` not an integer >= 1 or ``seed`` not
            one >= 0.
        DatasetError: no UAV or no UAV-free window.
    """
    s = check_numbers("scores", scores)
    a = check_bools("actual", actual)
    rec = np.asarray(recording)
    other = None if against is None else check_numbers("against", against)
    if not s.shape == a.shape == rec.shape or (other is not None and other.shape != s.shape):
        theirs = "" if other is None else f", against {other.size}"
        raise ShapeError(
            f"scores has {s.size}, actual {a.size} and recording {rec.size} windows{theirs}"
        )
    if np.isnan(s).any() or (other is not None and np.isnan(other).any()):
        raise ParameterError("scores hold NaN")
    rate = check_real("rate", rate)
    if not 0 <= rate <= 1:
        raise ParameterError(f"rate must be in [0, 1], got {rate}")
    resamples = check_int("resamples", resamples, 1)
    seed = check_int("seed", seed, 0)
    if a.all() or not a.any():
        raise DatasetError("a point on the ROC needs UAV and UAV-free windows")
    # Each window's recording, numbered among the UAV-free (and the UAV) windows' recordings.
    neg_rec = np.unique(rec[~a], return_inverse=True)[1].ravel()
    pos_rec = np.unique(rec[a], return_inverse=True)[1].ravel()
    rng = np.random.default_rng(seed)
    # Draws at once: _RESAMPLE_CHUNK, fewer where a draw's window weights would pass the bound.
    chunk = max(1, min(_RESAMPLE_CHUNK, _DRAW_ELEMENTS // max(neg_rec.size, pos_rec.size)))
    found = []
    for start in range(0, resamples, chunk):
        draws = min(chunk, resamples - start)
        neg_counts = _draw_counts(rng, int(neg_rec.max()) + 1, draws)
        pos_counts = _draw_counts(rng, int(pos_rec.max()) + 1, draws)
        mine = _detection_on_draws(s, a, neg_rec, pos_rec, neg_counts, pos_counts, rate)
        if other is not None:
            mine -= _detection_on_draws(other, a, neg_rec, pos_rec, neg_counts, pos_counts, rate)
        found.append(mine)
    return np.concatenate(found)


def roc_point_interval(
    scores: npt.ArrayLike,
    actual: npt.ArrayLike,
    recording: npt.ArrayLike,
    rate: float,
    *,
    against: npt.ArrayLike | None = None,
    level: float = 0.95,
    resamples: int = INTERVAL_RESAMPLES,
    seed: int = 0,
) -> tuple[float, float]:
    """The ``level`` interval of :func:`detection_at_false_alarm` at ``rate`` when the
    recordings are drawn again: the middle ``level`` of :func:`roc_point_draws` (a percentile
    bootstrap over recordings, as :func:`recording_interval`'s).

    A point read off a set's own ROC moves with the set twice: the threshold is set by the few
    UAV-free windows scoring highest (10 of 1000 at 1 %), often from a few recordings, and the
    detection is a share of the UAV windows. This interval holds both. How well it covers is
    measured, not assumed (``benches/python/roc_point_coverage.py``, and against other ways of
    reading an interval off the same draws ``benches/python/roc_interval_methods.py``;
    docs/identification.md, "How well a point read off the ROC is known"). Where every draw
    gives the same detection (0 or 1), the interval is :func:`recording_interval`'s for the UAV
    windows at the set's own threshold. The same inputs and ``seed`` give the same interval.

    ``against``: another score of the same windows (another model's); the interval is then
    that of the difference, ``scores``' detection minus ``against``'s, each at its own
    threshold on the same draws of recordings: whether one model's lead on a set is more than
    the set's draw.

    Raises:
        ShapeError: the arrays differ in length.
        ParameterError: as :func:`roc_point_draws`; ``level`` not a number in (0, 1).
        DatasetError: no UAV or no UAV-free window.
    """
    level = _level(level)
    shares = roc_point_draws(
        scores, actual, recording, rate, against=against, resamples=resamples, seed=seed
    )
    if against is None and np.all(shares == shares[0]) and shares[0] in (0.0, 1.0):
        s = check_numbers("scores", scores)
        a = check_bools("actual", actual)
        at_own = s[a] >= threshold_at_false_alarm(s, a, rate)
        return recording_interval(at_own, np.asarray(recording)[a], level=level, seed=seed)
    lo, hi = np.percentile(shares, [50 * (1 - level), 50 * (1 + level)])
    return (float(lo), float(hi))


def _detection_on_draws(
    s: np.ndarray,
    a: np.ndarray,
    neg_rec: np.ndarray,
    pos_rec: np.ndarray,
    neg_counts: np.ndarray,
    pos_counts: np.ndarray,
    rate: float,
) -> np.ndarray:
    """:func:`detection_at_false_alarm` on each draw of recordings (a row of ``neg_counts`` and
    of ``pos_counts``: how often each recording of the UAV-free and of the UAV windows is
    drawn), each window weighing as often as its recording was drawn."""
    order = np.argsort(-s[~a], kind="stable")
    neg = s[~a][order]
    cum = np.cumsum(neg_counts[:, neg_rec[order]], axis=1)
    # threshold_at_false_alarm on the draw: just above its (k+1)-th highest UAV-free score.
    k = np.floor(rate * cum[:, -1] + 1e-9)
    past = cum > k[:, None]
    threshold = np.where(
        past.any(axis=1),
        np.nextafter(neg[np.argmax(past, axis=1)], np.inf),
        np.nextafter(-np.inf, 0),
    )
    weight = pos_counts[:, pos_rec]
    hit = s[a][None, :] >= threshold[:, None]
    return (weight * hit).sum(axis=1) / weight.sum(axis=1)
