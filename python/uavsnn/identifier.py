"""The identification model (SPEC §3): :class:`Identifier`, a fitted UAV score and class
guess for the objects of a window, with its operating points, and its form in a model file.

:mod:`uavsnn.identify` fits it (and re-exports it); this module holds what inference and the
model file need. The model is stored beside the network as plain arrays, ``identify.*``
(:meth:`Identifier.to_arrays`, :meth:`Identifier.from_arrays`; the names are listed in
:mod:`uavsnn.identify`'s docs and docs/identification.md; no pickle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from uavsnn._validate import check_numbers, check_real
from uavsnn.errors import ModelFileError, ParameterError, ShapeError
from uavsnn.features import FEATURES, UAV_CLASS, WindowFeatures
from uavsnn.linear import predict_logistic, predict_softmax
from uavsnn.track_eval import DEFAULT_CONFIRM, Confirm
from uavsnn.tracks import check_gate
from uavsnn.trees import Trees

__all__ = ["VERSION", "Identifier"]

#: The newest version of the stored arrays (``identify.version``) this reads: 2 adds the class
#: model, 3 the trees. A model without trees is written as version 2, which older uavsnn read;
#: version 1 files still load (their class guess is ``"uav"`` or ``"other"``).
VERSION = 3

#: The relative difference within which a rate names one of the rates a model was tuned for
#: (:meth:`Identifier.at_false_alarm`, :meth:`Identifier.at_false_tracks`): a float32's
#: precision, far finer than the rates' spacing.
_RATE_TOLERANCE = 1e-6


@dataclass(frozen=True, eq=False)
class Identifier:
    """A fitted identification model: UAV score of an object from its features, and (when
    ``classes`` is not empty) a class model for the class guess: ``class_coef``
    ``(len(classes), d + 1)`` over the same standardised features (:func:`fit_softmax`).

    The UAV score is the logistic regression ``coef`` ``(d + 1,)`` on the standardised
    features, or, when ``trees`` is set (:class:`uavsnn.trees.Trees` over the same
    standardised columns), the trees' (``coef`` is then the logistic fit they were chosen
    over, kept for the record).

    ``threshold`` is the operating point the model was tuned for (the highest threshold whose
    balanced accuracy of the combined rule on the tuning windows is the best,
    :func:`uavsnn.identify.best_threshold`). ``alarm_thresholds``: further operating points
    set on the same tuning windows, ``(false-alarm share, threshold)`` pairs: at that threshold,
    at most that share of the tuning set's UAV-free windows alarms
    (:data:`uavsnn.evaluation.FALSE_ALARM_RATES`); :meth:`at_false_alarm` switches to one.
    Whether the share carries to other recordings is what
    :func:`uavsnn.evaluation.identification_figures` measures.

    ``track_alarm_thresholds``: operating points of the track-level rule, ``(false tracks per
    minute, threshold)`` pairs set on ``track_alarm_minutes`` of streamed UAV-free recording
    (:func:`uavsnn.false_alarms.tune_track_alarms`): at that threshold, at most that many
    confirmed tracks per minute of it alarmed; :meth:`at_false_tracks` switches to one.
    ``track_alarm_confirm``: the tracker's confirmation rule ``(hits, windows)`` they were set
    with (the points hold for that rule only; 3 of 5, the detector's, by default).

    ``gate_px``: the gate (px) of the tracker its track features were built with
    (:attr:`uavsnn.features.WindowFeatures.gate_px`); a network with this model runs its
    tracker at that gate (:func:`uavsnn.tracks.tracker_for`). ``None``: a model written before
    uavsnn recorded it, which runs at its sensor's gate
    (:meth:`uavsnn.tracks.Tracker.for_sensor`).

    Two models are equal (``==``) when every field is: the arrays (the trees' too) element by
    element. A model holds arrays, so it is not hashable (as a :class:`uavsnn.Network`)."""

    features: tuple[str, ...]
    coef: np.ndarray
    mean: np.ndarray
    scale: np.ndarray
    threshold: float
    l2: float
    classes: tuple[str, ...] = ()
    class_coef: np.ndarray | None = None
    class_l2: float | None = None
    alarm_thresholds: tuple[tuple[float, float], ...] = ()
    trees: Trees | None = None
    track_alarm_thresholds: tuple[tuple[float, float], ...] = ()
    track_alarm_minutes: float = 0.0
    track_alarm_confirm: tuple[int, int] = DEFAULT_CONFIRM
    gate_px: float | None = None

    def __post_init__(self) -> None:
        d = len(self.features)
        if self.gate_px is not None:  # a NumPy number too, kept as float
            object.__setattr__(self, "gate_px", check_gate(self.gate_px))
        # Each number as a float: a string or a bool is refused here, an integer beyond a
        # float's range (inf) by the checks below, not a TypeError or OverflowError.
        alarms = _number_pairs("alarm_thresholds", self.alarm_thresholds)
        tracks = _number_pairs("track_alarm_thresholds", self.track_alarm_thresholds)
        for name, value in (
            ("alarm_thresholds", alarms),
            ("track_alarm_thresholds", tracks),
            ("track_alarm_minutes", _number("track_alarm_minutes", self.track_alarm_minutes)),
            ("threshold", _number("threshold", self.threshold)),
            ("l2", _number("l2", self.l2)),
        ):
            object.__setattr__(self, name, value)
        # The arrays as float64 arrays (a list too); values that are not numbers are refused.
        for name in ("coef", "mean", "scale", "class_coef"):
            values = getattr(self, name)
            if values is not None:
                object.__setattr__(self, name, check_numbers(name, values))
        for rate, threshold in self.alarm_thresholds:
            if not (0.0 < rate < 1.0 and math.isfinite(threshold)):
                raise ParameterError(
                    f"alarm thresholds must pair a false-alarm share in (0, 1) with a finite "
                    f"threshold, got ({rate}, {threshold})"
                )
        if len({rate for rate, _ in self.alarm_thresholds}) != len(self.alarm_thresholds):
            raise ParameterError(f"alarm thresholds name a share twice: {self.alarm_thresholds}")
        for rate, threshold in tracks:
            if not (0.0 < rate < math.inf and math.isfinite(threshold)):
                raise ParameterError(
                    f"track alarm thresholds must pair a positive rate of false tracks per "
                    f"minute with a finite threshold, got ({rate}, {threshold})"
                )
        if len({rate for rate, _ in tracks}) != len(tracks):
            raise ParameterError(f"track alarm thresholds name a rate twice: {tracks}")
        confirm = self.track_alarm_confirm
        if not isinstance(confirm, tuple):
            raise ParameterError(f"track_alarm_confirm must be a tuple, got {confirm!r}")
        try:  # a pair of integers (NumPy ones too, kept as int), 1 <= hits <= windows <= 64
            pair = Confirm.of_pair(confirm).pair
        except ParameterError as err:
            raise ParameterError(f"track_alarm_confirm: {err}") from err
        object.__setattr__(self, "track_alarm_confirm", pair)
        minutes = self.track_alarm_minutes
        if not (math.isfinite(minutes) and (minutes > 0) == bool(tracks) and minutes >= 0):
            raise ParameterError(
                f"track_alarm_minutes must be positive with track alarm thresholds and 0 "
                f"without, got {minutes!r}"
            )
        unknown = [f for f in self.features if f not in FEATURES]
        if unknown:
            raise ParameterError(f"unknown identification features {unknown}")
        if self.coef.shape != (d + 1,) or self.mean.shape != (d,) or self.scale.shape != (d,):
            raise ShapeError(f"identification arrays do not match {d} features")
        # Not a number anywhere would score every object NaN: never an alarm, without a word.
        if not math.isfinite(self.threshold):
            raise ParameterError(f"threshold must be finite, got {self.threshold!r}")
        if not (math.isfinite(self.l2) and self.l2 >= 0):
            raise ParameterError(f"l2 must be finite and >= 0, got {self.l2!r}")
        for name in ("coef", "mean", "class_coef"):
            values = getattr(self, name)
            if values is not None and not np.isfinite(values).all():
                raise ParameterError(f"{name} must hold finite numbers only")
        if not (np.isfinite(self.scale).all() and (self.scale > 0).all()):
            raise ParameterError("scale must hold finite numbers > 0 only")
        if self.classes:
            if len(set(self.classes)) != len(self.classes) or len(self.classes) < 2:
                raise ParameterError(f"classes must be 2 or more distinct names: {self.classes}")
            if self.class_coef is None or self.class_coef.shape != (len(self.classes), d + 1):
                raise ShapeError(
                    f"the class model must be ({len(self.classes)}, {d + 1}), got "
                    f"{None if self.class_coef is None else self.class_coef.shape}"
                )
        elif self.class_coef is not None:
            raise ParameterError("a class model needs its class names")
        if self.trees is not None and self.trees.columns > d:
            raise ShapeError(f"the trees split on column {self.trees.columns - 1} of {d} features")

    def __eq__(self, other: object) -> bool:
        """Every field equal, the arrays (and the trees') element by element."""
        if other.__class__ is not self.__class__:
            return NotImplemented
        return _same(self, other)

    __hash__ = None  # type: ignore[assignment]  # holds arrays

    def at_false_alarm(self, rate: float) -> Identifier:
        """This model with its threshold set where ``rate`` of the tuning set's UAV-free windows
        alarmed (one of :attr:`alarm_thresholds`' shares, matched to a relative 1e-6, so that a
        float32 share is the same), e.g. ``ident.at_false_alarm(0.01)``.

        Raises:
            ParameterError: ``rate`` not a number, or the model was not tuned for that share
                (see :attr:`alarm_thresholds`).
        """
        rate = check_real("rate", rate)
        for share, threshold in self.alarm_thresholds:
            # Within a float32's precision: np.float32(0.01) is 0.01 too.
            if math.isclose(share, rate, rel_tol=_RATE_TOLERANCE):
                return replace(self, threshold=threshold)
        have = ", ".join(f"{share:g}" for share, _ in self.alarm_thresholds) or "none"
        raise ParameterError(
            f"this identification was not tuned for a false-alarm share of {rate!r} "
            f"(tuned shares: {have})"
        )

    def at_false_tracks(self, rate: float) -> Identifier:
        """This model with its threshold set where ``rate`` confirmed tracks per minute of the
        streamed UAV-free tuning recordings alarmed (one of :attr:`track_alarm_thresholds`'
        rates, matched to a relative 1e-6), e.g. ``ident.at_false_tracks(0.1)``.

        Raises:
            ParameterError: ``rate`` not a number, or the model was not tuned for that rate.
        """
        rate = check_real("rate", rate)
        for have, threshold in self.track_alarm_thresholds:
            if math.isclose(have, rate, rel_tol=_RATE_TOLERANCE):
                return replace(self, threshold=threshold)
        tuned = ", ".join(f"{r:g}" for r, _ in self.track_alarm_thresholds) or "none"
        raise ParameterError(
            f"this identification was not tuned for {rate!r} false tracks per minute "
            f"(tuned rates: {tuned})"
        )

    def _standardised(self, x: np.ndarray) -> np.ndarray:
        """``x``'s rows on the model's columns, standardised. A row of ``len(FEATURES)``
        values is one of :data:`FEATURES` and is read by name, whatever the order of
        :attr:`features` (a model over the same names in another order reads the same
        columns); a row of another length is one of :attr:`features`.

        Raises:
            ShapeError: ``x`` is not ``(m, d)`` with ``d`` either of those lengths.
            ParameterError: a value that is not a finite number, or one so large that
                standardising it overflows (named: it would score NaN, never an alarm, or
                1, without a word). No feature computed by uavsnn is either.
        """
        x = check_numbers("features", x)
        if x.ndim != 2:
            raise ShapeError(f"features must be (m, d), got {x.shape}")
        if x.shape[1] == len(FEATURES):
            names = FEATURES
        elif x.shape[1] == len(self.features):
            names = self.features
        else:
            raise ShapeError(f"features must have {len(self.features)} columns, got {x.shape[1]}")
        bad = ~np.isfinite(x)
        if bad.any():
            row, col = (int(i) for i in np.argwhere(bad)[0])
            raise ParameterError(
                f"features must be finite numbers: feature {names[col]!r} (column {col}) of "
                f"row {row} is {x[row, col]}"
            )
        if names is FEATURES and self.features != FEATURES:
            x = x[:, [FEATURES.index(f) for f in self.features]]
        with np.errstate(over="ignore", invalid="ignore"):
            z = (x - self.mean) / self.scale
        bad = ~np.isfinite(z)
        if bad.any():  # a finite value so large that standardising it overflows
            row, col = (int(i) for i in np.argwhere(bad)[0])
            raise ParameterError(
                f"feature {self.features[col]!r} of row {row} is too large for the model: "
                f"{x[row, col]}"
            )
        return z

    def scores(self, x: np.ndarray) -> np.ndarray:
        """UAV score of each object: rows of :data:`FEATURES` (read by name whatever the
        order of :attr:`features`), or of :attr:`features` when they are fewer.

        Raises:
            ShapeError: rows of neither length.
            ParameterError: a feature that is not a finite number (named).
        """
        z = self._standardised(x)
        if self.trees is not None:
            return self.trees.predict(z)
        return predict_logistic(self.coef, z)

    def class_probabilities(self, x: np.ndarray) -> np.ndarray:
        """Each object's probability of each of :attr:`classes` ``(m, len(classes))``;
        ``(m, 0)`` without a class model."""
        z = self._standardised(x)
        if self.class_coef is None:
            return np.zeros((len(z), 0))
        return predict_softmax(self.class_coef, z)

    def guess(self, x: np.ndarray, scores: np.ndarray | None = None) -> list[str]:
        """Each object's class guess: :data:`UAV_CLASS` where its UAV score (``scores``, else
        computed) reaches :attr:`threshold`; else the most probable class other than
        :data:`UAV_CLASS` of the class model, or ``"other"`` without one.

        Raises:
            ShapeError: rows of neither length of :meth:`scores`, or ``scores`` not one per row.
            ParameterError: a feature or a score that is not a finite number.
        """
        s = self.scores(x) if scores is None else scores
        return self.guess_from(s, self.class_probabilities(x))

    def guess_from(self, scores: np.ndarray, probabilities: np.ndarray) -> list[str]:
        """The guess of :meth:`guess` from UAV scores ``(m,)`` and class probabilities
        ``(m, len(classes))`` already computed (or averaged, as a track's are)."""
        s, p = check_numbers("scores", scores), check_numbers("probabilities", probabilities)
        if s.ndim != 1 or p.shape != (len(s), len(self.classes)):
            raise ShapeError(
                f"scores must be (m,) and probabilities (m, {len(self.classes)}), got "
                f"{s.shape} and {p.shape}"
            )
        for name, values in (("scores", s), ("probabilities", p)):
            bad = np.flatnonzero(~np.isfinite(values.ravel()))
            if len(bad):
                raise ParameterError(
                    f"{name} must be finite numbers, got {values.ravel()[bad[0]]} at flat "
                    f"index {int(bad[0])}"
                )
        others = ["other"] * len(s)
        if self.classes:
            cols = [i for i, c in enumerate(self.classes) if c != UAV_CLASS]
            best = np.argmax(p[:, cols], axis=1)
            others = [self.classes[cols[int(b)]] for b in best]
        return [UAV_CLASS if v >= self.threshold else o for v, o in zip(s, others, strict=True)]

    def window_scores(self, feats: WindowFeatures) -> np.ndarray:
        """Per window, its objects' largest UAV score (0 for a window without an object)."""
        out = np.zeros(feats.windows)
        if len(feats.x):
            np.maximum.at(out, feats.window, self.scores(feats.x))
        return out

    def combined_scores(self, feats: WindowFeatures, detected: npt.ArrayLike) -> np.ndarray:
        """Per window, the score of detection + identification: :meth:`window_scores` where the
        network detected (``detected``, one flag a window), ``-inf`` (never an alarm) where it
        did not. A threshold on it is the combined rule; its ROC is the rule's."""
        fired = np.asarray(detected, dtype=bool)
        if fired.shape != (feats.windows,):
            raise ShapeError(f"detected must be ({feats.windows},), got {fired.shape}")
        return np.where(fired, self.window_scores(feats), -np.inf)

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The arrays stored in a model file."""
        out = {
            "identify.version": np.array(2 if self.trees is None else VERSION, dtype=np.int64),
            "identify.features": np.array(self.features, dtype="<U32"),
            "identify.coef": self.coef.astype(np.float64),
            "identify.mean": self.mean.astype(np.float64),
            "identify.scale": self.scale.astype(np.float64),
            "identify.threshold": np.array(self.threshold, dtype=np.float64),
            "identify.l2": np.array(self.l2, dtype=np.float64),
        }
        if self.class_coef is not None:
            out["identify.classes"] = np.array(self.classes, dtype="<U32")
            out["identify.class_coef"] = self.class_coef.astype(np.float64)
            out["identify.class_l2"] = np.array(
                np.nan if self.class_l2 is None else self.class_l2, dtype=np.float64
            )
        if self.alarm_thresholds:
            rates, thresholds = zip(*self.alarm_thresholds, strict=True)
            out["identify.alarm_rates"] = np.array(rates, dtype=np.float64)
            out["identify.alarm_thresholds"] = np.array(thresholds, dtype=np.float64)
        if self.track_alarm_thresholds:
            rates, thresholds = zip(*self.track_alarm_thresholds, strict=True)
            out["identify.track_alarm_rates"] = np.array(rates, dtype=np.float64)
            out["identify.track_alarm_thresholds"] = np.array(thresholds, dtype=np.float64)
            out["identify.track_alarm_minutes"] = np.array(
                self.track_alarm_minutes, dtype=np.float64
            )
            out["identify.track_alarm_confirm"] = np.array(self.track_alarm_confirm, dtype=np.int64)
        if self.trees is not None:
            out["identify.tree_feature"] = self.trees.feature.astype(np.int64)
            out["identify.tree_threshold"] = self.trees.threshold.astype(np.float64)
            out["identify.tree_leaf"] = self.trees.leaf.astype(np.float64)
            out["identify.tree_base"] = np.array(self.trees.base, dtype=np.float64)
        if self.gate_px is not None:
            # An array older uavsnn ignore (they read the keys they know): no new version.
            out["identify.gate_px"] = np.array(self.gate_px, dtype=np.float64)
        return out

    @classmethod
    def from_arrays(cls, arrays: Any) -> Identifier | None:
        """The model stored in ``arrays`` (a mapping, e.g. an ``np.load`` of a model file), or
        ``None`` when it holds none (no ``identify.*`` array). Reads versions 1 (no class
        model), 2 (with or without the class model) and 3 (trees: their four arrays must be
        there), with or without ``identify.gate_px`` (absent: :attr:`gate_px` is ``None``);
        arrays it does not know are ignored.

        Raises:
            ModelFileError: another version, a stored gate that is not one finite number > 0,
                or arrays that do not fit together: one missing (``identify.version`` beside
                the others too), one of another shape or dtype (each named).
        """
        if "identify.version" not in arrays:
            stored = sorted(str(k) for k in arrays if str(k).startswith("identify."))
            if stored:
                shown = ", ".join(stored[:3]) + (", ..." if len(stored) > 3 else "")
                raise ModelFileError(
                    f"its identification arrays are inconsistent: identify.version is missing "
                    f"beside {len(stored)} of them ({shown})"
                )
            return None
        version = int(_one(arrays, "identify.version", "iu", "one integer"))
        if version not in (1, 2, VERSION):
            raise ModelFileError(
                f"identification version {version}; this uavsnn reads versions 1 to {VERSION}"
            )
        gate = _gate(arrays)
        try:
            classes: tuple[str, ...] = ()
            class_coef, class_l2 = None, None
            if version >= 2 and "identify.classes" in arrays:
                classes = tuple(str(c) for c in _stored(arrays, "identify.classes"))
                class_coef = np.asarray(_stored(arrays, "identify.class_coef"), dtype=np.float64)
                l2 = _scalar(arrays, "identify.class_l2")
                class_l2 = None if math.isnan(l2) else l2
            elif version >= 2:
                for key in ("identify.class_coef", "identify.class_l2"):
                    if key in arrays:
                        raise ModelFileError(f"{key} is stored without identify.classes")
            alarms = _pairs(arrays, "identify.alarm_rates", "identify.alarm_thresholds")
            track_alarms = _pairs(
                arrays, "identify.track_alarm_rates", "identify.track_alarm_thresholds"
            )
            minutes, confirm = 0.0, DEFAULT_CONFIRM
            if track_alarms:
                minutes = _scalar(arrays, "identify.track_alarm_minutes")
                if "identify.track_alarm_confirm" in arrays:
                    pair = _stored(arrays, "identify.track_alarm_confirm").tolist()
                    if not isinstance(pair, list) or len(pair) != 2:
                        raise ShapeError(f"identify.track_alarm_confirm must be 2 values: {pair}")
                    confirm = (int(pair[0]), int(pair[1]))
            trees = None
            if version >= 3:  # a version-3 model has trees (without them it is version 2)
                trees = Trees(
                    feature=np.asarray(_stored(arrays, "identify.tree_feature"), dtype=np.int64),
                    threshold=np.asarray(
                        _stored(arrays, "identify.tree_threshold"), dtype=np.float64
                    ),
                    leaf=np.asarray(_stored(arrays, "identify.tree_leaf"), dtype=np.float64),
                    base=_scalar(arrays, "identify.tree_base"),
                )
            return cls(
                features=tuple(str(f) for f in _stored(arrays, "identify.features")),
                coef=np.asarray(_stored(arrays, "identify.coef"), dtype=np.float64),
                mean=np.asarray(_stored(arrays, "identify.mean"), dtype=np.float64),
                scale=np.asarray(_stored(arrays, "identify.scale"), dtype=np.float64),
                threshold=_scalar(arrays, "identify.threshold"),
                l2=_scalar(arrays, "identify.l2"),
                classes=classes,
                class_coef=class_coef,
                class_l2=class_l2,
                alarm_thresholds=alarms,
                trees=trees,
                track_alarm_thresholds=track_alarms,
                track_alarm_minutes=minutes,
                track_alarm_confirm=confirm,
                gate_px=gate,
            )
        except (KeyError, TypeError, ValueError, ParameterError, ShapeError) as exc:
            # TypeError: one number where names belong (iterating a 0-D array). ValueError:
            # the ModelFileErrors above too (an array missing, or not one number), named.
            raise ModelFileError(f"its identification arrays are inconsistent: {exc}") from exc


def _same(a: Any, b: Any) -> bool:
    """Whether two field values are equal: arrays element by element (and of one shape), the
    fields of two models each by this rule, others (:class:`Trees` too) by ``==``."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and np.array_equal(a, b)
    if isinstance(a, Identifier) or isinstance(b, Identifier):
        return a.__class__ is b.__class__ and all(
            _same(getattr(a, f.name), getattr(b, f.name)) for f in fields(a)
        )
    return a is b or bool(a == b)


def _number(name: str, value: Any) -> float:
    """``value`` as a float; inf for an integer beyond a float's range.

    Raises:
        ParameterError: ``value`` is not a real number (a string, a bool), named ``name``.
    """
    if not _is_real(value):
        raise ParameterError(f"{name} must be a number, got {value!r}")
    try:
        return float(value)
    except OverflowError:
        return math.inf


def _is_real(value: Any) -> bool:
    """Whether ``value`` is a real number (a NumPy one too), not a bool."""
    real = (int, float, np.integer, np.floating)
    return isinstance(value, real) and not isinstance(value, (bool, np.bool_))


def _number_pairs(name: str, pairs: Any) -> tuple[tuple[float, float], ...]:
    """``pairs`` (``(rate, threshold)`` pairs) as pairs of floats (:func:`_number`).

    Raises:
        ParameterError: ``pairs`` is not an iterable of pairs of two numbers, named ``name``.
    """
    try:
        given = [tuple(pair) for pair in pairs]
    except TypeError:
        given = None
    if given is None or any(len(pair) != 2 for pair in given):
        raise ParameterError(f"{name} must be (rate, threshold) pairs, got {pairs!r}")
    for pair in given:
        if not all(_is_real(v) for v in pair):
            raise ParameterError(f"{name} must pair two numbers, got {pair!r}")
    return tuple((_number(name, r), _number(name, t)) for r, t in given)


def _stored(arrays: Any, key: str) -> np.ndarray:
    """The array stored as ``key``.

    Raises:
        ModelFileError: there is none (named).
    """
    if key not in arrays:
        raise ModelFileError(f"{key} is missing")
    return np.asarray(arrays[key])


def _one(arrays: Any, key: str, kinds: str, what: str) -> np.ndarray:
    """The 0-D array stored as ``key``, of a dtype kind in ``kinds``.

    Raises:
        ModelFileError: there is none, or it is an array of another shape or dtype (``what`` it
            must be).
    """
    stored = _stored(arrays, key)
    if stored.shape != () or stored.dtype.kind not in kinds:
        raise ModelFileError(f"{key} must be {what}, got an array of {stored.dtype} {stored.shape}")
    return stored


def _scalar(arrays: Any, key: str) -> float:
    """The one number stored as ``key``, as a float.

    Raises:
        ModelFileError: there is none, or it is not one number (named).
    """
    return float(_one(arrays, key, "iuf", "one number"))


def _gate(arrays: Any) -> float | None:
    """The tracker gate stored as ``identify.gate_px`` (``None`` when absent).

    Raises:
        ModelFileError: it is not one finite number > 0.
    """
    if "identify.gate_px" not in arrays:
        return None
    gate = _scalar(arrays, "identify.gate_px")
    if not (math.isfinite(gate) and gate > 0):
        raise ModelFileError(f"identify.gate_px must be a finite number > 0, got {gate}")
    return gate


def _pairs(arrays: Any, rates_key: str, thresholds_key: str) -> tuple[tuple[float, float], ...]:
    """The ``(rate, threshold)`` pairs stored as two arrays (none when both are absent).

    Raises:
        ShapeError: arrays that are not of one length.
        ModelFileError: one of the two arrays missing beside the other.
    """
    if rates_key not in arrays and thresholds_key not in arrays:
        return ()
    rates = np.asarray(_stored(arrays, rates_key), dtype=np.float64)
    thresholds = np.asarray(_stored(arrays, thresholds_key), dtype=np.float64)
    if rates.ndim != 1 or rates.shape != thresholds.shape:
        raise ShapeError(
            f"{rates_key} {rates.shape} and {thresholds_key} {thresholds.shape} differ"
        )
    return tuple(zip(rates.tolist(), thresholds.tolist(), strict=True))
