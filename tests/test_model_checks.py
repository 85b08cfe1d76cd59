"""Bad input to identification's fit and thresholds, the Identifier, the tracker's boxes,
merge_boxes, convert's layout and the window overlap: each is a typed error naming the
argument, never read as something else (a string as a flag, NaN features as a loss), and a
refused call leaves the tracker as it was."""

from __future__ import annotations

import numpy as np
import pytest
from test_tracks import STEP, report

from uavsnn import EVENT_DTYPE, ParameterError, Recording, ShapeError, UavsnnError
from uavsnn.events import convert
from uavsnn.grouping import _NO_DETECTIONS, WindowReport, merge_boxes
from uavsnn.identify import (
    FEATURES,
    Identifier,
    WindowFeatures,
    alarm_note,
    best_threshold,
    fit,
    fit_score,
    threshold_accuracies,
)
from uavsnn.network import WINDOW_DETECTION_DTYPE
from uavsnn.tracks import Tracker, track_windows
from uavsnn.windows import make_windows, window_step


def features(n: int, seed: int) -> WindowFeatures:
    """``n`` windows of one object each, half of them UAVs, told apart by the width."""
    rng = np.random.default_rng(seed)
    label = np.arange(n) % 2 == 0
    x = rng.normal(size=(n, len(FEATURES)))
    x[:, FEATURES.index("log_width")] += np.where(label, 1.5, -1.5)
    return WindowFeatures(x, np.arange(n), np.zeros((n, 4), np.int64), n, label, np.ones(n, bool))


# ---------------------------------------------------------------- flags are booleans


SCORES = np.linspace(0.0, 1.0, 40)
STRINGS = np.array(["False"] * 20 + ["True"] * 20)


@pytest.mark.parametrize(
    "label", [STRINGS, np.full(40, np.nan), np.arange(40) % 2], ids=["strings", "nan", "ints"]
)
def test_thresholds_refuse_labels_that_are_not_booleans(label: np.ndarray) -> None:
    # "False" was True: every window a UAV, and a threshold came back.
    with pytest.raises(ParameterError, match="label must be boolean"):
        best_threshold(SCORES, label)
    with pytest.raises(ParameterError, match="label must be boolean"):
        threshold_accuracies(SCORES, label)


def test_thresholds_still_take_booleans_and_no_windows() -> None:
    label = SCORES > 0.5
    assert best_threshold(SCORES, label) == best_threshold(SCORES, list(label))
    assert best_threshold([], []) == 0.5
    assert best_threshold(np.zeros(0), np.zeros(0, bool)) == 0.5
    with pytest.raises(ShapeError):
        best_threshold(SCORES, np.zeros(0, bool))  # not one label a score


def test_alarm_note_refuses_labels_that_are_not_booleans() -> None:
    # "False" × 5 was read as 5 UAV windows: "hold no UAV-free window".
    with pytest.raises(ParameterError, match="tune_label must be boolean"):
        alarm_note(["False"] * 5, [(0.01, 0.5)])
    with pytest.raises(ShapeError, match="tune_label"):
        alarm_note(np.ones((2, 2), bool), [(0.01, 0.5)])
    assert "5 UAV-free windows" in alarm_note([False] * 5, [(0.01, 0.5)])


def test_best_threshold_refuses_a_within_that_is_not_a_number() -> None:
    for bad in ("0.1", None, True):
        with pytest.raises(ParameterError, match="within"):
            best_threshold(SCORES, SCORES > 0.5, within=bad)  # type: ignore[arg-type]
    assert best_threshold(SCORES, SCORES > 0.5, within=np.float64(0.0)) == best_threshold(
        SCORES, SCORES > 0.5
    )


def test_fit_refuses_tuning_flags_that_are_not_booleans_or_not_one_a_window() -> None:
    train, tune = features(80, 0), features(40, 1)
    label = tune.label
    with pytest.raises(ParameterError, match="tune_detected must be boolean"):
        fit(train, tune, tune_detected=np.array(["False"] * 40), tune_label=label)
    with pytest.raises(ParameterError, match="tune_label must be boolean"):
        fit(train, tune, tune_detected=np.ones(40, bool), tune_label=label.astype(float))
    # a broadcast ValueError before
    with pytest.raises(ShapeError, match="one flag a window of tune"):
        fit(train, tune, tune_detected=np.ones(3, bool), tune_label=label[:3])
    with pytest.raises(ShapeError, match="one flag a window of tune"):
        fit(train, tune, tune_detected=np.ones(40, bool), tune_label=label[:39])
    ident = fit(train, tune, tune_detected=np.ones(40, bool), tune_label=list(label))
    assert (
        ident.threshold
        == fit(train, tune, tune_detected=np.ones(40, bool), tune_label=label).threshold
    )


def test_fit_refuses_an_unknown_feature() -> None:
    train = features(40, 0)
    with pytest.raises(ParameterError, match=r"unknown \['nope'\]"):
        fit(train, train, features=("nope",))


# ---------------------------------------------------------------- fit_score's arrays


def plain(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(60, 3))
    return x, x[:, 0] > 0


def test_fit_score_refuses_nan_tuning_features() -> None:
    # every loss was NaN and the first L2 weight kept, without a word
    x, y = plain(0)
    bad = x.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ParameterError, match="x_tune holds NaN"):
        fit_score(x, y, bad, y)
    train, tune = features(80, 0), features(40, 1)
    tune.x[0, 0] = np.nan
    with pytest.raises(ParameterError, match="x_tune holds NaN"):
        fit(train, tune, model="logistic")


def test_fit_score_refuses_bad_arrays_by_name() -> None:
    x, y = plain(0)
    with pytest.raises(ParameterError, match="x must hold at least one row"):
        fit_score(np.zeros((0, 3)), np.zeros(0, bool), np.zeros((0, 3)), np.zeros(0, bool))
    with pytest.raises(ParameterError, match="l2_grid"):
        fit_score(x, y, x, y, l2_grid=[])
    with pytest.raises(ParameterError, match="l2_grid"):
        fit_score(x, y, x, y, l2_grid=["1.0"])
    with pytest.raises(ShapeError, match="x_tune must be"):
        fit_score(x, y, x[:, :2], y)
    with pytest.raises(ShapeError, match="x_tune must be"):
        fit_score(x, y, x, y[:10])
    with pytest.raises(ParameterError, match="y_tune must be boolean"):
        fit_score(x, y, x, np.array(["False"] * len(y)))
    with pytest.raises(ParameterError, match="x_tune must be numbers"):
        fit_score(x, y, [["a", "b", "c"]], [True])
    _, _, coef, l2 = fit_score(x, y, x, y, l2_grid=(np.float64(0.1), 1))
    assert l2 in (0.1, 1.0) and coef.shape == (4,)


# ---------------------------------------------------------------- the Identifier


def model(**changes: object) -> Identifier:
    given: dict = {
        "features": ("log_width", "log_height"),
        "coef": np.array([0.5, -0.25, 0.1]),
        "mean": np.zeros(2),
        "scale": np.ones(2),
        "threshold": 0.4,
        "l2": 1.0,
    }
    return Identifier(**(given | changes))


def test_identifier_takes_lists_for_its_arrays() -> None:
    # an AttributeError before (a list has no shape)
    ident = model(coef=[0.5, -0.25, 0.1], mean=[0.0, 0.0], scale=[1.0, 1.0])
    np.testing.assert_array_equal(ident.scores(np.ones((2, 2))), model().scores(np.ones((2, 2))))
    with pytest.raises(ParameterError, match="coef must be numbers"):
        model(coef=["a", "b", "c"])


def test_identifier_refuses_what_is_not_a_number_by_what_it_got() -> None:
    # "threshold must be finite, got nan" for a string before
    with pytest.raises(ParameterError, match=r"threshold must be a number, got '0\.5'"):
        model(threshold="0.5")
    with pytest.raises(ParameterError, match="l2 must be a number, got True"):
        model(l2=True)
    # a ValueError from unpacking before
    with pytest.raises(ParameterError, match="alarm_thresholds must be"):
        model(alarm_thresholds=((0.1,),))
    with pytest.raises(ParameterError, match="alarm_thresholds must be"):
        model(alarm_thresholds=None)
    with pytest.raises(ParameterError, match="track_alarm_thresholds must pair two numbers"):
        model(track_alarm_thresholds=(("0.1", 0.5),), track_alarm_minutes=10.0)
    ok = model(alarm_thresholds=np.array([[0.01, 0.9]]))
    assert ok.alarm_thresholds == ((0.01, 0.9),)


# ---------------------------------------------------------------- the tracker's boxes


@pytest.mark.parametrize(
    "box",
    [
        ("a", 10, 14, 14),
        (np.nan, 10, 14, 14),
        (14, 10, 10, 14),
        (10, 14, 14, 10),
        (10, 10, 14),
        (True, 10, 14, 14),
        None,
    ],
    ids=["string", "nan", "x-inverted", "y-inverted", "three", "bool", "none"],
)
def test_tracker_refuses_a_bad_box_and_stays_as_it_was(box: object) -> None:
    tracker = Tracker()
    tracker.update(report(0, [(10, 10, 14, 14)]))
    before = tracker.live
    with pytest.raises(ParameterError, match="object 0 of window 1: a box must be"):
        tracker.update(report(1, [box]))
    assert tracker.live == before
    # the failed call did not take window 1: a valid one for it is accepted
    after = tracker.update(report(1, [(10, 10, 14, 14)]))
    assert after.objects[0].track_id == 1
    assert tracker.live[0].hits == 2


def test_tracker_takes_every_valid_box() -> None:
    boxes = [(10, 10, 14, 14), (30, 30, 30, 30), (50.5, 50, 52.5, 52), np.array([70, 5, 74, 9])]
    result = track_windows([report(k, boxes) for k in range(3)])
    assert [o.track_id for o in result.reports[-1].objects] == [1, 2, 3, 4]
    with pytest.raises(ParameterError, match="must be a WindowObject"):
        Tracker().update(
            WindowReport(0, 0, STEP, True, _NO_DETECTIONS, ((10, 10, 14, 14),))  # type: ignore[arg-type]
        )


# ---------------------------------------------------------------- merge_boxes, convert, overlap


def test_merge_boxes_refuses_what_is_not_detections() -> None:
    for bad in (np.zeros(3), np.zeros(3, dtype=[("x0", "<i4"), ("y0", "<i4")]), 5, [(1, 2, 3, 4)]):
        with pytest.raises(ParameterError, match="detections must be a 1-D structured array"):
            merge_boxes(bad)  # type: ignore[arg-type]
    d = np.zeros(2, dtype=WINDOW_DETECTION_DTYPE)
    d["x1"], d["y1"] = 4, 4
    assert [(o.box, o.spikes) for o in merge_boxes(d)] == [((0, 0, 4, 4), 2)]
    assert merge_boxes(d[:0]) == () and merge_boxes([]) == ()


def test_convert_refuses_a_layout_that_is_not_a_name() -> None:
    plain_events = np.zeros((2, 4), np.int64)
    for bad in ([], None, 3):
        with pytest.raises(ParameterError, match="unknown layout"):
            convert(plain_events, layout=bad)  # type: ignore[arg-type]
    assert len(convert(plain_events, layout="canonical")) == 2


def test_overlap_refuses_strings_and_bools() -> None:
    events = np.zeros(3, EVENT_DTYPE)
    events["t"] = [0, 10, 30]
    recording = Recording(events, (8, 8))
    for bad in ("0.5", b"0.5", False, True, np.bool_(False)):
        with pytest.raises(ParameterError, match="overlap must be a number"):
            make_windows(recording, 20, overlap=bad)  # type: ignore[arg-type]
        with pytest.raises(ParameterError, match="overlap must be a number"):
            window_step(20, bad)  # type: ignore[arg-type]
    for good in (0.5, 0, np.float32(0.5), np.float64(0.5), np.int64(0)):
        assert window_step(20, good) == (10 if good else 20)  # type: ignore[arg-type]
    assert len(make_windows(recording, 20, overlap=0.5)) == len(
        make_windows(recording, 20, overlap=np.float64(0.5))
    )


def test_every_refusal_here_is_a_uavsnn_error() -> None:
    for call in (
        lambda: best_threshold(SCORES, STRINGS),
        lambda: model(threshold="0.5"),
        lambda: merge_boxes(np.zeros(3)),
        lambda: convert(np.zeros((2, 4), np.int64), layout=[]),  # type: ignore[arg-type]
    ):
        with pytest.raises(UavsnnError):
            call()


def test_one_window_out_of_range_is_named_as_the_caller_gave_it() -> None:
    # Windows.spikes(99) said "indices[0]=99", an argument the caller never passed.
    events = np.zeros(5, EVENT_DTYPE)
    events["t"] = np.arange(5) * 10_000
    windows = make_windows(Recording(events, (10, 10)), 20_000)
    with pytest.raises(ParameterError, match=r"^i=99 is out of range for 3 windows"):
        windows.spikes(99)
    with pytest.raises(ParameterError, match=r"^i must be integers"):
        windows.spikes(1.5)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match=r"^indices\[1\]=99 is out of range"):
        windows.select([0, 99])
