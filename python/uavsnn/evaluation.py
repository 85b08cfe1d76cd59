"""Honest figures for a detector on a labelled test set (SPEC §5).

The paper's rule decides: a window holds a UAV when at least ``min_detections`` conv3 neurons
fire (:attr:`uavsnn.network.Inference.detected`). Beside the confusion matrix
``[[TP, FN], [FP, TN]]`` and the accuracy, an :class:`Evaluation` carries what users ask next:

- per object class, how often windows of that class were called UAV;
- per object size (the labelled box's longer side, in bins of :data:`SIZE_BINS_PX`), how often
  UAV windows and windows of other objects were called UAV: what the any-spike rule responds to;
- latency in event time: from the first input spike of the window that falls inside the
  labelled UAV box to the first conv3 spike the UAV can have caused (one at or after that
  spike whose box overlaps the labelled box: :func:`first_detection_on_box`), over the true
  positives that have both (how many do not is counted); and from the window's start to its
  first conv3 spike, over every true positive;
- where: over the true positives with a labelled box, the overlap (IoU) of the first
  detection's box with the labelled UAV box, and the distance between their centres;
- the fraction of the sensor's pixels that spiked per window (the paper's sparsity);
- the cost: input spikes per second of wall time through :meth:`~uavsnn.Network.infer`, and
  nanoseconds per input spike.

A share's 95 % interval is drawn over the recordings (:func:`recording_interval`), and only
where each kind of recording drawn again has at least :data:`MIN_INTERVAL_RECORDINGS`; else it
is ``(nan, nan)``: none.

::

    from uavsnn import Network, dataset, evaluation
    test = dataset.load("data/dvs", "test")
    result = evaluation.evaluate(Network.load("model.npz"), test)
    print(result.accuracy, result.confusion)
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from uavsnn._validate import check_bools, check_int, check_numbers, check_real

# The boxes of detections and labels live in uavsnn.boxes; their names stay here too.
from uavsnn.boxes import (
    box_iou,
    centre_distance,
    first_detection_boxes,
    first_detection_on_box,
    first_spike_in_box,
)
from uavsnn.dataset import LabelledWindows
from uavsnn.errors import DatasetError, ParameterError, ShapeError
from uavsnn.network import Inference, Network

# The operating points and their intervals live in uavsnn.roc; their names stay here too.
from uavsnn.roc import (
    detection_at_false_alarm,
    recording_interval,
    roc_area,
    roc_curve,
    roc_point_draws,
    roc_point_interval,
    threshold_at_false_alarm,
)

__all__ = [
    "FALSE_ALARM_RATES",
    "MIN_INTERVAL_RECORDINGS",
    "RANGE_BINS_M",
    "SIZE_BINS_PX",
    "ClassFigures",
    "Evaluation",
    "SizeFigures",
    "WindowInputs",
    "accuracy",
    "accuracy_lead",
    "box_iou",
    "centre_distance",
    "check_test_set",
    "confusion_matrix",
    "detection_at_false_alarm",
    "detection_by_target",
    "drawn_point_interval",
    "evaluate",
    "first_detection_boxes",
    "first_detection_on_box",
    "first_spike_in_box",
    "identification_figures",
    "interval_recordings",
    "recording_interval",
    "roc_area",
    "roc_curve",
    "roc_point_draws",
    "roc_point_interval",
    "score",
    "threshold_at_false_alarm",
]

SIZE_BINS_PX: tuple[float, ...] = (0.0, 6.0, 12.0, 24.0, 48.0, float("inf"))
"""Edges of the object-size bins of :attr:`Evaluation.per_size`: the longer side of a window's
labelled box, in sensor pixels (each bin holds ``low <= side < high``)."""


def confusion_matrix(predicted: npt.ArrayLike, actual: npt.ArrayLike) -> np.ndarray:
    """``[[TP, FN], [FP, TN]]`` (int64): rows are the truth (UAV, not), columns the call.

    Raises:
        ShapeError: the flags are not 1-D or differ in length.
        ParameterError: flags that are not boolean (an empty list is no flags).
    """
    p = check_bools("predicted", predicted)
    a = check_bools("actual", actual)
    if p.shape != a.shape:
        raise ShapeError(f"predicted has {p.size} windows, actual {a.size}")
    return np.array(
        [[np.sum(p & a), np.sum(~p & a)], [np.sum(p & ~a), np.sum(~p & ~a)]], dtype=np.int64
    )


def accuracy(matrix: npt.ArrayLike) -> float:
    """``(TP + TN) / N`` of a confusion matrix (NaN for an empty one).

    Raises:
        ShapeError: not 2x2.
        ParameterError: entries that are not whole counts >= 0 (NaN, a fraction, a string).
    """
    counts = check_numbers("matrix", matrix)
    if counts.shape != (2, 2):
        raise ShapeError(f"a confusion matrix is 2x2, got shape {counts.shape}")
    if not (np.isfinite(counts).all() and (counts >= 0).all() and (counts % 1 == 0).all()):
        raise ParameterError(f"a confusion matrix holds whole counts >= 0, got {counts.tolist()}")
    m = np.asarray(matrix, dtype=np.int64)
    total = int(m.sum())
    return float("nan") if total == 0 else float(m[0, 0] + m[1, 1]) / total


MIN_INTERVAL_RECORDINGS = 5
"""The fewest recordings of each kind drawn again (the UAV and the UAV-free recordings, where
they are drawn apart) for which a figure carries its 95 % interval over the recordings; with
fewer, the interval is ``(nan, nan)``: none (``null`` in JSON, ``–`` in text).

Windows of one recording are not independent, so the interval says how the figure moves when
other recordings are drawn, and that needs recordings to draw. A kind with one recording gives
the same windows on every draw and adds nothing to the interval, which then reflects the other
kind alone: one drone clip and two other clips gave an accuracy of 34.0 % "(28.3–40.4)" that
says nothing of how another drone would fare. With ``r`` recordings the bootstrap has at most
``C(2r - 1, r)`` distinct draws (1, 3, 10 and 35 for 1 to 4 recordings, 126 for 5), and its
variance is ``(r - 1) / r`` of the usual estimate of the recordings' own (none at 1, half at
2), so below 5 it is too coarse and too narrow to be read as a 95 % interval. Even at 5 it
covers less than 95 %: read it as a lower bound on the uncertainty. Every figure of
docs/results/RESULTS.md draws from 16 recordings of a kind or more."""


def interval_recordings(recording: npt.ArrayLike, strata: npt.ArrayLike | None = None) -> int:
    """The fewest recordings in any group of ``strata`` (one group without it): what a figure's
    interval over ``recording`` draws again from, which :data:`MIN_INTERVAL_RECORDINGS` bounds;
    0 for no windows.

    Raises:
        ShapeError: ``strata`` and ``recording`` differ in length."""
    rec = np.asarray(recording).ravel()
    group = np.zeros(rec.shape, np.int64) if strata is None else np.asarray(strata).ravel()
    if group.shape != rec.shape:
        raise ShapeError(f"recording has {rec.size} windows, strata {group.size}")
    if rec.size == 0:
        return 0
    return min(len(np.unique(rec[group == g])) for g in np.unique(group))


#: No interval: one NaN object, so that figures without one still compare equal in Python.
_NAN = float("nan")


def _drawn_interval(
    hit: np.ndarray,
    recording: np.ndarray,
    *,
    against: np.ndarray | None = None,
    strata: np.ndarray | None = None,
) -> tuple[float, float]:
    """:func:`recording_interval`, where each group drawn again has at least
    :data:`MIN_INTERVAL_RECORDINGS` recordings; else none, ``(nan, nan)``. Arrays of other
    lengths get :func:`recording_interval`'s ShapeError either way."""
    shape = np.shape(hit)
    agree = np.shape(recording) == shape and all(
        a is None or np.shape(a) == shape for a in (against, strata)
    )
    if agree and interval_recordings(recording, strata) < MIN_INTERVAL_RECORDINGS:
        return (_NAN, _NAN)
    return recording_interval(hit, recording, against=against, strata=strata)


def drawn_point_interval(
    scores: npt.ArrayLike,
    actual: npt.ArrayLike,
    recording: npt.ArrayLike,
    rate: float,
    *,
    against: npt.ArrayLike | None = None,
) -> tuple[float, float]:
    """:func:`roc_point_interval` (with ``against``, the paired interval of a lead), where the
    UAV and the UAV-free recordings each number at least :data:`MIN_INTERVAL_RECORDINGS`; else
    none, ``(nan, nan)``: a point read off the ROC moves with both kinds of recording."""
    if interval_recordings(recording, actual) < MIN_INTERVAL_RECORDINGS:
        return (_NAN, _NAN)
    return roc_point_interval(scores, actual, recording, rate, against=against)


def _recording_counts(actual: np.ndarray, recording: np.ndarray) -> dict[str, int]:
    """The UAV and the UAV-free recordings of a set's windows (a recording with windows of
    both kinds counts in each): what its intervals are drawn from."""
    return {
        "uav": len(np.unique(recording[actual])),
        "uav_free": len(np.unique(recording[~actual])),
    }


def _accuracy_interval(
    predicted: np.ndarray, actual: np.ndarray, recording: np.ndarray
) -> tuple[float, float]:
    """The 95 % interval of the share of windows ``predicted`` decides right, the UAV and the
    UAV-free recordings drawn again apart (:func:`recording_interval` with ``strata``); none,
    ``(nan, nan)``, with fewer than :data:`MIN_INTERVAL_RECORDINGS` of either."""
    return _drawn_interval(predicted == actual, recording, strata=actual)


def accuracy_lead(
    right: npt.ArrayLike, their_right: npt.ArrayLike, data: LabelledWindows
) -> dict[str, Any]:
    """How much more of ``data``'s windows one rule or network decides right (``right``, one
    flag a window) than another (``their_right``): ``{"lead", "interval"}``, the difference of
    the two accuracies and its paired 95 % interval when the recordings are drawn again, both
    on the same draws, the UAV and the UAV-free recordings apart (:func:`recording_interval`
    with ``against`` and ``strata``; none, ``[nan, nan]``, with fewer than
    :data:`MIN_INTERVAL_RECORDINGS` of either). The lead is NaN for no windows.

    Raises:
        ShapeError: the flags and ``data`` differ in length.
        ParameterError: flags that are not boolean."""
    mine = check_bools("right", right)
    theirs = check_bools("their_right", their_right)
    interval = _drawn_interval(
        mine, np.asarray(data.recording), against=theirs, strata=np.asarray(data.label)
    )
    lead = float(mine.mean() - theirs.mean()) if mine.size else float("nan")
    return {"lead": lead, "interval": list(interval)}


@dataclass(frozen=True)
class ClassFigures:
    """Windows of one object class: how many, how many were called UAV, and how many of the
    calls were right (for ``drone`` that is the detection rate, for the others 1 − it)."""

    windows: int
    called_uav: int
    correct: int

    @property
    def called_uav_rate(self) -> float:
        """Share of this class's windows called UAV."""
        return self.called_uav / self.windows if self.windows else float("nan")


@dataclass(frozen=True)
class SizeFigures:
    """Windows whose labelled object's longer side is in ``[low_px, high_px)``: those with a UAV
    and those with another object, each as a :class:`ClassFigures`."""

    low_px: float
    high_px: float
    uav: ClassFigures
    other: ClassFigures

    @property
    def label(self) -> str:
        """``"6-12 px"``, or ``">= 48 px"`` for the last bin."""
        if np.isinf(self.high_px):
            return f">= {self.low_px:g} px"
        return f"{self.low_px:g}-{self.high_px:g} px"


@dataclass(frozen=True)
class Evaluation:
    """A detector's figures on one test set (see the module's docstring)."""

    confusion: np.ndarray
    per_class: dict[str, ClassFigures]
    latency_us: np.ndarray
    latency_from_start_us: np.ndarray
    pixel_fraction: float
    input_spikes: int
    seconds: float
    min_detections: int
    predicted: np.ndarray = field(repr=False)
    inference: Inference | None = field(default=None, repr=False)
    #: Over the true positives with a labelled box: IoU of the first detection's box with it.
    box_iou: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    #: The same windows: distance (pixels) between the two boxes' centres.
    box_centre_error_px: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    #: By the labelled object's size (:data:`SIZE_BINS_PX`; windows without a box left out).
    per_size: tuple[SizeFigures, ...] = ()
    #: The accuracy's 95 % interval when the recordings are drawn again, the UAV and the
    #: UAV-free ones apart (:func:`recording_interval` with ``strata``); ``(nan, nan)``, none,
    #: with fewer than :data:`MIN_INTERVAL_RECORDINGS` of either.
    accuracy_interval: tuple[float, float] = (float("nan"), float("nan"))
    #: The set's UAV and UAV-free recordings, what the interval is drawn from (a recording
    #: with windows of both kinds counts in each).
    recordings: tuple[int, int] = (0, 0)
    #: True positives left out of :attr:`latency_us` with no input spike in the labelled box.
    latency_no_spike_in_box: int = 0
    #: True positives left out of :attr:`latency_us` with an input spike in the box but no
    #: detection the UAV can have caused (every one came before the box's first input spike,
    #: or its box lies off the labelled box: :func:`first_detection_on_box`).
    latency_not_caused: int = 0

    @property
    def accuracy(self) -> float:
        """``(TP + TN) / N``."""
        return accuracy(self.confusion)

    @property
    def windows(self) -> int:
        """Test windows scored."""
        return int(self.confusion.sum())

    @property
    def events_per_second(self) -> float:
        """Input spikes through the network per second of wall time."""
        return self.input_spikes / self.seconds if self.seconds > 0 else float("nan")

    @property
    def ns_per_event(self) -> float:
        """Wall time per input spike, in nanoseconds."""
        return 1e9 * self.seconds / self.input_spikes if self.input_spikes else float("nan")

    def to_dict(self) -> dict[str, Any]:
        """Everything as plain values for :func:`json.dumps`. A figure that is not defined
        (the speed of a run without one input spike, or of :func:`score` given no time, or an
        interval from too few recordings) is NaN, which :func:`json.dumps` writes as the bare
        word ``NaN``, outside strict JSON; the commands write it as ``null``
        (``uavsnn._jsonout``). ``latency_left_out``: the true positives :attr:`latency_us`
        leaves out, ``no_spike_in_box`` and ``not_caused``."""
        (tp, fn), (fp, tn) = self.confusion.tolist()

        def stats(values: np.ndarray) -> dict[str, float | int | None]:
            if values.size == 0:
                return {"n": 0, "median": None, "p90": None, "mean": None}
            return {
                "n": int(values.size),
                "median": float(np.median(values)),
                "p90": float(np.percentile(values, 90)),
                "mean": float(values.mean()),
            }

        return {
            "windows": self.windows,
            "confusion": [[tp, fn], [fp, tn]],
            "accuracy": self.accuracy,
            "accuracy_interval": list(self.accuracy_interval),
            "recordings": {"uav": self.recordings[0], "uav_free": self.recordings[1]},
            "tp": tp,
            "fn": fn,
            "fp": fp,
            "tn": tn,
            "min_detections": self.min_detections,
            "per_class": {
                name: {
                    "windows": c.windows,
                    "called_uav": c.called_uav,
                    "correct": c.correct,
                    "called_uav_rate": c.called_uav_rate,
                }
                for name, c in sorted(self.per_class.items())
            },
            "per_size": [
                {
                    "low_px": z.low_px,
                    "high_px": None if np.isinf(z.high_px) else z.high_px,
                    "uav": {"windows": z.uav.windows, "called_uav": z.uav.called_uav},
                    "other": {"windows": z.other.windows, "called_uav": z.other.called_uav},
                }
                for z in self.per_size
            ],
            "latency_us": stats(self.latency_us),
            "latency_left_out": {
                "no_spike_in_box": self.latency_no_spike_in_box,
                "not_caused": self.latency_not_caused,
            },
            "latency_from_window_start_us": stats(self.latency_from_start_us),
            "box_iou": stats(self.box_iou),
            "box_centre_error_px": stats(self.box_centre_error_px),
            "pixel_fraction": self.pixel_fraction,
            "input_spikes": self.input_spikes,
            "seconds": self.seconds,
            "events_per_second": self.events_per_second,
            "ns_per_event": self.ns_per_event,
        }


def check_test_set(data: LabelledWindows, network: Network, *, balanced: bool = True) -> None:
    """Refuse a test set that cannot give an honest figure for ``network``: empty, of another
    sensor size, or (with ``balanced``) not half UAV windows.

    Raises:
        DatasetError: an empty or unbalanced set.
        ShapeError: the set's sensor size is not the network's input.
    """
    if not isinstance(data, LabelledWindows):
        raise ParameterError(f"expected uavsnn.dataset.LabelledWindows, got {type(data).__name__}")
    if len(data) == 0:
        raise DatasetError("the test set is empty")
    config = network.config
    expected = (int(config["width"]), int(config["height"]))
    if tuple(data.windows.sensor_size) != expected:
        raise ShapeError(
            f"the test set's sensor is {data.windows.sensor_size[0]}x"
            f"{data.windows.sensor_size[1]} but the model's input is {expected[0]}x{expected[1]}"
        )
    uav = int(np.count_nonzero(data.label))
    if balanced and 2 * uav != len(data):
        raise DatasetError(
            f"the set is unbalanced: {uav} UAV and {len(data) - uav} other windows "
            "(SPEC §5 asks for half each; pass balanced=False, uavsnn evaluate --unbalanced, "
            "to score it anyway)"
        )


def evaluate(
    network: Network,
    data: LabelledWindows,
    *,
    threads: int | None = None,
    balanced: bool = True,
    keep_inference: bool = False,
) -> Evaluation:
    """Run ``network`` on every window of ``data`` and score it (see :func:`check_test_set`
    for what is refused)."""
    check_test_set(data, network, balanced=balanced)
    start = time.perf_counter()
    inference = network.infer(data.windows, threads=threads)
    seconds = time.perf_counter() - start
    return score(inference, data, seconds=seconds, keep_inference=keep_inference, network=network)


@dataclass(frozen=True)
class WindowInputs:
    """What :func:`score` reads of the windows a network ran on, beside their starts: each
    window's input spikes (``spikes``, int64) and the time of its first one inside its labelled
    box (``first_in_box``, :func:`first_spike_in_box`). Kept in place of the windows where they
    were made part by part and let go (noise on a large sensor,
    :func:`uavsnn.experiments.noise_level`)."""

    spikes: np.ndarray
    first_in_box: np.ndarray

    @classmethod
    def of(cls, windows: Any, boxes: npt.ArrayLike) -> WindowInputs:
        """The inputs of ``windows``, each with its labelled box ``x0, y0, x1, y1``."""
        return cls(
            spikes=np.diff(np.asarray(windows.offsets, dtype=np.int64)),
            first_in_box=first_spike_in_box(windows, boxes),
        )

    @classmethod
    def concatenate(cls, parts: Sequence[WindowInputs]) -> WindowInputs:
        """The inputs of consecutive runs of windows as one."""
        return cls(
            spikes=np.concatenate([p.spikes for p in parts]).astype(np.int64, copy=False),
            first_in_box=np.concatenate([p.first_in_box for p in parts]).astype(
                np.int64, copy=False
            ),
        )


def score(
    inference: Inference,
    data: LabelledWindows,
    *,
    seconds: float = float("nan"),
    keep_inference: bool = False,
    network: Network | None = None,
    inputs: WindowInputs | None = None,
) -> Evaluation:
    """Score an :class:`~uavsnn.network.Inference` of ``data``'s windows against its labels.
    ``inputs``: what the network's input windows held when they are not ``data.windows`` (the
    same starts, other spikes: with noise added), else read from ``data.windows``."""
    if len(inference) != len(data):
        raise ShapeError(f"inference has {len(inference)} windows, the data {len(data)}")
    if inputs is None:
        inputs = WindowInputs.of(data.windows, data.box)
    elif len(inputs.spikes) != len(data) or len(inputs.first_in_box) != len(data):
        raise ShapeError(
            f"inputs have {len(inputs.spikes)} and {len(inputs.first_in_box)} windows, "
            f"the data {len(data)}"
        )
    predicted = np.asarray(inference.detected, dtype=bool)
    actual = np.asarray(data.label, dtype=bool)

    def figures(mask: np.ndarray) -> ClassFigures:
        return ClassFigures(
            windows=int(mask.sum()),
            called_uav=int(predicted[mask].sum()),
            correct=int((predicted[mask] == actual[mask]).sum()),
        )

    per_class = {str(name): figures(data.cls == name) for name in np.unique(data.cls)}
    labelled = np.asarray(data.box, dtype=np.float64)
    boxed = np.asarray(np.isfinite(labelled).all(axis=1), dtype=bool)
    side = np.zeros(len(data))
    side[boxed] = np.maximum(
        labelled[boxed, 2] - labelled[boxed, 0], labelled[boxed, 3] - labelled[boxed, 1]
    )
    per_size = []
    for low, high in itertools.pairwise(SIZE_BINS_PX):
        inside = boxed & (side >= low) & (side < high)
        if inside.any():
            per_size.append(
                SizeFigures(
                    low, high, uav=figures(inside & actual), other=figures(inside & ~actual)
                )
            )
    w = data.windows
    tp = np.flatnonzero(predicted & actual)
    first_in_box = inputs.first_in_box
    detection_t = inference.first_detection_t.astype(np.int64)
    # The latency runs to the first detection the UAV can have caused: a detection before its
    # first input spike in the box, or boxed off it, was caused by something else.
    caused_t = first_detection_on_box(inference, labelled, first_in_box)
    reached = tp[first_in_box[tp] >= 0]
    caused = reached[caused_t[reached] >= 0]
    latency = caused_t[caused] - first_in_box[caused]
    from_start = detection_t[tp] - w.t0[tp].astype(np.int64)
    first_box = first_detection_boxes(inference, len(data))
    located = tp[boxed[tp]]
    iou = box_iou(first_box[located], labelled[located])
    centre = centre_distance(first_box[located], labelled[located])
    width, height = w.sensor_size
    spikes = inputs.spikes
    min_detections = 1 if network is None else int(network.config["detection"]["min_detections"])
    rec = np.asarray(data.recording)
    counts = _recording_counts(actual, rec)
    return Evaluation(
        confusion=confusion_matrix(predicted, actual),
        per_class=per_class,
        latency_us=latency.astype(np.int64),
        latency_from_start_us=from_start.astype(np.int64),
        pixel_fraction=float(spikes.mean() / (width * height)) if len(spikes) else float("nan"),
        input_spikes=int(spikes.sum()),
        seconds=float(seconds),
        min_detections=min_detections,
        predicted=predicted,
        inference=inference if keep_inference else None,
        box_iou=iou,
        box_centre_error_px=centre,
        per_size=tuple(per_size),
        accuracy_interval=_accuracy_interval(predicted, actual, rec),
        recordings=(counts["uav"], counts["uav_free"]),
        latency_no_spike_in_box=len(tp) - len(reached),
        latency_not_caused=len(reached) - len(caused),
    )


# ------------------------------------------------------------ detection, then identification

RANGE_BINS_M: tuple[float, ...] = (0.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, float("inf"))
"""Edges of the range bins (metres) of :func:`identification_figures`."""

FALSE_ALARM_RATES: tuple[float, ...] = (0.01, 0.05)
"""The shares of UAV-free windows raising an alarm at which detection is reported."""


def _binned_rate(
    hit: np.ndarray, value: np.ndarray, edges: Sequence[float], recording: np.ndarray
) -> list[dict]:
    """Per bin of ``value`` between ``edges`` that holds a window: its windows, the recordings
    they come from (a recording whose object changes size or range has windows in several
    bins), and the windows hit."""
    out = []
    for low, high in itertools.pairwise(edges):
        inside = np.isfinite(value) & (value >= low) & (value < high)
        if inside.any():
            out.append(
                {
                    "low": float(low),
                    "high": None if np.isinf(high) else float(high),
                    "windows": int(inside.sum()),
                    "recordings": int(np.unique(recording[inside]).size),
                    "detected": int(hit[inside].sum()),
                    "rate": float(hit[inside].mean()),
                }
            )
    return out


def identification_figures(
    detected: npt.ArrayLike,
    scores: npt.ArrayLike,
    data: LabelledWindows,
    threshold: float,
    *,
    alarm_thresholds: Sequence[tuple[float, float]] = (),
    roc_points: int = 101,
) -> dict[str, Any]:
    """Both rules side by side on ``data``: the any-spike rule (``detected``) and detection +
    identification (a window is UAV when ``detected`` and its UAV score (``scores``) is at
    least ``threshold``). Each with its confusion matrix, accuracy and per-class calls; the
    combined score's ROC (``roc_points`` points at most, and the area under it up to the
    any-spike rule's own false-alarm rate); and at the
    thresholds where :data:`FALSE_ALARM_RATES` of the UAV-free windows alarm, the detection
    rate against size (``data.size_px``, :data:`SIZE_BINS_PX`) and range (``data.range_m``,
    :data:`RANGE_BINS_M`) and the false alarms per class of other object. Those thresholds are
    read off this set's UAV-free windows (points on its own ROC, which no user can set
    beforehand; nothing else is tuned on them); each point's
    ``"detection_interval"`` is its 95 % interval when the recordings are drawn again, the
    threshold read again each time (:func:`roc_point_interval`). Each rule's
    ``"accuracy_interval"`` is its accuracy's, the UAV and the UAV-free recordings drawn apart
    (:func:`recording_interval` with ``strata``); ``"accuracy_lead"`` is the second rule's
    accuracy minus the first's, with the paired interval (``against``: both rules on the same
    draws). Every interval is ``[nan, nan]``, none, where the recordings it draws again number
    fewer than :data:`MIN_INTERVAL_RECORDINGS` of a kind; ``"recordings"`` gives the set's
    ``"uav"`` and ``"uav_free"`` recordings.

    ``alarm_thresholds`` (:attr:`uavsnn.identify.Identifier.alarm_thresholds`: thresholds set
    on other recordings for a false-alarm share) adds ``"at_tuned_false_alarm"``: the same
    figures at each of those thresholds, where this set's false-alarm share is measured, not
    chosen — what a user who sets the threshold beforehand gets — with the 95 % intervals of
    the false-alarm share and of the detection over this set's recordings
    (:func:`recording_interval`: ``"false_alarm_interval"``, ``"detection_interval"``).

    A set of one class (all UAV, or none) has no ROC: ``"roc"`` is ``None`` and
    ``"at_false_alarm"`` empty, and a rate of the class it lacks is ``None``.

    Raises:
        ShapeError: ``detected`` or ``scores`` not one a window of ``data``.
        ParameterError: ``detected`` not boolean, ``scores`` not finite numbers, ``threshold``
            not a finite number, ``alarm_thresholds`` not pairs of a false-alarm share in
            [0, 1] and a finite threshold, or ``roc_points`` not an integer >= 2."""
    fired = check_bools("detected", detected)
    s = check_numbers("scores", scores)
    actual = np.asarray(data.label, dtype=bool)
    if fired.shape != actual.shape or s.shape != actual.shape:
        raise ShapeError(
            f"detected has {fired.size} and scores {s.size} windows, the data {actual.size}"
        )
    if not np.isfinite(s).all():
        bad = int((~np.isfinite(s)).sum())
        raise ParameterError(f"scores must be finite, got {bad} NaN or infinite")
    threshold = check_real("threshold", threshold)
    tuned = _alarm_thresholds(alarm_thresholds)
    roc_points = check_int("roc_points", roc_points, 2)
    combined = np.where(fired, s, -np.inf)
    rec = np.asarray(data.recording)

    def rule(pred: np.ndarray) -> dict[str, Any]:
        m = confusion_matrix(pred, actual)
        return {
            "confusion": m.tolist(),
            "accuracy": accuracy(m),
            "accuracy_interval": list(_accuracy_interval(pred, actual, rec)),
            "per_class": {str(c): float(pred[data.cls == c].mean()) for c in np.unique(data.cls)},
        }

    others = [str(c) for c in np.unique(data.cls[~actual])]
    # A set of one class (drone-only footage under --unbalanced) has no ROC and no point read
    # off one; the rules' figures and the rates at thresholds set beforehand remain.
    both = bool(actual.any() and (~actual).any())

    def share(hit: np.ndarray) -> float | None:
        return float(hit.mean()) if hit.size else None

    def at(rate: float, t: float, intervals: bool = False) -> dict[str, Any]:
        alarm = combined >= t
        point: dict[str, Any] = {
            "false_alarm_target": rate,
            "threshold": t,
            "false_alarm_rate": share(alarm[~actual]),
            "detection_rate": share(alarm[actual]),
            "by_size_px": _binned_rate(
                alarm[actual], data.size_px[actual], SIZE_BINS_PX, rec[actual]
            ),
            "by_range_m": _binned_rate(
                alarm[actual], data.range_m[actual], RANGE_BINS_M, rec[actual]
            ),
            "false_alarms_per_class": {
                c: float(alarm[~actual & (data.cls == c)].mean()) for c in others
            },
        }
        if intervals:
            point["false_alarm_interval"] = list(_drawn_interval(alarm[~actual], rec[~actual]))
            point["detection_interval"] = list(_drawn_interval(alarm[actual], rec[actual]))
        return point

    roc: dict[str, Any] | None = None
    at_fa = []
    if both:
        fa, pd = roc_curve(combined, actual)
        keep = np.unique(np.linspace(0, len(fa) - 1, min(roc_points, len(fa))).round().astype(int))
        roc = {
            "false_alarm": fa[keep].tolist(),
            "detection": pd[keep].tolist(),
            # Up to the any-spike rule's own false-alarm rate: windows it misses never alarm.
            "area_reachable": float(np.sum(np.diff(fa) * (pd[1:] + pd[:-1]) / 2)),
        }
        # Where a share needs more windows than the rule calls, every detection alarms: the
        # point is the lowest detection's score, not the float just above -inf that stands for
        # it (-1.797e308 in the JSON).
        lowest = float(s[fired].min()) if fired.any() else float(s.min())
        for r in FALSE_ALARM_RATES:
            point = at(r, max(threshold_at_false_alarm(combined, actual, r), lowest))
            point["detection_interval"] = list(drawn_point_interval(combined, actual, rec, r))
            at_fa.append(point)
    identified = combined >= threshold
    out = {
        "threshold": float(threshold),
        "any_spike": rule(fired),
        "identified": rule(identified),
        # What identification adds to the any-spike rule's accuracy on these windows, with the
        # paired interval: both rules on the same draws of the recordings.
        "accuracy_lead": accuracy_lead(identified == actual, fired == actual, data),
        "recordings": _recording_counts(actual, rec),
        "roc": roc,
        "at_false_alarm": at_fa,
    }
    if tuned:
        out["at_tuned_false_alarm"] = [at(r, t, intervals=True) for r, t in tuned]
    return out


def _alarm_thresholds(pairs: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
    """:func:`identification_figures`' ``alarm_thresholds`` as ``(share, threshold)`` floats,
    each share in [0, 1] and each threshold finite, or a ParameterError."""
    try:
        items = list(pairs)
    except TypeError as exc:
        raise ParameterError(
            f"alarm_thresholds must be a sequence of pairs, got {pairs!r}"
        ) from exc
    out = []
    for pair in items:
        try:
            rate, t = pair
            rate, t = check_real("rate", rate, low=0, high=1), check_real("threshold", t)
        except (TypeError, ValueError) as exc:  # ParameterError is a ValueError
            raise ParameterError(
                f"alarm_thresholds must be (false-alarm share in [0, 1], finite threshold) "
                f"pairs, got {pair!r}"
            ) from exc
        out.append((rate, t))
    return out


def detection_by_target(points: Sequence[Mapping[str, Any]]) -> dict[float, float]:
    """The detection rate at each operating point of :func:`identification_figures`
    (``"at_false_alarm"`` or ``"at_tuned_false_alarm"``), keyed by its false-alarm target:
    ``detection_by_target(figures["at_false_alarm"])[0.01]``."""
    return {float(p["false_alarm_target"]): float(p["detection_rate"]) for p in points}
