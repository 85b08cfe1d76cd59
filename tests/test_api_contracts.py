"""What docs/api.md promises of the Python API against what it does: "every error is a
uavsnn.UavsnnError subclass", and each function's arguments as the page lists them. Each case
here came out as a plain Python error or a silent wrong answer before."""

from __future__ import annotations

import numpy as np
import pytest

import uavsnn
from uavsnn import evaluation, identify
from uavsnn.errors import EventError, ParameterError, ShapeError
from uavsnn.events import EVENT_DTYPE
from uavsnn.network import Inference, Network
from uavsnn.signature import rotor_signature, rotor_spectrum
from uavsnn.sim import Pix2NvsParams
from uavsnn.windows import make_windows


def test_boxes_of_another_shape_are_shape_errors() -> None:
    # (4,) boxes raised IndexError ("too many indices").
    for boxes in (np.zeros(4), np.zeros((2, 2, 4)), np.zeros((3, 5))):
        with pytest.raises(ShapeError, match=r"boxes must be \(n, 4\)"):
            evaluation.box_iou(boxes, boxes)
        with pytest.raises(ShapeError, match=r"boxes must be \(n, 4\)"):
            evaluation.centre_distance(boxes, boxes)
    assert evaluation.box_iou(np.zeros((0, 4)), np.zeros((0, 4))).shape == (0,)


def test_first_detection_boxes_takes_a_count_of_windows() -> None:
    net = Network({"width": 16, "height": 12})
    events = np.zeros(3, dtype=EVENT_DTYPE)
    events["t"] = [1, 2, 3]
    windows = make_windows(uavsnn.Recording(events, (16, 12)), 5_000)
    inference: Inference = net.infer(windows)
    boxes = evaluation.first_detection_boxes(inference, len(windows))
    assert boxes.shape == (len(windows), 4) and np.isnan(boxes).all()
    # the windows themselves (what api.md listed) raised TypeError
    with pytest.raises(ParameterError, match="windows must be an integer"):
        evaluation.first_detection_boxes(inference, windows)  # type: ignore[arg-type]


def test_threads_out_of_range_say_the_range() -> None:
    # threads=0 said "must be in [1, 18446744073709551615]"; the limit is MAX_THREADS.
    net = Network({"width": 16, "height": 12})
    events = np.zeros(1, dtype=EVENT_DTYPE)
    windows = make_windows(uavsnn.Recording(events, (16, 12)), 5_000)
    with pytest.raises(ParameterError, match="threads must be an integer >= 1, got 0"):
        net.infer(windows, threads=0)


@pytest.mark.parametrize("rate", ["0.01", None, float("nan")])
def test_an_operating_point_asked_for_by_other_than_a_number_is_refused(rate: object) -> None:
    ident = identify.Identifier(
        features=identify.FEATURES,
        coef=np.zeros(len(identify.FEATURES) + 1),
        mean=np.zeros(len(identify.FEATURES)),
        scale=np.ones(len(identify.FEATURES)),
        threshold=0.5,
        l2=1.0,
        alarm_thresholds=((0.01, 0.9),),
    )
    assert ident.at_false_alarm(0.01).threshold == 0.9
    for call in (ident.at_false_alarm, ident.at_false_tracks):
        with pytest.raises(ParameterError, match="rate must be"):
            call(rate)  # type: ignore[arg-type]


def test_the_released_pix2nvs_refuses_an_option_it_has_not() -> None:
    assert Pix2NvsParams.original(threshold=0.2).threshold == 0.2
    # an unknown name raised TypeError; compat=False was overwritten silently
    with pytest.raises(ParameterError, match="no option 'bogus'"):
        Pix2NvsParams.original(bogus=1)
    with pytest.raises(ParameterError, match="no option 'compat'"):
        Pix2NvsParams.original(compat=False)


def test_nan_scores_are_refused_where_thresholds_are_set() -> None:
    # threshold_at_false_alarm gave 1.0000000000000002 and best_threshold 0.8 with a NaN score.
    label = np.array([True, True, False, False, False])
    nan = np.array([np.nan, 1.0, 1.0, 0.0, 0.0])
    for call in (
        lambda: evaluation.threshold_at_false_alarm(nan, label, 0.01),
        lambda: evaluation.detection_at_false_alarm(nan, label, 0.01),
        lambda: uavsnn.roc.roc_area(nan, label),
        lambda: identify.best_threshold(nan, label),
        lambda: identify.threshold_accuracies(nan, label),
    ):
        with pytest.raises(ParameterError, match="scores hold NaN"):
            call()
    with pytest.raises(ShapeError, match="one a window"):
        evaluation.detection_at_false_alarm(np.zeros(3), label, 0.01)
    with pytest.raises(ParameterError, match="rate must be a number"):
        evaluation.threshold_at_false_alarm(np.zeros(5), label, "0.01")  # type: ignore[arg-type]
    # -inf stays a score (never an alarm), and no windows still give best_threshold's 0.5
    assert evaluation.threshold_at_false_alarm(np.full(5, -np.inf), label, 0.5) > -np.inf
    assert identify.best_threshold(np.zeros(0), np.zeros(0, bool)) == 0.5


@pytest.mark.parametrize("estimate", [rotor_signature, rotor_spectrum])
def test_a_batch_rotor_estimate_refuses_events_out_of_time_order(estimate: object) -> None:
    # Reversed events gave an all-zero estimate without a word.
    events = np.zeros(6, dtype=EVENT_DTYPE)
    events["t"], events["x"], events["y"] = [10, 20, 30, 25, 40, 50], 3, 3
    with pytest.raises(EventError, match=r"event 3: t=25 is earlier .* \(t=30\)"):
        estimate(events, (0, 0, 8, 8))  # type: ignore[operator]
    events["t"] = [10, 20, 30, 35, 40, 50]
    estimate(events, (0, 0, 8, 8))  # type: ignore[operator]
