"""The figures' functions on what a new user passes them: an interval that the resampled
recordings cannot vary is not reported as known exactly (roc.recording_interval), and bad
arguments to roc, evaluation, track_eval and false_alarms get a typed error naming them, while
NumPy numbers, empty lists and what worked before keep working."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uavsnn import false_alarms, roc, track_eval
from uavsnn.dataset import LabelledWindows
from uavsnn.errors import ParameterError, ShapeError, UavsnnError
from uavsnn.evaluation import (
    accuracy,
    accuracy_lead,
    box_iou,
    confusion_matrix,
    identification_figures,
    recording_interval,
)
from uavsnn.windows import Windows

HIT = np.array([1, 0, 1, 0, 1, 1, 0, 0], bool)
# Clopper-Pearson's 95 % interval of 4 hits in 8 (the beta distribution's 2.5 % and 97.5 %
# points, scipy.stats.beta.ppf(0.025, 4, 5) and beta.ppf(0.975, 5, 4)).
CP_4_OF_8 = (0.15701277048705795, 0.842987229512942)


# ---------------------------------------------------------------- intervals no draw can vary


@pytest.mark.parametrize(
    "recording, strata",
    [
        (np.zeros(8, int), None),  # one recording
        (np.zeros(8, int), HIT),  # one recording a label
        (np.array([0, 0, 0, 0, 1, 1, 1, 1]), None),  # two recordings of the same share
    ],
)
def test_recording_interval_is_never_zero_width_between_0_and_1(recording, strata) -> None:
    lo, hi = recording_interval(HIT, recording, strata=strata)
    assert lo < 0.5 < hi
    assert (lo, hi) == pytest.approx(CP_4_OF_8, abs=1e-9)


def test_clopper_pearson_fallback_holds_for_many_windows() -> None:
    # 1 hit in 5000 windows of one recording: beta.ppf(0.025, 1, 5000), beta.ppf(0.975, 2, 4999).
    hit = np.zeros(5000, bool)
    hit[0] = True
    lo, hi = recording_interval(hit, np.zeros(5000, int))
    assert (lo, hi) == pytest.approx((5.06354877705159e-06, 0.001113819380333972), rel=1e-6)


def test_accuracy_intervals_built_on_it() -> None:
    """The accuracy's interval (strata: the labels) of a rule right on every UAV window and
    wrong on every other is no longer the share itself; a lead of identical decisions is
    still exactly none (the difference is the same on every draw by construction)."""
    n = 20
    label = np.arange(n) < 10
    # 5 UAV and 5 UAV-free recordings: the fewest an interval is drawn from
    # (evaluation.MIN_INTERVAL_RECORDINGS).
    data = _data(label, np.arange(n) // 2)
    figures = identification_figures(np.ones(n, bool), np.linspace(0, 1, n), data, 0.5)
    lo, hi = figures["any_spike"]["accuracy_interval"]
    assert lo < 0.5 < hi
    right = np.ones(n, bool)
    assert accuracy_lead(right, right, data) == {"lead": 0.0, "interval": [0.0, 0.0]}


# ---------------------------------------------------------------- identification_figures


def test_identification_figures_checks_its_arguments() -> None:
    n = 20
    label = np.arange(n) < 10
    data = _data(label, np.arange(n) // 5)
    fired, scores = np.ones(n, bool), np.linspace(0, 1, n)
    for threshold in (math.nan, math.inf, "0.5", None):
        with pytest.raises(ParameterError, match="threshold"):
            identification_figures(fired, scores, data, threshold)
    for bad in (math.nan, math.inf):
        with pytest.raises(ParameterError, match="scores must be finite"):
            identification_figures(fired, np.where(label, bad, scores), data, 0.5)
    with pytest.raises(ParameterError, match="scores must be numbers"):
        identification_figures(fired, ["x"] * n, data, 0.5)
    with pytest.raises(ShapeError, match="scores 3"):
        identification_figures(fired, scores[:3], data, 0.5)
    for pairs in ([(1.5, 0.5)], [(-0.1, 0.5)], [(0.01, math.nan)], [(0.01,)], [0.01], 0.01):
        with pytest.raises(ParameterError, match="alarm_thresholds"):
            identification_figures(fired, scores, data, 0.5, alarm_thresholds=pairs)
    for points in (-5, 0, 1, 2.5, True):
        with pytest.raises(ParameterError, match="roc_points"):
            identification_figures(fired, scores, data, 0.5, roc_points=points)
    # NumPy numbers as the rest of the package takes them, and a list of pairs.
    got = identification_figures(
        fired,
        scores,
        data,
        np.float32(0.5),
        alarm_thresholds=[[0.01, 0.75]],
        roc_points=np.int64(2),
    )
    assert len(got["roc"]["false_alarm"]) == 2 and got["threshold"] == 0.5
    assert got["at_tuned_false_alarm"][0]["threshold"] == 0.75


# ---------------------------------------------------------------- track_eval


def test_decision_figures_takes_flags_only() -> None:
    classes = ["drone", "bird"]
    with pytest.raises(ParameterError, match="uav must be boolean"):
        track_eval.decision_figures(["False", "False"], ["False", "False"], classes)
    with pytest.raises(ParameterError, match="alarmed must be boolean"):
        track_eval.decision_figures([True, False], [math.nan, 0.0], classes)
    with pytest.raises(ShapeError, match="1-D"):
        track_eval.decision_figures(True, False, "drone")
    with pytest.raises(ShapeError, match="one entry per recording"):
        track_eval.decision_figures([True], [True, False], classes)
    # What worked before: lists of flags, arrays, and no recording at all.
    assert (
        track_eval.decision_figures([True, False], np.array([True, False]), classes)["right"] == 2
    )
    assert track_eval.decision_figures([], [], [])["accuracy"] is None


def test_track_eval_names_bad_numbers() -> None:
    with pytest.raises(ParameterError, match="confidence"):
        track_eval.poisson_upper(0, "0.9")
    assert track_eval.poisson_upper(0, np.float64(0.95)) == pytest.approx(2.996, abs=1e-3)
    for value in ("5", math.nan, True):
        with pytest.raises(ParameterError, match="value"):
            track_eval.ms_text(value)
    assert (track_eval.ms_text(137.5), track_eval.ms_text(None)) == ("137.5", "–")
    assert track_eval.ms_text(np.float64(12.0)) == "12"


# ---------------------------------------------------------------- roc and evaluation


def test_roc_names_bad_arguments() -> None:
    scores, actual, rec = np.arange(8.0), HIT, np.arange(8)
    with pytest.raises(ParameterError, match="scores must be numbers"):
        roc.roc_area(["a", "b"], [True, False])
    for kwargs, name in (
        ({"level": "0.9"}, "level"),
        ({"seed": -1}, "seed"),
        ({"seed": 1.5}, "seed"),
        ({"resamples": "5"}, "resamples"),
    ):
        with pytest.raises(ParameterError, match=name):
            recording_interval(HIT, rec, **kwargs)
    for kwargs, name in (({"seed": -1}, "seed"), ({"level": "0.9"}, "level")):
        with pytest.raises(ParameterError, match=name):
            roc.roc_point_interval(scores, actual, rec, 0.1, **kwargs)
    with pytest.raises(ParameterError, match="rate"):
        roc.roc_point_interval(scores, actual, rec, "0.1")
    with pytest.raises(ParameterError, match="against must be numbers"):
        roc.roc_point_draws(scores, actual, rec, 0.1, against=["x"] * 8)
    with pytest.raises(ParameterError, match="hit must be boolean"):
        recording_interval([1.0, 0.0], [0, 1])


def test_numpy_counts_and_empty_lists_are_taken() -> None:
    rec = np.arange(8)
    assert recording_interval(HIT, rec, resamples=np.int64(10), seed=np.int64(1)) == (
        recording_interval(HIT, rec, resamples=10, seed=1)
    )
    draws = roc.roc_point_draws(np.arange(8.0), HIT, rec, 0.1, resamples=np.int64(5))
    assert len(draws) == 5
    # An empty list is no windows (NumPy reads [] as float64): no ROC area, an empty matrix.
    assert roc.roc_area([], []) is None
    assert confusion_matrix([], []).tolist() == [[0, 0], [0, 0]]
    assert all(np.isnan(recording_interval([], [])))


def test_evaluation_names_bad_boxes_and_counts() -> None:
    with pytest.raises(ParameterError, match="boxes must be numbers"):
        box_iou([["a"] * 4], [[0, 0, 1, 1]])
    for matrix in ([[math.nan, 1], [1, 1]], [[2.5, 1], [1, 1]], [[-1, 1], [1, 1]]):
        with pytest.raises(ParameterError, match="whole counts"):
            accuracy(matrix)
    with pytest.raises(ParameterError, match="matrix must be numbers"):
        accuracy([["a", 1], [1, 1]])
    assert accuracy(np.array([[2.0, 1.0], [1.0, 1.0]])) == 0.6


# ---------------------------------------------------------------- false_alarms


def test_false_alarms_names_bad_arguments() -> None:
    with pytest.raises(ParameterError, match="seed"):
        false_alarms.uav_free_scenes(-1, 3)
    with pytest.raises(ParameterError, match="recordings"):
        false_alarms.uav_free_scenes(0, 2.5)
    assert false_alarms.uav_free_scenes(np.int64(0), np.int64(3)) == false_alarms.uav_free_scenes(
        0, 3
    )
    with pytest.raises(ParameterError, match="peaks must be a sequence"):
        false_alarms.track_alarm_threshold(0.5, 1, 0.1)
    with pytest.raises(ParameterError, match="peaks must be a sequence"):
        false_alarms.track_alarm_threshold([0.5, None], 1, 0.1)
    with pytest.raises(ParameterError, match="minutes must be positive"):
        false_alarms.track_alarm_threshold([0.5], True, 0.1)
    for floor in (math.nan, math.inf, "0"):
        with pytest.raises(ParameterError, match="floor"):
            false_alarms.track_alarm_threshold([], 1, 0.1, floor=floor)
    assert false_alarms.track_alarm_threshold([], 1, 0.1, floor=-math.inf) == -math.inf


@pytest.mark.parametrize("minutes", [np.int64(1), np.float32(1), np.float64(1.0)])
def test_false_alarms_take_numpy_numbers(minutes) -> None:
    want = false_alarms.track_alarm_threshold([0.5, 0.4], 1, 0.1)
    assert false_alarms.track_alarm_threshold([0.5, 0.4], minutes, 0.1) == want
    assert false_alarms.scene_batches(minutes, np.int64(0)) == false_alarms.scene_batches(1, 0)


def test_false_alarm_table_of_no_recording() -> None:
    text = false_alarms.false_alarm_table(false_alarms.summarise([], {"any_spike": None}))
    assert "| any-spike | 0.00 % | 0 | – (–) | 0 | – |" in text
    assert "0 UAV-free recordings, 0.00 minutes, 0 windows." in text


def test_every_refusal_is_a_uavsnn_error() -> None:
    """The snippets of the report, each an error of the package (a ValueError too)."""
    calls = [
        lambda: roc.roc_area(["a", "b"], [True, False]),
        lambda: track_eval.ms_text("5"),
        lambda: false_alarms.uav_free_scenes(0, 2.5),
        lambda: accuracy([[math.nan, 1], [1, 1]]),
    ]
    for call in calls:
        with pytest.raises(UavsnnError):
            call()


def _data(label: np.ndarray, recording: np.ndarray) -> LabelledWindows:
    """Windows without spikes, one every 1000 µs, labelled ``label``, of ``recording``."""
    n = len(label)
    windows = Windows(
        (20, 10), 1000, np.arange(n, dtype=np.uint64) * 1000, np.zeros(n + 1, np.int64),
        np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64),
        np.zeros(n, np.int64),
    )  # fmt: skip
    return LabelledWindows(
        windows, label, np.where(label, "drone", "bird"), recording,
        np.full((n, 4), np.nan, np.float32), size_px=np.full(n, 8.0, np.float32),
        range_m=np.full(n, 30.0, np.float32),
    )  # fmt: skip
