"""Evaluation: the counts on hand-made predictions, latency, refusals, and that a saved model
scores the same after loading."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import uavsnn
from uavsnn.dataset import LabelledWindows, SceneSource, build, load
from uavsnn.errors import DatasetError, ParameterError, ShapeError
from uavsnn.evaluation import (
    accuracy,
    box_iou,
    confusion_matrix,
    evaluate,
    first_detection_boxes,
    first_spike_in_box,
    score,
)
from uavsnn.network import WINDOW_DETECTION_DTYPE, Inference
from uavsnn.windows import Windows

NAN4 = [np.nan] * 4


def test_confusion_matrix_on_hand_made_predictions() -> None:
    predicted = np.array([1, 1, 0, 0, 1, 0, 0], dtype=bool)
    actual = np.array([1, 0, 1, 0, 1, 0, 0], dtype=bool)
    m = confusion_matrix(predicted, actual)
    assert m.tolist() == [[2, 1], [1, 3]]
    assert accuracy(m) == pytest.approx(5 / 7)


@given(st.lists(st.tuples(st.booleans(), st.booleans()), max_size=60))
def test_confusion_matrix_counts_every_window_once(pairs: list[tuple[bool, bool]]) -> None:
    p = np.array([a for a, _ in pairs], dtype=bool)
    a = np.array([b for _, b in pairs], dtype=bool)
    (tp, fn), (fp, tn) = confusion_matrix(p, a).tolist()
    assert tp == sum(x and y for x, y in pairs)
    assert fn == sum((not x) and y for x, y in pairs)
    assert fp == sum(x and not y for x, y in pairs)
    assert tn == sum(not x and not y for x, y in pairs)
    if pairs:
        assert accuracy([[tp, fn], [fp, tn]]) == sum(x == y for x, y in pairs) / len(pairs)
    else:
        assert np.isnan(accuracy([[tp, fn], [fp, tn]]))


def test_confusion_matrix_refuses_bad_input() -> None:
    with pytest.raises(ShapeError, match="predicted has 2 windows, actual 3"):
        confusion_matrix(np.zeros(2, bool), np.zeros(3, bool))
    with pytest.raises(ParameterError, match="boolean"):
        confusion_matrix(np.zeros(2, int), np.zeros(2, bool))
    with pytest.raises(ShapeError, match="2x2"):
        accuracy(np.zeros((3, 2)))


def _windows(spikes: list[list[tuple[int, int, int]]], size: tuple[int, int] = (20, 10)) -> Windows:
    """Windows of 1000 µs starting every 1000 µs, with the given (t offset, x, y) spikes."""
    t0 = np.arange(len(spikes), dtype=np.uint64) * 1000
    offsets = np.cumsum([0] + [len(s) for s in spikes]).astype(np.int64)
    flat = [(int(t0[i]) + dt, x, y) for i, s in enumerate(spikes) for dt, x, y in s]
    cols = np.array(flat, dtype=np.int64).reshape(-1, 3)
    return Windows(
        size, 1000, t0, offsets, cols[:, 0], cols[:, 1], cols[:, 2], np.zeros(len(spikes), np.int64)
    )


def _labelled(windows: Windows, label: list[bool], cls: list[str], box: object) -> LabelledWindows:
    n = len(windows)
    return LabelledWindows(
        windows,
        np.array(label, dtype=bool),
        np.array(cls, dtype="<U12"),
        np.zeros(n, np.int64),
        np.array(box, dtype=np.float32),
    )


def _inference(
    detected: list[bool], first_t: list[int], detections: np.ndarray | None = None
) -> Inference:
    """An inference of hand-made calls, with zero layer counts and thresholds."""
    n = len(detected)
    return Inference(
        detected=np.array(detected),
        counts=np.zeros((n, 5), np.int64),
        first_detection_t=np.array(first_t, dtype=np.uint64),
        detections=np.zeros(0, WINDOW_DETECTION_DTYPE) if detections is None else detections,
        thresholds=np.zeros((n, 4), np.float32),
    )


def test_first_spike_in_box() -> None:
    w = _windows([[(1, 0, 0), (5, 4, 4), (9, 5, 5)], [], [(2, 1, 1)], [(3, 7, 2)]])
    boxes = np.array([[4, 4, 6, 6], [0, 0, 20, 10], NAN4, [0, 0, 5, 5]], dtype=np.float32)
    assert first_spike_in_box(w, boxes).tolist() == [5, -1, -1, -1]


def test_first_spike_in_box_counts_a_pixel_by_its_centre() -> None:
    # Boxes of scaled labels have fractional edges: pixel x covers [x, x + 1), and it is in a
    # box when its centre x + 1/2 is, an edge through the centre counting as inside.
    w = _windows(
        [
            [(1, 2, 0), (3, 3, 0)],  # centre 2.5 >= 2.4: pixel 2 is in
            [(1, 5, 0), (4, 4, 0)],  # centre 5.5 >= 5.4: pixel 5 is out, pixel 4 in
            [(1, 2, 0), (3, 3, 0)],  # an edge at 2.5, through pixel 2's centre
            [(1, 0, 2), (3, 0, 3)],  # the same in y
            [(1, 0, 5), (3, 0, 4)],
        ]
    )
    boxes = np.array(
        [
            [2.4, 0, 5.4, 10],
            [2.4, 0, 5.4, 10],
            [2.5, 0, 4, 10],
            [0, 2.5, 20, 4],
            [0, 2.4, 20, 5.4],
        ],
        dtype=np.float32,
    )
    assert first_spike_in_box(w, boxes).tolist() == [1, 1004, 2001, 3001, 4003]


def _detections(rows: list[tuple[int, int, list[int]]]) -> np.ndarray:
    """Detections of (window, t, box x0, y0, x1, y1), in the order given."""
    out = np.zeros(len(rows), dtype=WINDOW_DETECTION_DTYPE)
    for i, (window, t, box) in enumerate(rows):
        out[i]["window"], out[i]["t"] = window, t
        for k, v in zip(("x0", "y0", "x1", "y1"), box, strict=True):
            out[i][k] = v
    return out


def test_latency_leaves_out_detections_with_no_input_spike_in_the_box() -> None:
    # Two detected drones: the first's box holds an input spike (at 5), the second's none.
    w = _windows([[(5, 4, 4)], [(2, 0, 0)]])
    data = _labelled(w, [True, True], ["drone", "drone"], [[4, 4, 5, 5], [10, 5, 12, 7]])
    detections = _detections([(0, 30, [3, 3, 6, 6]), (1, 1040, [10, 5, 12, 7])])
    inference = _inference([True, True], [30, 1040], detections)
    e = score(inference, data)
    assert e.latency_us.tolist() == [25]
    assert e.latency_from_start_us.tolist() == [30, 40]
    assert (e.latency_no_spike_in_box, e.latency_not_caused) == (1, 0)


def test_latency_runs_to_a_detection_the_uav_can_have_caused() -> None:
    """A detection before the UAV's first input spike in its box, or boxed off the UAV, was
    caused by something else: the latency runs to the first detection at or after that spike
    whose box overlaps the labelled one, and a window without one is left out of the latency
    (counted), while it stays a true positive."""
    # The UAV's first input spike in its box [10, 12) x [4, 6) comes 20 µs into each window
    # (windows start every 1000 µs); a spike elsewhere 1 µs in (a bird at (2, 2)).
    w = _windows([[(1, 2, 2), (20, 10, 4), (30, 11, 5)]] * 4 + [[(1, 2, 2)]])
    on_uav, off = [9, 3, 13, 7], [0, 0, 5, 5]
    detections = _detections(
        [
            (0, 5, on_uav),  # before the UAV's first spike (20), though boxed on it
            (1, 1030, off),  # after it, boxed off it
            (2, 2003, off),  # caused by the bird ...
            (2, 2025, on_uav),  # ... then by the UAV: 5 µs after its first spike
            (3, 3020, on_uav),  # at the UAV's first spike itself
            (4, 4003, off),  # a false positive
        ]
    )
    data = _labelled(
        w,
        [True, True, True, True, False],
        ["drone"] * 4 + ["bird"],
        [[10, 4, 12, 6]] * 4 + [[2, 2, 3, 3]],
    )
    inference = _inference([True] * 5, [5, 1030, 2003, 3020, 4003], detections)
    e = score(inference, data)
    # What counts as detected does not move: four true positives and a false one.
    assert e.confusion.tolist() == [[4, 0], [1, 0]]
    assert e.latency_us.tolist() == [5, 0]
    assert (e.latency_us >= 0).all()
    assert (e.latency_no_spike_in_box, e.latency_not_caused) == (0, 2)
    # From the window's start to its first detection, over every true positive.
    assert e.latency_from_start_us.tolist() == [5, 30, 3, 20]
    d = e.to_dict()
    assert d["latency_us"]["n"] == 2 and d["latency_us"]["median"] == 2.5
    assert d["latency_left_out"] == {"no_spike_in_box": 0, "not_caused": 2}
    from uavsnn.evaluation import first_detection_on_box, first_spike_in_box

    caused = first_detection_on_box(inference, data.box, first_spike_in_box(w, data.box))
    # (the bird's window, too: the function reads boxes, not labels)
    assert caused.tolist() == [-1, -1, 2025, 3020, 4003]
    from uavsnn.report import evaluation_markdown

    text = evaluation_markdown(e)
    assert "Latency in event time over 2 true positives" in text
    assert "Left out: 2 whose every detection came before the first input spike" in text
    # Only detections before the UAV's spike: no latency at all, said so.
    early = _inference([True], [5], _detections([(0, 5, on_uav)]))
    one = _labelled(_windows([[(1, 2, 2), (20, 10, 4)]]), [True], ["drone"], [[10, 4, 12, 6]])
    alone = score(early, one)
    assert alone.latency_us.size == 0 and alone.latency_not_caused == 1
    assert "No latency from the UAV's first input spike: of 1 true positives, 1 whose" in (
        evaluation_markdown(alone)
    )
    with pytest.raises(ShapeError, match="boxes must have shape"):
        first_detection_on_box(inference, data.box[:2], np.zeros(5, np.int64))


def test_score_per_class_latency_and_pixels() -> None:
    w = _windows([[(1, 0, 0), (5, 4, 4)], [(2, 4, 4)], [(3, 1, 1)], [(4, 2, 2), (6, 3, 3)]])
    data = _labelled(
        w,
        [True, True, False, False],
        ["drone", "drone", "bird", "none"],
        [[4, 4, 5, 5], [0, 0, 20, 10], [0, 0, 2, 2], NAN4],
    )
    # The drone window's first detection (at 25) has the zero box, off the drone's [4, 5)²;
    # its second (at 28) is boxed on it.
    detections = _detections(
        [(0, 25, [0, 0, 0, 0]), (0, 28, [4, 4, 5, 5]), (2, 2003, [1, 1, 2, 2])]
    )
    inference = _inference([True, False, True, False], [25, 0, 2003, 0], detections)
    e = score(inference, data, seconds=0.5)
    assert e.confusion.tolist() == [[1, 1], [1, 1]]
    assert e.accuracy == 0.5
    assert e.per_class["drone"].called_uav == 1 and e.per_class["drone"].correct == 1
    assert e.per_class["bird"].called_uav == 1 and e.per_class["bird"].correct == 0
    assert e.per_class["none"].correct == 1
    # the drone window's first spike in its box is at 5; the first detection it can have
    # caused (boxed on it) at 28
    assert e.latency_us.tolist() == [23]
    assert e.latency_from_start_us.tolist() == [25]
    assert e.pixel_fraction == pytest.approx(6 / 4 / 200)
    assert e.input_spikes == 6 and e.events_per_second == 12.0
    d = e.to_dict()
    assert (d["tp"], d["fn"], d["fp"], d["tn"]) == (1, 1, 1, 1)
    assert d["latency_us"]["median"] == 23.0
    # The true positive's first detection has the zero box: no overlap with [4, 5)², centres
    # (0, 0) and (4.5, 4.5).
    assert e.box_iou.tolist() == [0.0]
    assert e.box_centre_error_px.tolist() == pytest.approx([np.hypot(4.5, 4.5)])
    assert d["box_iou"]["n"] == 1
    # By object size: the drone of side 1 and the bird of side 2 (both called UAV) share the
    # first bin, the missed drone of side 20 is in the 12-24 px bin, the empty window in none.
    sizes = {z.label: z for z in e.per_size}
    assert list(sizes) == ["0-6 px", "12-24 px"]
    assert (sizes["0-6 px"].uav.windows, sizes["0-6 px"].uav.called_uav) == (1, 1)
    assert (sizes["0-6 px"].other.windows, sizes["0-6 px"].other.called_uav) == (1, 1)
    assert (sizes["12-24 px"].uav.windows, sizes["12-24 px"].uav.called_uav) == (1, 0)
    assert sizes["12-24 px"].other.windows == 0
    assert d["per_size"][1] == {
        "low_px": 12.0,
        "high_px": 24.0,
        "uav": {"windows": 1, "called_uav": 0},
        "other": {"windows": 0, "called_uav": 0},
    }


def test_per_size_bins_are_half_open_and_the_last_is_unbounded() -> None:
    w = _windows([[(1, 0, 0)]] * 4, size=(200, 100))
    # longer sides 6 (the second bin's low edge), 11.5, 48 and 150 (the last bin)
    data = _labelled(
        w,
        [True, False, True, False],
        ["drone", "ball", "drone", "helicopter"],
        [[0, 0, 6, 3], [0, 0, 2, 11.5], [10, 10, 58, 20], [0, 0, 150, 90]],
    )
    inference = _inference([False, True, True, True], [0, 0, 0, 0])
    sizes = {z.label: z for z in score(inference, data).per_size}
    assert list(sizes) == ["6-12 px", ">= 48 px"]
    six = sizes["6-12 px"]
    assert (six.uav.windows, six.uav.called_uav, six.other.windows, six.other.called_uav) == (
        1, 0, 1, 1,
    )  # fmt: skip
    big = sizes[">= 48 px"]
    assert (big.uav.windows, big.uav.called_uav, big.other.windows, big.other.called_uav) == (
        1, 1, 1, 1,
    )  # fmt: skip
    assert score(inference, data).to_dict()["per_size"][1]["high_px"] is None


def test_box_iou_on_hand_made_boxes() -> None:
    a = np.array([[0, 0, 4, 4], [0, 0, 4, 4], [0, 0, 2, 2], [1, 1, 1, 1]], dtype=np.float64)
    b = np.array([[0, 0, 4, 4], [2, 0, 6, 4], [5, 5, 6, 6], [1, 1, 1, 1]], dtype=np.float64)
    # same box; half overlapping (8 / 24); apart; two empty boxes (nothing to overlap)
    assert box_iou(a, b).tolist() == pytest.approx([1.0, 8 / 24, 0.0, 0.0])
    with pytest.raises(ShapeError):
        box_iou(a, b[:2])


def test_first_detection_boxes_take_each_windows_first_row() -> None:
    detections = np.zeros(3, dtype=WINDOW_DETECTION_DTYPE)
    detections["window"] = [1, 1, 3]
    detections["t"] = [5, 9, 2]
    for k, v in zip(
        ("x0", "y0", "x1", "y1"), ([1, 7, 2], [1, 7, 2], [3, 9, 4], [3, 9, 4]), strict=True
    ):
        detections[k] = v
    inference = _inference([False, True, False, True], [0, 5, 0, 2], detections)
    boxes = first_detection_boxes(inference, 4)
    assert np.isnan(boxes[[0, 2]]).all()
    assert boxes[1].tolist() == [1, 1, 3, 3] and boxes[3].tolist() == [2, 2, 4, 4]


def test_evaluate_refuses_what_cannot_be_scored_honestly() -> None:
    net = uavsnn.Network({"width": 20, "height": 10}, seed=0)
    w = _windows([[(1, 0, 0)], [(2, 3, 3)], [(3, 4, 4)]])
    unbalanced = _labelled(w, [True, False, False], ["drone", "none", "none"], [NAN4] * 3)
    with pytest.raises(DatasetError, match="unbalanced: 1 UAV and 2 other"):
        evaluate(net, unbalanced)
    assert evaluate(net, unbalanced, balanced=False).windows == 3
    empty = _labelled(_windows([]), [], [], np.zeros((0, 4)))
    with pytest.raises(DatasetError, match="empty"):
        evaluate(net, empty)
    other = uavsnn.Network({"width": 24, "height": 10}, seed=0)
    with pytest.raises(ShapeError, match="sensor is 20x10 but the model's input is 24x10"):
        evaluate(other, unbalanced, balanced=False)
    with pytest.raises(ParameterError, match="LabelledWindows"):
        evaluate(net, w)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def small_set(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("eval") / "set"
    build(
        root, "dvs", n_test=20, n_train=16, seed=5, dvs=SceneSource("dvs", (240, 180), 200.0, 0.3)
    )
    return root


def test_train_save_load_evaluate_gives_the_same_numbers(small_set: Path, tmp_path: Path) -> None:
    from uavsnn.training import train

    net = uavsnn.Network({"conv2": {"threshold": 15.0}}, seed=2)
    train(net, load(small_set, "train").windows, windows_per_layer=64, snapshots=0)
    test = load(small_set, "test")
    before = evaluate(net, test)
    net.save(tmp_path / "m.npz")
    after = evaluate(uavsnn.Network.load(tmp_path / "m.npz"), test)
    assert after.confusion.tolist() == before.confusion.tolist()
    assert after.per_class == before.per_class
    assert after.latency_us.tolist() == before.latency_us.tolist()


# ---------------------------------------------------------------- shares known from recordings


def _binomial_tail(n: int, k: int, p: float, *, upper: bool) -> float:
    """P(X >= k) (``upper``) or P(X <= k) for X binomial (n, p), summed exactly."""
    from math import comb

    ks = range(k, n + 1) if upper else range(k + 1)
    return sum(comb(n, j) * p**j * (1 - p) ** (n - j) for j in ks)


def _recorded(label: list[bool] | np.ndarray, recording: np.ndarray) -> LabelledWindows:
    """Windows of one spike each, with the given labels and recordings."""
    label = np.asarray(label, dtype=bool)
    n = len(label)
    return LabelledWindows(
        _windows([[(1, 0, 0)]] * n),
        label,
        np.where(label, "drone", "bird").astype("<U12"),
        np.asarray(recording, np.int64),
        np.full((n, 4), np.nan, dtype=np.float32),
    )


def test_an_interval_needs_enough_recordings_of_each_kind() -> None:
    """With fewer than MIN_INTERVAL_RECORDINGS recordings of a kind, the figures carry no
    interval over the recordings (a kind of one recording adds nothing to the draw); with
    enough, the interval is recording_interval's, as before."""
    from uavsnn.evaluation import (
        MIN_INTERVAL_RECORDINGS,
        accuracy_lead,
        identification_figures,
        interval_recordings,
        recording_interval,
    )
    from uavsnn.report import (
        evaluation_markdown,
        identification_markdown,
        interval_text,
        lead_text,
    )

    assert MIN_INTERVAL_RECORDINGS == 5
    label = np.arange(60) < 30
    rng = np.random.default_rng(0)
    called = rng.random(60) < np.where(label, 0.7, 0.3)
    scores = rng.random(60)
    # One UAV recording (the walk's: one drone clip), six UAV-free ones.
    few = np.where(label, 0, 1 + np.arange(60) % 6)
    # Five UAV recordings and six UAV-free.
    enough = np.where(label, 100 + np.arange(60) % 5, 1 + np.arange(60) % 6)
    assert interval_recordings(few, label) == 1 and interval_recordings(enough, label) == 5
    assert interval_recordings(few) == 7 and interval_recordings([]) == 0
    for recording, drawn in ((few, False), (enough, True)):
        data = _recorded(label, recording)
        e = score(_inference(called.tolist(), [0] * 60), data)
        expected = recording_interval(called == label, recording, strata=label)
        lo, hi = e.accuracy_interval
        if drawn:
            assert (lo, hi) == expected and lo <= e.accuracy <= hi
            assert "– in place of an interval" not in evaluation_markdown(e)
        else:
            assert np.isnan(lo) and np.isnan(hi)
            assert e.to_dict()["recordings"] == {"uav": 1, "uav_free": 6}
            text = evaluation_markdown(e)
            assert f"**{100 * e.accuracy:.1f} %** (–) on 60 windows" in text
            assert "fewer than 5 recordings of a kind to draw again (this set has 1 UAV" in text
        figures = identification_figures(called, scores, data, 0.5, alarm_thresholds=[(0.05, 0.9)])
        lead = accuracy_lead(called & (scores >= 0.5) == label, called == label, data)
        assert figures["accuracy_lead"]["lead"] == lead["lead"]
        tuned = figures["at_tuned_false_alarm"][0]
        alarm = np.where(called, scores, -np.inf) >= 0.9
        # The false alarms draw from the six UAV-free recordings alone: always an interval.
        assert tuned["false_alarm_interval"] == list(
            recording_interval(alarm[~label], recording[~label])
        )
        if drawn:
            assert figures["any_spike"]["accuracy_interval"] == list(expected)
            assert lead["interval"] == list(
                recording_interval(
                    called & (scores >= 0.5) == label,
                    recording,
                    against=called == label,
                    strata=label,
                )
            )
            assert "(–)" not in lead_text(lead)
            assert interval_text(e.accuracy_interval) == (
                f"95 % interval {100 * lo:.1f}-{100 * hi:.1f}"
            )
        else:
            for interval in (
                figures["any_spike"]["accuracy_interval"],
                figures["identified"]["accuracy_interval"],
                figures["accuracy_lead"]["interval"],
                tuned["detection_interval"],
                *(p["detection_interval"] for p in figures["at_false_alarm"]),
            ):
                assert all(np.isnan(interval))
            assert lead_text(figures["accuracy_lead"]).endswith(" (–)")
            assert figures["recordings"] == {"uav": 1, "uav_free": 6}
            assert interval_text(e.accuracy_interval) == (
                "no 95 % interval: fewer than 5 recordings of a kind"
            )
            text = identification_markdown(figures)
            assert "– in place of an interval: fewer than 5 recordings of a kind" in text
            # Figures without an interval still compare equal to themselves.
            assert figures == identification_figures(
                called, scores, data, 0.5, alarm_thresholds=[(0.05, 0.9)]
            )
    # Arrays that do not fit are refused whatever the recordings.
    with pytest.raises(ShapeError):
        accuracy_lead(np.ones(3, bool), np.ones(60, bool), _recorded(label, few))


def test_recording_interval_draws_recordings_not_windows() -> None:
    from uavsnn.evaluation import recording_interval

    # Every recording has the same share: every draw gives it back, which would say the share
    # is known exactly; the interval is then Clopper-Pearson's over the windows (60 of 200),
    # whose ends leave 2.5 % of the binomial's tail each side.
    rec = np.repeat(np.arange(20), 10)
    hit = np.tile(np.arange(10) < 3, 20)
    lo, hi = recording_interval(hit, rec)
    assert lo < 0.3 < hi
    assert _binomial_tail(200, 60, lo, upper=True) == pytest.approx(0.025, rel=1e-6)
    assert _binomial_tail(200, 60, hi, upper=False) == pytest.approx(0.025, rel=1e-6)
    # One recording of 30 alarms in all its windows, the other 29 never: 30 of 900 windows
    # (3.3 %). Drawn as windows the share would be known to about ±1.2 points; drawn as
    # recordings, a draw without that recording (a third of them) gives 0.
    rec = np.repeat(np.arange(30), 30)
    hit = rec == 7
    lo, hi = recording_interval(hit, rec)
    # A draw holds that recording 0 to 3 times (in 95 % of draws): shares 0 to 3/30.
    assert lo == 0.0 and 0.08 < hi <= 0.15
    # 5 of 20 recordings alarm throughout: the count drawn is binomial (20, 1/4), whose 95 %
    # range is 1 to 9 recordings, so 0.05 to 0.45 of the windows.
    few = np.repeat(np.arange(20), 10)
    lo5, hi5 = recording_interval(few < 5, few)
    assert 0.05 <= lo5 <= 0.15 and 0.4 <= hi5 <= 0.5
    # The same inputs and seed give the same interval; another seed one nearby (a draw's
    # share moves by a whole recording, 1/30, at a time).
    assert recording_interval(hit, rec) == (lo, hi)
    other = recording_interval(hit, rec, seed=1)
    assert abs(other[0] - lo) <= 1 / 30 + 1e-12 and abs(other[1] - hi) <= 1 / 30 + 1e-12
    # A narrower level gives a narrower interval, inside the wider one.
    lo50, hi50 = recording_interval(hit, rec, level=0.5)
    assert lo <= lo50 <= hi50 <= hi
    assert all(np.isnan(recording_interval(np.zeros(0, bool), np.zeros(0, int))))
    # No alarm in 30 recordings is not a share known to be 0: at most 11.6 % of recordings
    # (1 - 0.025^(1/30)), so of windows, may alarm. The rule of three gives 10 %.
    lo, hi = recording_interval(np.zeros(900, bool), rec)
    assert lo == 0.0 and hi == pytest.approx(0.1157, abs=1e-4)


@given(
    st.lists(st.tuples(st.integers(0, 5), st.booleans()), min_size=1, max_size=60),
    st.integers(0, 3),
)
def test_recording_interval_holds_the_share_when_each_recording_agrees(rows, seed) -> None:
    """When every window of a recording has the same outcome, the interval lies within the
    recordings' lowest and highest share, and holds the whole set's share when the
    recordings are of one size."""
    from uavsnn.evaluation import recording_interval

    rec = np.array([r for r, _ in rows])
    outcome = {r: h for r, h in rows}  # the last outcome named for a recording wins
    hit = np.array([outcome[r] for r in rec])
    lo, hi = recording_interval(hit, rec, resamples=200, seed=seed)
    assert 0.0 <= lo <= hi <= 1.0
    if hit.all() or not hit.any():
        # Clopper-Pearson's bound for none (or all) of the recordings hitting.
        bound = 0.025 ** (1 / len(set(rec.tolist())))
        assert (lo, hi) == pytest.approx((bound, 1.0) if hit.all() else (0.0, 1 - bound))


def test_recording_interval_refuses_what_it_cannot_draw() -> None:
    from uavsnn.evaluation import recording_interval

    with pytest.raises(ShapeError, match="hit has 3 windows, recording 2"):
        recording_interval(np.ones(3, bool), np.zeros(2, int))
    with pytest.raises(ParameterError, match="level"):
        recording_interval(np.ones(3, bool), np.zeros(3, int), level=1.0)
    with pytest.raises(ParameterError, match="resamples"):
        recording_interval(np.ones(3, bool), np.zeros(3, int), resamples=0)


def test_recording_interval_of_a_difference_draws_both_on_the_same_recordings() -> None:
    from uavsnn.evaluation import recording_interval

    r = np.random.default_rng(11)
    rec = np.repeat(np.arange(40), 25)
    # Each recording has its own difficulty, shared by both rules: a hit for one is a hit for
    # the other in most windows.
    hard = r.random(40)[rec]
    noise = r.random(rec.size)
    mine, theirs = noise > hard - 0.05, noise > hard
    lead = mine.mean() - theirs.mean()
    lo, hi = recording_interval(mine, rec, against=theirs)
    one_lo, one_hi = recording_interval(mine, rec)
    # The difference holds the set's lead, is above zero (mine hits wherever theirs does, and
    # more), and is much narrower than either share's interval, which moves with the draw
    # (drawn apart, the difference would move more than either).
    assert 0 < lo <= lead <= hi and hi - lo < (one_hi - one_lo) / 4
    # Against itself: no lead on any draw; the other way round, the mirror.
    assert recording_interval(mine, rec, against=mine) == (0.0, 0.0)
    back = recording_interval(theirs, rec, against=mine)
    assert back == pytest.approx((-hi, -lo))
    with pytest.raises(ShapeError, match="against 5"):
        recording_interval(mine, rec, against=theirs[:5])


def test_recording_interval_by_strata_keeps_each_group_drawn_apart() -> None:
    from uavsnn.evaluation import recording_interval

    # 10 UAV recordings whose windows are all decided right, 10 UAV-free ones all wrong, of
    # one size: the set's share is 1/2. Drawn together, a draw may hold 3 UAV recordings or
    # 17; drawn within each label, every draw holds 10 and 10: the share is 1/2 on each.
    rec = np.repeat(np.arange(20), 10)
    label = rec < 10
    right = label.copy()
    lo, hi = recording_interval(right, rec)
    assert lo < 0.35 and hi > 0.65
    # The share is 1/2 on every draw, which would say it is known exactly: Clopper-Pearson's
    # interval over the windows (100 of 200) instead.
    lo, hi = recording_interval(right, rec, strata=label)
    assert lo < 0.5 < hi and lo + hi == pytest.approx(1.0)
    assert _binomial_tail(200, 100, lo, upper=True) == pytest.approx(0.025, rel=1e-6)
    # A group of mixed recordings is drawn as its recordings, as without strata.
    rec2 = np.repeat(np.arange(30), 30)
    hit2 = rec2 == 7
    assert recording_interval(hit2, rec2, strata=np.zeros(900)) == recording_interval(hit2, rec2)
    with pytest.raises(ShapeError, match="strata 3"):
        recording_interval(right, rec, strata=label[:3])


def test_accuracy_lead_is_the_paired_interval_of_the_windows_decided_right() -> None:
    from uavsnn.evaluation import accuracy_lead, recording_interval

    r = np.random.default_rng(12)
    n = 400
    rec = np.repeat(np.arange(20), 20)
    label = rec % 2 == 0
    data = LabelledWindows(
        _windows([[] for _ in range(n)]), label, np.where(label, "drone", "bird"), rec,
        np.full((n, 4), np.nan, np.float32),
    )  # fmt: skip
    mine, theirs = r.random(n) < 0.7, r.random(n) < 0.6
    got = accuracy_lead(mine, theirs, data)
    assert got["lead"] == pytest.approx(mine.mean() - theirs.mean())
    assert got["interval"] == list(recording_interval(mine, rec, against=theirs, strata=label))
    assert accuracy_lead(mine, mine, data) == {"lead": 0.0, "interval": [0.0, 0.0]}
    with pytest.raises(ShapeError, match="against 3"):
        accuracy_lead(mine, theirs[:3], data)


def _identical_recordings(scores: np.ndarray, copies: int) -> np.ndarray:
    """Recording ids for ``copies`` copies of ``scores`` laid end to end, one per copy."""
    return np.repeat(np.arange(copies), len(scores))


def test_roc_point_interval_reads_the_threshold_again_on_each_draw(monkeypatch) -> None:
    from uavsnn import roc
    from uavsnn.evaluation import detection_at_false_alarm, roc_point_interval

    r = np.random.default_rng(5)
    # Every UAV-free recording holds the same 100 scores (ties and never-alarming windows
    # among them), and every UAV recording the same 50: any draw of recordings is the set
    # again, so the interval is the set's own point, at each rate (the threshold's tie rule
    # and the -inf windows as threshold_at_false_alarm has them).
    free = np.round(r.normal(0, 1, 100), 1)
    free[:20] = -np.inf
    uav = np.round(r.normal(1, 1, 50), 1)
    uav[:5] = -np.inf
    scores = np.concatenate([np.tile(free, 10), np.tile(uav, 8)])
    actual = np.concatenate([np.zeros(1000, bool), np.ones(400, bool)])
    rec = np.concatenate([_identical_recordings(free, 10), 10 + _identical_recordings(uav, 8)])
    for rate in (0.0, 0.01, 0.05, 0.3, 0.8, 1.0):
        point = detection_at_false_alarm(scores, actual, rate)
        assert roc_point_interval(scores, actual, rec, rate, resamples=300) == pytest.approx(
            (point, point)
        ), rate
    # A set too large for its draws' weights at once is drawn a few draws at a time (here one).
    monkeypatch.setattr(roc, "_DRAW_ELEMENTS", 1000)
    point = detection_at_false_alarm(scores, actual, 0.05)
    assert roc_point_interval(scores, actual, rec, 0.05, resamples=30) == pytest.approx(
        (point, point)
    )


def test_roc_point_interval_widens_when_a_recording_sets_the_threshold() -> None:
    from uavsnn.evaluation import detection_at_false_alarm, roc_point_interval

    r = np.random.default_rng(6)
    scores = np.concatenate([r.normal(0, 1, 2000), r.normal(2, 1, 2000)])
    actual = np.concatenate([np.zeros(2000, bool), np.ones(2000, bool)])
    mixed = np.tile(np.arange(40), 100)  # every recording a fair share of each score
    # The same scores, the highest UAV-free ones all in one recording of 40: whether a draw
    # holds it (0, 1, 2 ... times) moves the 1 % threshold across the UAV scores.
    clustered = np.empty(4000, int)
    order = np.argsort(-scores[:2000])
    clustered[:2000][order] = np.repeat(np.arange(20), 100)
    clustered[2000:] = 20 + np.repeat(np.arange(20), 100)
    point = detection_at_false_alarm(scores, actual, 0.01)
    lo_m, hi_m = roc_point_interval(scores, actual, mixed, 0.01)
    lo_c, hi_c = roc_point_interval(scores, actual, clustered, 0.01)
    assert lo_m <= point <= hi_m and lo_c <= point <= hi_c
    assert hi_c - lo_c > 2 * (hi_m - lo_m)
    # The same inputs and seed, the same interval; a narrower level inside it.
    assert roc_point_interval(scores, actual, clustered, 0.01) == (lo_c, hi_c)
    lo50, hi50 = roc_point_interval(scores, actual, clustered, 0.01, level=0.5)
    assert lo_c <= lo50 <= hi50 <= hi_c


def test_roc_point_interval_with_nothing_detected_bounds_the_share() -> None:
    from uavsnn.evaluation import recording_interval, roc_point_interval

    # No UAV window scores finite: every draw detects nothing, which is not a share known to
    # be 0; the interval is the recordings' Clopper-Pearson bound, as recording_interval's.
    scores = np.concatenate([np.linspace(0, 1, 300), np.full(300, -np.inf)])
    actual = np.arange(600) >= 300
    rec = np.repeat(np.arange(60), 10)
    got = roc_point_interval(scores, actual, rec, 0.05)
    assert got == recording_interval(np.zeros(300, bool), rec[300:])
    assert got[0] == 0.0 and got[1] > 0.05


def test_roc_point_interval_of_a_difference_draws_both_models_on_the_same_recordings() -> None:
    from uavsnn.evaluation import detection_at_false_alarm, roc_point_interval

    r = np.random.default_rng(8)
    rec = np.repeat(np.arange(60), 30)
    actual = rec % 2 == 1
    # Windows of a recording score together (its own level), as the dataset's do.
    base = r.normal(0, 1, rec.size) + r.normal(0, 1.5, 60)[rec] + 1.5 * actual
    # A score that ranks the windows as `base` does detects the same on every draw.
    assert roc_point_interval(base, actual, rec, 0.01, against=2 * base + 1) == (0.0, 0.0)
    # A model a little off `base`: the difference, drawn on the same recordings, moves much
    # less than either model's figure, whose threshold moves with the draw.
    near = base + r.normal(0, 0.3, rec.size)
    lo, hi = roc_point_interval(base, actual, rec, 0.05)
    d_lo, d_hi = roc_point_interval(near, actual, rec, 0.05, against=base)
    lead = detection_at_false_alarm(near, actual, 0.05) - detection_at_false_alarm(
        base, actual, 0.05
    )
    assert d_lo <= lead <= d_hi and d_hi - d_lo < (hi - lo) / 2
    # A model whose UAV windows score higher leads on every draw.
    better = base + 2.0 * actual
    b_lo, _ = roc_point_interval(better, actual, rec, 0.05, against=base)
    assert b_lo > 0
    with pytest.raises(ShapeError, match="against 5"):
        roc_point_interval(base, actual, rec, 0.05, against=base[:5])
    with pytest.raises(ParameterError, match="NaN"):
        roc_point_interval(base, actual, rec, 0.05, against=np.full(rec.size, np.nan))


def test_roc_point_interval_refuses_what_it_cannot_draw() -> None:
    from uavsnn.evaluation import roc_point_interval

    s, a, rec = np.zeros(4), np.array([0, 0, 1, 1], bool), np.arange(4)
    with pytest.raises(ShapeError, match="recording 3"):
        roc_point_interval(s, a, rec[:3], 0.01)
    with pytest.raises(ParameterError, match="NaN"):
        roc_point_interval(np.array([0, np.nan, 0, 0]), a, rec, 0.01)
    with pytest.raises(ParameterError, match="rate"):
        roc_point_interval(s, a, rec, 1.5)
    with pytest.raises(ParameterError, match="level"):
        roc_point_interval(s, a, rec, 0.01, level=0)
    with pytest.raises(ParameterError, match="resamples"):
        roc_point_interval(s, a, rec, 0.01, resamples=True)
    with pytest.raises(DatasetError, match="UAV and UAV-free"):
        roc_point_interval(s, np.ones(4, bool), rec, 0.01)


def test_a_point_past_the_rules_reach_is_the_lowest_detections_score() -> None:
    """Where a false-alarm share needs more UAV-free windows than the any-spike rule calls,
    every detection alarms: the point's threshold is the lowest detection's score (it was the
    float just above -inf, -1.797e308 in the JSON), with the same alarms."""
    from uavsnn.evaluation import identification_figures

    label = np.arange(40) % 2 == 0
    called = label | (np.arange(40) == 1)  # one UAV-free window of 20 called: 5 %
    scores = np.linspace(0.2, 0.9, 40)
    figures = identification_figures(called, scores, _recorded(label, np.arange(40)), 0.5)
    at1, at5 = figures["at_false_alarm"]
    # 1 %: no UAV-free window may alarm, just above the one called.
    assert at1["threshold"] == np.nextafter(scores[1], np.inf) and at1["false_alarm_rate"] == 0
    # 5 %: one may, and the rule calls no second: every detection alarms.
    assert at5["false_alarm_target"] == 0.05 and at5["threshold"] == scores[called].min()
    assert at5["false_alarm_rate"] == 0.05 and at5["detection_rate"] == 1.0
