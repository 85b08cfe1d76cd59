"""Identification (uavsnn.identify) and the figures that report it (uavsnn.evaluation)."""

from __future__ import annotations

import math
import random
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from uavsnn import EVENT_DTYPE, Detector, Network
from uavsnn.dataset import LabelledWindows
from uavsnn.dataset.format import RawEvents
from uavsnn.errors import DatasetError, ModelFileError, ParameterError, ShapeError
from uavsnn.evaluation import (
    detection_at_false_alarm,
    detection_by_target,
    identification_figures,
    recording_interval,
    roc_area,
    roc_curve,
    threshold_at_false_alarm,
)
from uavsnn.events import Recording
from uavsnn.identify import (
    FEATURES,
    TRACK_ACTIVITY,
    TRACK_FEATURES,
    UAV_CLASS,
    Identifier,
    WindowFeatures,
    best_threshold,
    class_figures,
    fit,
    fit_logistic,
    fit_score,
    fit_softmax,
    object_features,
    predict_logistic,
    predict_softmax,
    rate_swing,
    threshold_accuracies,
    track_features,
    window_features,
)
from uavsnn.signature import rotor_signature
from uavsnn.tracks import Tracker
from uavsnn.windows import make_windows

SIZE = (40, 30)


def small_net() -> Network:
    config = {
        "width": SIZE[0],
        "height": SIZE[1],
        "pent": {"mode": "pent", "beta": 2.0, "theta_min": 1.5, "estimate": "preceding"},
        "conv2": {"threshold": 3.0},
        "conv3": {"threshold": 1.5},
    }
    return Network(config, seed=3)


# ---------------------------------------------------------------- the logistic fit


def test_the_fit_recovers_a_separable_rule() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(size=(400, 3))
    y = x[:, 0] + 2 * x[:, 1] > 0.5  # x[:, 2] is noise
    coef = fit_logistic(x, y, l2=1e-3)
    assert np.all((predict_logistic(coef, x) >= 0.5) == y)
    direction = coef[:3] / np.linalg.norm(coef[:3])
    assert direction @ np.array([1, 2, 0]) / np.sqrt(5) > 0.98
    # The intercept places the boundary at x0 + 2 x1 = 0.5.
    assert -coef[3] / coef[0] == pytest.approx(0.5, abs=0.1)
    # A strong penalty shrinks the weights.
    assert np.linalg.norm(fit_logistic(x, y, l2=100.0)[:3]) < np.linalg.norm(coef[:3])


@pytest.mark.parametrize(
    ("x", "y", "l2", "error"),
    [
        (np.zeros((3, 2)), np.zeros(4, bool), 1.0, ShapeError),
        (np.zeros((3, 2)), np.zeros(3), 1.0, ParameterError),
        (np.full((3, 2), np.nan), np.zeros(3, bool), 1.0, ParameterError),
        (np.zeros((3, 2)), np.zeros(3, bool), -1.0, ParameterError),
    ],
)
def test_bad_fit_inputs_are_typed_errors(x, y, l2, error) -> None:
    with pytest.raises(error):
        fit_logistic(x, y, l2=l2)


def test_the_softmax_fit_separates_three_classes_and_weights_a_rare_one() -> None:
    rng = np.random.default_rng(4)
    centres = np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0]])
    y = np.repeat([0, 1, 2], [300, 300, 12])  # class 2 is rare
    x = centres[y] + rng.normal(size=(len(y), 2))
    coef = fit_softmax(x, y, 3, l2=1e-2)
    p = predict_softmax(coef, x)
    np.testing.assert_allclose(p.sum(axis=1), 1.0)
    assert np.mean(p.argmax(axis=1) == y) > 0.9
    # Weighting each class by the inverse of its share finds more of the rare class.
    w = (len(y) / (3 * np.bincount(y)))[y]
    weighted = predict_softmax(fit_softmax(x, y, 3, l2=1e-2, weights=w), x).argmax(axis=1)
    plain = p.argmax(axis=1)
    assert np.sum(weighted[y == 2] == 2) > np.sum(plain[y == 2] == 2)


def test_two_class_softmax_is_the_logistic_fit() -> None:
    rng = np.random.default_rng(5)
    x = rng.normal(size=(300, 3))
    y = x[:, 0] - x[:, 2] + rng.normal(size=300) > 0
    binary = predict_logistic(fit_logistic(x, y, l2=1.0), x)
    # Two classes, each with half the penalty's weight vector: the same log-odds with l2 / 2
    # on the difference; compare probabilities of a fit at 2 * l2.
    two = predict_softmax(fit_softmax(x, y.astype(np.int64), 2, l2=2.0), x)[:, 1]
    np.testing.assert_allclose(two, binary, atol=1e-4)


@pytest.mark.parametrize(
    ("x", "y", "k", "error"),
    [
        (np.zeros((3, 2)), np.zeros(4, np.int64), 2, ShapeError),
        (np.zeros((3, 2)), np.zeros(3, bool), 2, ParameterError),
        (np.zeros((3, 2)), np.array([0, 1, 2]), 2, ParameterError),
        (np.zeros((3, 2)), np.zeros(3, np.int64), 1, ParameterError),
        (np.full((3, 2), np.inf), np.zeros(3, np.int64), 2, ParameterError),
    ],
)
def test_bad_softmax_inputs_are_typed_errors(x, y, k, error) -> None:
    with pytest.raises(error):
        fit_softmax(x, y, k)


def test_fit_adds_a_class_model_from_the_objects_classes() -> None:
    from uavsnn.identify import WindowFeatures

    rng = np.random.default_rng(6)
    kinds = np.repeat(["uav", "bird", "clutter", "ball", ""], [60, 40, 40, 3, 10])
    centre = {"uav": 2.0, "bird": -2.0, "clutter": 0.0, "ball": 5.0, "": 0.0}
    x = rng.normal(size=(len(kinds), len(FEATURES)))
    x[:, 4] += [centre[k] for k in kinds]
    x[:, 5] += [2.0 * (k == "clutter") for k in kinds]
    m = len(kinds)
    feats = WindowFeatures(
        x, np.arange(m), np.zeros((m, 4)), m, kinds == "uav", kinds != "", cls=kinds
    )
    ident = fit(feats, feats)
    # "ball" has fewer than MIN_CLASS_OBJECTS objects; "" is unknown: neither is a class.
    assert ident.classes == ("uav", "bird", "clutter")
    figures = class_figures(ident, feats)
    assert figures["objects"] == 143 and set(figures["per_class"]) == {
        "uav",
        "bird",
        "clutter",
        "ball",
    }
    assert figures["per_class"]["ball"]["recall"] == 0.0  # never a guess
    assert figures["balanced_accuracy"] > 0.8
    assert sum(sum(r.values()) for r in figures["confusion"].values()) == 143
    # Without classes, or asked not to, no class model.
    assert fit(feats, feats, classes=False).class_coef is None
    bare = WindowFeatures(x, np.arange(m), np.zeros((m, 4)), m, kinds == "uav", kinds != "")
    assert fit(bare, bare).classes == ()
    assert class_figures(fit(bare, bare), bare)["objects"] == 0


def test_fit_refuses_a_set_without_both_kinds() -> None:
    from uavsnn.identify import WindowFeatures

    x = np.zeros((4, len(FEATURES)))
    feats = WindowFeatures(
        x, np.arange(4), np.zeros((4, 4)), 4, np.zeros(4, bool), np.ones(4, bool)
    )
    with pytest.raises(DatasetError):
        fit(feats, feats)


def test_fit_score_keeps_the_l2_with_the_smallest_tuning_loss() -> None:
    rng = np.random.default_rng(5)
    x = rng.normal(size=(200, 3)) * [1.0, 10.0, 0.1] + [0.0, 5.0, -2.0]
    y = x[:, 0] + 0.1 * rng.normal(size=200) > 0
    xt, yt = x[:100], y[:100]
    mean, scale, coef, l2 = fit_score(x[100:], y[100:], xt, yt, l2_grid=(0.01, 1e6))
    np.testing.assert_allclose(mean, x[100:].mean(axis=0))
    np.testing.assert_allclose(scale, x[100:].std(axis=0))
    # a huge penalty flattens the score to the base rate: the small one must win on held-out data
    assert l2 == 0.01
    assert np.mean((predict_logistic(coef, (xt - mean) / scale) > 0.5) == yt) > 0.9


def test_best_threshold_maximises_balanced_accuracy() -> None:
    # 2 UAV windows, 6 others: plain accuracy would reject both UAVs at any threshold above 0.4
    score = np.array([0.9, 0.45, 0.5, 0.3, 0.2, 0.1, -1.0, -1.0])
    label = np.array([True, True, False, False, False, False, False, False])
    assert best_threshold(score, label) == 0.45
    # windows the any-spike rule did not call (negative) are never candidates
    assert best_threshold(np.array([-1.0, -1.0]), np.array([True, False])) == 0.5


def test_best_threshold_takes_the_highest_of_a_flat_best() -> None:
    # 4 UAV windows, 4 others: 0.45 calls every UAV and one other (balanced accuracy 0.875),
    # 0.7 misses one UAV and calls no other (0.875 too)
    score = np.array([0.9, 0.8, 0.7, 0.6, 0.45, 0.3, 0.2, 0.1])
    label = np.array([True, True, True, True, False, False, False, False])
    # every threshold from 0.5 to 0.6 separates them exactly: the highest of the best
    assert best_threshold(score, label, within=0.0) == 0.6
    assert best_threshold(score, label) == 0.6  # the default: the highest of the best
    # within an eighth of the best (1 - 0.125): 0.45 and 0.7 count too, the highest is taken
    assert best_threshold(score, label, within=0.125) == 0.7
    assert best_threshold(score, label, within=0.124) == 0.6
    assert best_threshold(np.zeros(0), np.zeros(0, bool)) == 0.5
    for bad in (-0.01, 1.0, float("nan")):
        with pytest.raises(ParameterError, match="within"):
            best_threshold(score, label, within=bad)


@given(
    st.lists(st.floats(0.0, 1.0), min_size=2, max_size=40),
    st.randoms(use_true_random=False),
    st.floats(0.0, 0.2),
)
def test_best_threshold_is_the_highest_within_of_the_best(
    scores: list[float], rnd: random.Random, within: float
) -> None:
    score = np.array(scores)
    label = np.array([rnd.random() < 0.5 for _ in scores])
    label[0], label[1] = True, False
    candidates, acc = threshold_accuracies(score, label)
    chosen = best_threshold(score, label, within)
    assert chosen in candidates
    assert acc[candidates == chosen][0] >= acc.max() - within
    # no higher candidate is within of the best
    assert (acc[candidates > chosen] < acc.max() - within).all()


# ---------------------------------------------------------------- the model file


def model(threshold: float = 0.3) -> Identifier:
    k = len(FEATURES)
    return Identifier(
        FEATURES, np.linspace(-1, 1, k + 1), np.arange(k) * 0.5, np.ones(k) * 2, threshold, 0.1
    )


def test_save_load_round_trip_with_identification(tmp_path: Path) -> None:
    net = small_net()
    net.identification = model()
    net.save(tmp_path / "m.npz")
    back = Network.load(tmp_path / "m.npz")
    assert back == net and back.load_note is None
    ident = back.identification
    assert ident is not None and ident.features == FEATURES and ident.threshold == 0.3
    for name in ("coef", "mean", "scale"):
        np.testing.assert_array_equal(getattr(ident, name), getattr(net.identification, name))
    x = np.random.default_rng(1).normal(size=(5, len(FEATURES)))
    np.testing.assert_array_equal(ident.scores(x), net.identification.scores(x))
    # No pickle in the file: every array loads with allow_pickle=False.
    with np.load(tmp_path / "m.npz", allow_pickle=False) as z:
        assert int(z["identify.version"]) == 2
        assert "identify.classes" not in z  # no class model: none stored
    assert ident.guess(x, np.array([0.1, 0.3, 0.5, 0.2, 0.9])) == [
        "other",
        "uav",
        "uav",
        "other",
        "uav",
    ]


def test_the_same_network_saves_the_same_bytes_at_any_time(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A model file carries no time of writing (a checksum compares two trainings)."""
    import time

    net = small_net()
    net.identification = model()
    saved = []
    for when in (0.0, 3e8):  # two times of writing, years apart
        monkeypatch.setattr(time, "time", lambda when=when: 1.6e9 + when)
        net.save(tmp_path / "m.npz")
        saved.append((tmp_path / "m.npz").read_bytes())
    assert saved[0] == saved[1]


def test_a_model_fitted_before_the_rate_swing_scores_with_its_own_features(
    tmp_path: Path,
) -> None:
    """A model file whose feature list lacks ``log_rate_swing`` (written before it joined
    FEATURES) loads and scores today's rows on its own columns: the swing never reaches it."""
    old = tuple(f for f in FEATURES if f != "log_rate_swing")
    k = len(old)
    rng = np.random.default_rng(3)
    ident = Identifier(old, rng.normal(size=k + 1), rng.normal(size=k), np.ones(k), 0.4, 1.0)
    net = small_net()
    net.identification = ident
    net.save(tmp_path / "old.npz")
    back = Network.load(tmp_path / "old.npz").identification
    assert back is not None and back.features == old
    x = rng.normal(size=(6, len(FEATURES)))
    expected = ident.scores(np.delete(x, FEATURES.index("log_rate_swing"), axis=1))
    # The same columns (to the last bits: a column subset may sum in another order).
    got = back.scores(x)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=0)
    x[:, FEATURES.index("log_rate_swing")] += 5.0
    np.testing.assert_array_equal(back.scores(x), got)


def with_classes(threshold: float = 0.3) -> Identifier:
    k = len(FEATURES)
    classes = ("uav", "bird", "clutter")
    coef = np.zeros((len(classes), k + 1))
    coef[1, 0], coef[2, 0] = 1.0, -1.0  # bird where the first feature is high, clutter low
    return replace(model(threshold), classes=classes, class_coef=coef, class_l2=0.5)


def test_the_class_model_round_trips_and_guesses_among_the_other_classes(
    tmp_path: Path,
) -> None:
    net = small_net()
    net.identification = with_classes()
    net.save(tmp_path / "m.npz")
    back = Network.load(tmp_path / "m.npz").identification
    assert back.classes == ("uav", "bird", "clutter") and back.class_l2 == 0.5
    np.testing.assert_array_equal(back.class_coef, net.identification.class_coef)
    x = np.random.default_rng(3).normal(size=(40, len(FEATURES)))
    p = back.class_probabilities(x)
    np.testing.assert_allclose(p.sum(axis=1), 1.0)
    scores = np.linspace(0.0, 1.0, len(x))
    guesses = back.guess(x, scores)
    assert back.guess(x) == back.guess(x, back.scores(x))
    for s, g, row in zip(scores, guesses, p, strict=True):
        if s >= back.threshold:
            assert g == "uav"
        else:  # the likelier of the two other classes, whatever the UAV column says
            assert g == ("bird" if row[1] >= row[2] else "clutter")
    assert {"uav", "bird", "clutter"} == set(guesses)


def test_a_version_1_file_loads_without_a_class_model(tmp_path: Path) -> None:
    from uavsnn.network import _add_arrays

    net = small_net()
    net.identification = model()
    net.save(tmp_path / "m.npz")
    _add_arrays(str(tmp_path / "m.npz"), {"identify.version": np.array(1)})
    back = Network.load(tmp_path / "m.npz").identification
    assert back.classes == () and back.class_coef is None
    x = np.zeros((1, len(FEATURES)))
    assert back.guess(x, np.array([0.0])) == ["other"]


def test_an_inconsistent_class_model_is_refused(tmp_path: Path) -> None:
    from uavsnn.network import _add_arrays

    net = small_net()
    net.identification = with_classes()
    net.save(tmp_path / "m.npz")
    _add_arrays(str(tmp_path / "m.npz"), {"identify.class_coef": np.zeros((2, 3))})
    with pytest.raises(ModelFileError, match="inconsistent"):
        Network.load(tmp_path / "m.npz")
    with pytest.raises(ParameterError):
        replace(model(), classes=("uav", "uav"), class_coef=np.zeros((2, len(FEATURES) + 1)))
    with pytest.raises(ParameterError):
        replace(model(), class_coef=np.zeros((2, len(FEATURES) + 1)))


@pytest.mark.parametrize(
    "change",
    [
        {"threshold": 2**2000},
        {"threshold": "0.5"},
        {"l2": True},
        {"alarm_thresholds": ((0.01, 10**400),)},
        {"track_alarm_thresholds": (("0.1", 0.5),), "track_alarm_minutes": 10.0},
        {"track_alarm_thresholds": ((0.1, 0.5),), "track_alarm_minutes": 2**2000},
    ],
)
def test_numbers_that_are_no_finite_floats_are_parameter_errors(change: dict) -> None:
    # An integer beyond a float's range raised OverflowError, a string TypeError.
    with pytest.raises(ParameterError):
        replace(model(), **change)
    same = replace(model(), threshold=np.float32(0.25), l2=np.int64(0))
    assert (same.threshold, same.l2) == (0.25, 0.0)


def test_an_old_model_loads_with_the_any_spike_rule_and_a_note(tmp_path: Path) -> None:
    net = small_net()
    net.save(tmp_path / "old.npz")
    back = Network.load(tmp_path / "old.npz")
    assert back.identification is None
    assert back.load_note is not None and "any-spike rule" in back.load_note
    Detector(tmp_path / "old.npz", window_us=3_000)  # still runs


def test_another_identification_version_is_refused(tmp_path: Path) -> None:
    from uavsnn.network import _add_arrays

    net = small_net()
    net.identification = model()
    net.save(tmp_path / "m.npz")
    _add_arrays(str(tmp_path / "m.npz"), {"identify.version": np.array(99)})
    with pytest.raises(ModelFileError, match="version 99"):
        Network.load(tmp_path / "m.npz")
    _add_arrays(
        str(tmp_path / "m.npz"), {"identify.version": np.array(1), "identify.coef": np.zeros(3)}
    )
    with pytest.raises(ModelFileError, match="inconsistent"):
        Network.load(tmp_path / "m.npz")


@pytest.mark.parametrize(
    "stored",
    [
        {"identify.version": np.array([3, 3])},
        {"identify.version": np.array(2.5)},
        {"identify.threshold": np.array([0.5, 0.5])},
        {"identify.l2": np.zeros(2)},
        {"identify.class_l2": np.zeros(3)},
        {"identify.features": np.array("log_width")},
        {"identify.classes": np.array("uav")},
        {"identify.threshold": np.array(np.nan)},
        {"identify.l2": np.array(-1.0)},
        {"identify.scale": np.zeros(len(FEATURES))},
        {"identify.mean": np.full(len(FEATURES), np.inf)},
        {"identify.coef": np.full(len(FEATURES) + 1, np.nan)},
    ],
    ids=lambda d: next(iter(d)) + str(np.asarray(next(iter(d.values()))).tolist())[:12],
)
def test_damaged_identification_arrays_are_a_model_file_error(
    tmp_path: Path, stored: dict[str, np.ndarray]
) -> None:
    """An array where one number belongs, one number where names belong, or a value no fit
    makes (NaN, a scale of 0): refused on load, not a TypeError, nor NaN scores later."""
    from uavsnn.network import _add_arrays

    net = small_net()
    net.identification = with_classes()
    net.save(tmp_path / "m.npz")
    _add_arrays(str(tmp_path / "m.npz"), stored)
    with pytest.raises(ModelFileError, match="identif"):
        Network.load(tmp_path / "m.npz")


@pytest.mark.parametrize("field", ["threshold", "l2"])
def test_a_non_finite_number_of_the_model_is_a_parameter_error(field: str) -> None:
    with pytest.raises(ParameterError, match=field):
        replace(model(), **{field: math.nan})


# ---------------------------------------------------------------- the tracker gate


def test_the_tracker_gate_round_trips_through_a_model_file(tmp_path: Path) -> None:
    """A model records the gate its track features were fitted with in ``identify.gate_px``,
    an array older readers ignore (the version stays); a model without one stores none."""
    net = small_net()
    net.identification = replace(model(), gate_px=24.0)
    net.save(tmp_path / "m.npz")
    with np.load(tmp_path / "m.npz", allow_pickle=False) as z:
        assert float(z["identify.gate_px"]) == 24.0 and int(z["identify.version"]) == 2
    back = Network.load(tmp_path / "m.npz")
    assert back.identification.gate_px == 24.0 and back.load_note is None
    net.identification = model()
    net.save(tmp_path / "old.npz")
    with np.load(tmp_path / "old.npz", allow_pickle=False) as z:
        assert "identify.gate_px" not in z
    assert Network.load(tmp_path / "old.npz").identification.gate_px is None


def test_a_model_without_a_recorded_gate_runs_at_its_sensors_with_a_note(
    tmp_path: Path,
) -> None:
    """A model written before the gate was recorded runs at its sensor's gate; wider than
    240 px, where that is not the 24 px it may have been fitted at, its load note says so,
    and ``uavsnn detect`` prints it."""
    import subprocess
    import sys

    from uavsnn.tracks import GATE_SHARE

    for w, h in ((1280, 720), (240, 180)):
        net = Network({"width": w, "height": h}, seed=0)
        net.identification = model()
        net.save(tmp_path / f"{w}.npz")
        back = Network.load(tmp_path / f"{w}.npz")
        assert back.identification.gate_px is None
        assert Detector(back).tracker.gate_px == pytest.approx(GATE_SHARE * w)
        data = as_dataset(scene(), (w, h), 10_000)
        assert window_features(back, data).gate_px == pytest.approx(GATE_SHARE * w)
    assert Network.load(tmp_path / "240.npz").load_note is None  # 24 px, as it always was
    note = Network.load(tmp_path / "1280.npz").load_note
    assert note is not None and "does not record the tracker gate" in note
    assert "(128 px)" in note and "24 px" in note and "--identify-only" in note
    cmd = [sys.executable, "-m", "uavsnn", "detect", "-", "--model", str(tmp_path / "1280.npz")]
    # one event: a stream without a usable event is refused (exit 2)
    one = np.zeros(1, EVENT_DTYPE).tobytes()
    done = subprocess.run(cmd, input=one, capture_output=True)
    assert done.returncode == 0 and "does not record the tracker gate" in done.stderr.decode()


def test_a_model_recording_its_gate_runs_with_it(tmp_path: Path) -> None:
    """A model fitted at 24 px on a 1280-px sensor runs at 24 px, not at the sensor's 128, in
    the Detector and in the batch features, from a model file too."""
    net = Network({"width": 1280, "height": 720}, seed=0)
    net.identification = replace(model(), gate_px=24.0)
    net.save(tmp_path / "m.npz")
    back = Network.load(tmp_path / "m.npz")
    assert back.load_note is None
    data = as_dataset(scene(), (1280, 720), 10_000)
    for n in (net, back):
        assert Detector(n).tracker.gate_px == 24.0
        feats = window_features(n, data)
        assert feats.gate_px == 24.0 and len(feats.x) > 0
    # On the small sensor (4 px): the features are those of a 24 px tracker.
    small = small_net()
    small.identification = replace(model(), gate_px=24.0)
    data = as_dataset(scene(), SIZE, 10_000)
    mine = window_features(small, data)
    given = window_features(small, data, tracker=Tracker(gate_px=24.0))
    assert mine.gate_px == 24.0
    np.testing.assert_array_equal(mine.x, given.x)
    np.testing.assert_array_equal(mine.track, given.track)


@pytest.mark.parametrize(
    "stored",
    [
        np.array(-24.0),
        np.array(0.0),
        np.array(np.nan),
        np.array(np.inf),
        np.array([24.0, 24.0]),
        np.array("24"),
    ],
)
def test_a_bad_stored_gate_is_refused(tmp_path: Path, stored: np.ndarray) -> None:
    from uavsnn.network import _add_arrays

    net = small_net()
    net.identification = model()
    net.save(tmp_path / "m.npz")
    _add_arrays(str(tmp_path / "m.npz"), {"identify.gate_px": stored})
    with pytest.raises(ModelFileError, match=r"identify\.gate_px"):
        Network.load(tmp_path / "m.npz")


@pytest.mark.parametrize(
    "gate",
    [
        0.0,
        -1.0,
        math.nan,
        math.inf,
        True,
        "24",
        pytest.param(2**2000, id="2**2000"),
        np.float32(-1),
        np.bool_(True),
    ],
)
def test_a_bad_gate_is_a_parameter_error(gate: object) -> None:
    with pytest.raises(ParameterError, match="gate_px"):
        replace(model(), gate_px=gate)


def test_numpy_numbers_are_taken_as_python_ones(tmp_path: Path) -> None:
    """A gate and a confirmation rule of NumPy numbers (as arrays hand them out) are taken,
    and kept as Python numbers; they were refused as not numbers, or not integers."""
    with_points = replace(model(), track_alarm_thresholds=((0.1, 0.4),), track_alarm_minutes=2.0)
    ident = replace(
        with_points, gate_px=np.float32(24), track_alarm_confirm=(np.int64(2), np.int32(4))
    )
    assert ident.gate_px == 24.0 and type(ident.gate_px) is float
    assert ident.track_alarm_confirm == (2, 4)
    assert all(type(v) is int for v in ident.track_alarm_confirm)
    assert replace(model(), gate_px=np.int64(64)).gate_px == 64.0
    net = small_net()
    net.identification = ident
    net.save(tmp_path / "m.npz")
    back = Network.load(tmp_path / "m.npz").identification
    assert back is not None and (back.gate_px, back.track_alarm_confirm) == (24.0, (2, 4))
    for confirm in ((3.0, 5), (np.float64(3), 5), [3, 5], (np.int64(6), 5), (True, 5)):
        with pytest.raises(ParameterError, match="track_alarm_confirm"):
            replace(with_points, track_alarm_confirm=confirm)


def test_fit_records_the_gate_its_features_were_tracked_with() -> None:
    train, tune = interaction_features(400, 0, True), interaction_features(200, 1, True)
    assert fit(train, tune, classes=False).gate_px is None  # features made by hand
    train, tune = replace(train, gate_px=64.0), replace(tune, gate_px=64.0)
    assert fit(train, tune, classes=False).gate_px == 64.0
    with pytest.raises(ParameterError, match="one gate"):
        fit(train, replace(tune, gate_px=24.0), classes=False)


def with_trees() -> Identifier:
    from uavsnn.trees import Trees

    k = len(FEATURES)
    trees = Trees(
        np.array([[0, k - 1], [3, 0]]),
        np.array([[0.0, 0.5], [-0.25, 1.0]]),
        np.array([[-1.0, 0.0, 1.0, 2.0], [0.5, -0.5, 0.25, 0.0]]),
        -0.2,
    )
    return replace(model(), trees=trees)


def test_trees_round_trip_as_version_3_and_give_the_score(tmp_path: Path) -> None:
    net = small_net()
    net.identification = with_trees()
    net.save(tmp_path / "m.npz")
    with np.load(tmp_path / "m.npz", allow_pickle=False) as z:
        assert int(z["identify.version"]) == 3
        assert z["identify.tree_leaf"].shape == (2, 4)
    back = Network.load(tmp_path / "m.npz").identification
    assert back is not None and back.trees is not None
    x = np.random.default_rng(2).normal(size=(7, len(FEATURES)))
    expected = with_trees().trees.predict((x - back.mean) / back.scale)
    np.testing.assert_array_equal(back.scores(x), expected)
    assert not np.allclose(back.scores(x), replace(back, trees=None).scores(x))
    # a split on a column the model does not have is refused, in memory and in a file
    bad = replace(with_trees().trees, feature=np.array([[0, len(FEATURES)], [0, 0]]))
    with pytest.raises(ShapeError):
        replace(model(), trees=bad)
    from uavsnn.network import _add_arrays

    _add_arrays(str(tmp_path / "m.npz"), {"identify.tree_leaf": np.zeros((2, 3))})
    with pytest.raises(ModelFileError, match="inconsistent"):
        Network.load(tmp_path / "m.npz")


def interaction_features(m: int, seed: int, linear: bool):
    """Objects whose UAV label is an interaction of two features (or, with ``linear``, their
    sum), as :class:`WindowFeatures`."""
    from uavsnn.identify import WindowFeatures

    rng = np.random.default_rng(seed)
    x = rng.normal(size=(m, len(FEATURES)))
    y = x[:, 4] + x[:, 5] > 0 if linear else (x[:, 4] > 0) != (x[:, 5] > 0)
    return WindowFeatures(x, np.arange(m), np.zeros((m, 4)), m, y, np.ones(m, bool))


def test_fit_keeps_trees_where_they_predict_the_tuning_objects_better() -> None:
    from uavsnn.identify import model_name

    train, tune = interaction_features(1500, 0, False), interaction_features(600, 1, False)
    auto = fit(train, tune, classes=False)
    assert auto.trees is not None and model_name(auto).startswith("trees (")
    test = interaction_features(600, 2, False)
    assert np.mean((auto.scores(test.x) > 0.5) == test.label) > 0.9
    assert fit(train, tune, classes=False, model="logistic").trees is None
    # where the rule is linear, the logistic fit predicts as well and is kept
    train, tune = interaction_features(1500, 3, True), interaction_features(600, 4, True)
    assert fit(train, tune, classes=False).trees is None
    assert model_name(fit(train, tune, classes=False)) == "logistic"
    assert fit(train, tune, classes=False, model="trees").trees is not None


def test_auto_never_keeps_trees_without_a_tree(monkeypatch) -> None:
    """Trees stopped before their first tree (the tuning loss rose from the start) give every
    object the base rate: a score that ranks nothing, which auto must not keep."""
    from uavsnn import identify
    from uavsnn.trees import Trees

    none = Trees(np.zeros((0, 2), np.int64), np.zeros((0, 2)), np.zeros((0, 4)), 0.3)
    monkeypatch.setattr(identify, "fit_tree_score", lambda *args, **kwargs: (none, 0.1))
    train, tune = interaction_features(400, 0, False), interaction_features(200, 1, False)
    assert fit(train, tune, classes=False).trees is None
    assert fit(train, tune, classes=False, model="trees").trees is none


def named(feats, classes: list[str]):
    """``feats`` with its non-UAV objects named by ``classes`` in turn."""
    cls = np.array([UAV_CLASS] * len(feats.label), dtype="<U12")
    others = np.flatnonzero(~feats.label)
    cls[others] = [classes[i % len(classes)] for i in range(len(others))]
    return replace(feats, cls=cls)


def test_auto_keeps_the_logistic_score_when_the_tuning_set_lacks_a_class() -> None:
    from uavsnn.identify import missing_classes

    train = named(interaction_features(1500, 0, False), ["bird", "helicopter"])
    tune = named(interaction_features(600, 1, False), ["bird", "helicopter"])
    assert missing_classes(train, tune) == ()
    assert fit(train, tune, classes=False).trees is not None
    lacking = named(interaction_features(600, 1, False), ["bird"])
    assert missing_classes(train, lacking) == ("helicopter",)
    assert fit(train, lacking, classes=False).trees is None
    assert fit(train, lacking, classes=False, model="trees").trees is not None  # asked for
    # A class of fewer than MIN_CLASS_OBJECTS training objects, or unusable objects, do not
    # count; nor do sets without classes.
    few = replace(train, cls=np.where(np.arange(1500) == np.flatnonzero(~train.label)[1],
                                      "kite", train.cls))  # fmt: skip
    assert missing_classes(few, tune) == ()
    unusable = replace(tune, usable=tune.cls != "helicopter")
    assert missing_classes(train, unusable) == ("helicopter",)
    assert missing_classes(interaction_features(50, 2, False), tune) == ()


def test_bad_model_choices_are_typed_errors() -> None:
    from uavsnn.identify import WindowFeatures

    train = interaction_features(100, 5, True)
    with pytest.raises(ParameterError, match="model must be"):
        fit(train, train, model="forest")
    unusable = WindowFeatures(
        train.x, train.window, train.boxes, train.windows, train.label, np.zeros(100, bool)
    )
    with pytest.raises(DatasetError, match="tuning objects"):
        fit(train, unusable, model="trees")
    assert fit(train, unusable).trees is None  # auto: nothing to choose on, the logistic fit


def reordered(ident: Identifier, order: list[int]) -> Identifier:
    """``ident`` over the features ``FEATURES[i] for i in order``: the same model, its
    columns (coefficients, mean, scale, class model, tree splits) in that order."""
    names = tuple(ident.features[i] for i in order)
    with_intercept = [*order, len(order)]
    trees = ident.trees
    if trees is not None:
        where = np.argsort(order)  # a column of ident at its place in the new order
        trees = replace(trees, feature=where[trees.feature])
    class_coef = None if ident.class_coef is None else ident.class_coef[:, with_intercept]
    return replace(
        ident,
        features=names,
        coef=ident.coef[with_intercept],
        mean=ident.mean[order],
        scale=ident.scale[order],
        class_coef=class_coef,
        trees=trees,
    )


ORDERS = {
    "reversed": list(reversed(range(len(FEATURES)))),
    "shuffled": np.random.default_rng(8).permutation(len(FEATURES)).tolist(),
}


def columns_of(ident: Identifier, keep: list[int]) -> Identifier:
    """``ident``'s logistic score over the features ``keep`` (indices into FEATURES), in
    that order."""
    return Identifier(
        tuple(FEATURES[i] for i in keep),
        ident.coef[[*keep, len(FEATURES)]],
        ident.mean[keep],
        ident.scale[keep],
        ident.threshold,
        ident.l2,
    )


@pytest.mark.parametrize("order", ORDERS.values(), ids=list(ORDERS))
@pytest.mark.parametrize("make", [model, with_classes, with_trees])
def test_a_model_over_the_features_in_another_order_reads_them_by_name(
    make, order: list[int], tmp_path: Path
) -> None:
    """Rows of FEATURES are read by name whatever the order of the model's features: a model
    over the same names in another order gives the same scores, class probabilities and
    guesses (it once read the rows in its own order: other columns, without a word)."""
    from uavsnn.identify import WindowFeatures

    ident = make()
    other = reordered(ident, order)
    assert other.features != FEATURES and sorted(other.features) == sorted(FEATURES)
    x = np.random.default_rng(9).normal(size=(40, len(FEATURES))) * 2
    feats = WindowFeatures(x, np.arange(40) // 2, np.zeros((40, 4)), 20)
    net = small_net()
    net.identification = other
    net.save(tmp_path / "m.npz")
    back = Network.load(tmp_path / "m.npz").identification
    assert back is not None and back.features == other.features
    for got in (other, back):
        # the same sums in another order: equal to the last bits
        np.testing.assert_allclose(got.scores(x), ident.scores(x), rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(
            got.window_scores(feats), ident.window_scores(feats), rtol=1e-12, atol=1e-15
        )
        probabilities = got.class_probabilities(x)
        # A model without classes has none to compare (with_classes covers them).
        assert probabilities.shape == (40, len(ident.classes) if ident.classes else 0)
        np.testing.assert_allclose(
            probabilities, ident.class_probabilities(x), rtol=1e-12, atol=1e-15
        )
        assert got.guess(x) == ident.guess(x)
    if ident.trees is not None:  # comparisons only: the same scores bit for bit
        np.testing.assert_array_equal(other.scores(x), ident.scores(x))
    # Rows of the model's own features alone, when fewer than FEATURES, are read as they are.
    keep = [i for i in order if i != FEATURES.index("log_rate_swing")]
    part = columns_of(ident, keep)
    np.testing.assert_array_equal(part.scores(x), part.scores(x[:, keep]))


def test_a_model_in_the_default_order_scores_as_before_bit_for_bit(tmp_path: Path) -> None:
    """A stored model over FEATURES in their order reads the rows as they are: the scores of
    the logistic fit and of the trees on the standardised rows, bit for bit."""
    x = np.random.default_rng(10).normal(size=(30, len(FEATURES)))
    for ident in (with_classes(), with_trees()):
        net = small_net()
        net.identification = ident
        net.save(tmp_path / "m.npz")
        back = Network.load(tmp_path / "m.npz").identification
        assert back is not None and back.features == FEATURES
        z = (x - ident.mean) / ident.scale
        expected = (
            predict_logistic(ident.coef, z) if ident.trees is None else ident.trees.predict(z)
        )
        np.testing.assert_array_equal(back.scores(x), expected)
        if ident.class_coef is not None:
            np.testing.assert_array_equal(
                back.class_probabilities(x), predict_softmax(ident.class_coef, z)
            )


def test_a_fit_over_the_features_in_another_order_scores_as_in_their_order() -> None:
    train, tune, test = (
        interaction_features(m, s, True) for m, s in ((800, 0), (300, 1), (400, 2))
    )
    plain = fit(train, tune, model="logistic", classes=False)
    backwards = fit(
        train, tune, model="logistic", classes=False, features=tuple(reversed(FEATURES))
    )
    assert backwards.features == tuple(reversed(FEATURES))
    np.testing.assert_allclose(
        backwards.window_scores(test), plain.window_scores(test), rtol=0, atol=1e-9
    )
    assert np.mean((backwards.scores(test.x) >= 0.5) == test.label) > 0.9


def test_a_fit_over_the_features_in_another_order_tunes_the_same_threshold() -> None:
    train, tune = interaction_features(800, 0, True), interaction_features(300, 1, True)
    detected = np.ones(tune.windows, bool)
    plain, backwards = (
        fit(
            train,
            tune,
            model="logistic",
            classes=False,
            features=names,
            tune_detected=detected,
            tune_label=tune.label,
        )
        for names in (FEATURES, tuple(reversed(FEATURES)))
    )
    assert backwards.threshold == pytest.approx(plain.threshold, abs=1e-9)
    for (rate, a), (_, b) in zip(plain.alarm_thresholds, backwards.alarm_thresholds, strict=True):
        assert b == pytest.approx(a, abs=1e-9), rate


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("make", [with_classes, with_trees])
def test_a_feature_that_is_not_a_finite_number_is_refused_by_name(make, value: float) -> None:
    """A NaN or infinite feature once scored NaN (never an alarm) or 1, and guessed "other",
    without a word: every way in refuses the rows, naming the feature, in the model's own
    columns too."""
    ident = make()
    x = np.random.default_rng(11).normal(size=(3, len(FEATURES)))
    x[2, FEATURES.index("track_log_speed")] = value
    calls = [ident.scores, ident.class_probabilities, ident.guess]
    for call in calls:
        with pytest.raises(ParameterError, match="'track_log_speed' \\(column 14\\) of row 2"):
            call(x)
    with pytest.raises(ParameterError, match="track_log_speed"):
        ident.window_scores(WindowFeatures(x, np.arange(3), np.zeros((3, 4)), 3))
    with pytest.raises(ParameterError, match="track_log_speed"):
        ident.guess(x, np.array([0.1, 0.2, 0.3]))
    # Rows of a model's own features (fewer than FEATURES): the name in its order.
    keep = [i for i in ORDERS["reversed"] if FEATURES[i] != "log_rate_swing"]
    part = columns_of(ident, keep)
    column = part.features.index("track_log_speed")
    with pytest.raises(ParameterError, match=f"'track_log_speed' \\(column {column}\\) of row 2"):
        part.scores(x[:, keep])
    with pytest.raises(ParameterError, match="'track_log_speed' \\(column 14\\) of row 2"):
        part.scores(x)  # rows of FEATURES
    # The finite rows alone still score.
    assert np.isfinite(ident.scores(x[:2])).all()


def test_a_score_that_is_not_a_finite_number_is_refused() -> None:
    ident = with_classes()
    x = np.zeros((2, len(FEATURES)))
    probabilities = ident.class_probabilities(x)
    for scores in ([0.9, math.nan], [math.inf, 0.1]):
        with pytest.raises(ParameterError, match="scores must be finite"):
            ident.guess(x, np.array(scores))
        with pytest.raises(ParameterError, match="scores must be finite"):
            ident.guess_from(np.array(scores), probabilities)
    probabilities[1, 2] = math.nan
    with pytest.raises(ParameterError, match="probabilities must be finite"):
        ident.guess_from(np.array([0.9, 0.1]), probabilities)


def test_features_too_large_for_the_model_or_not_numbers_are_refused() -> None:
    ident = replace(model(), scale=np.full(len(FEATURES), 1e-3))
    x = np.zeros((1, len(FEATURES)))
    x[0, 4] = 1e308  # finite, but not once standardised
    with pytest.raises(ParameterError, match="'log_width' of row 0 is too large"):
        ident.scores(x)
    with pytest.raises(ParameterError, match="features must be numbers"):
        ident.scores([["a"] * len(FEATURES)])
    with pytest.raises(ParameterError, match="scores must be numbers"):
        ident.guess_from(np.array(["a"]), np.zeros((1, 0)))


# ---------------------------------------------------------------- batch equals streaming


def scene() -> np.ndarray:
    """A blob drifting right over sparse noise, and a square flickering at 400 Hz."""
    rng = np.random.default_rng(0)
    n = 6000
    t = 5_000 + np.cumsum(rng.integers(0, 20, n) * (rng.random(n) < 0.7))
    noise = rng.random(n) < 0.2
    cx = 3 + np.arange(n) * 15 // n
    blob = np.zeros(n, dtype=EVENT_DTYPE)
    blob["t"] = t
    blob["x"] = np.where(noise, rng.integers(0, SIZE[0], n), cx + rng.integers(0, 5, n))
    blob["y"] = np.where(noise, rng.integers(0, SIZE[1], n), 4 + rng.integers(0, 5, n))
    blob["p"] = rng.random(n) < 0.5
    period = 2_500
    rows = [
        (5_000 + c * period + half + rep, x, y, p)
        for c in range(int((t[-1] - 5_000) // period))
        for half, p in ((0, 1), (period // 2, 0))
        for rep in range(2)
        for x in range(28, 34)
        for y in range(18, 24)
    ]
    flick = np.array(rows, dtype=[("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("p", "u1")])
    out = np.zeros(len(flick), dtype=EVENT_DTYPE)
    for f in ("t", "x", "y", "p"):
        out[f] = flick[f]
    both = np.concatenate([blob, out])
    return both[np.argsort(both["t"], kind="stable")]


def streaming_and_batch(net: Network, events: np.ndarray, size: tuple[int, int]) -> tuple:
    """The streaming detector's reports over ``events`` (in two chunks), and the batch
    features of the same windows as a dataset (``window_features``), with that dataset."""
    window_us = 10_000
    det = Detector(net, window_us=window_us, overlap=0.5, start_us=int(events["t"][0]))
    reports = det.push_windows(events[: len(events) // 2])
    reports += det.push_windows(events[len(events) // 2 :]) + det.flush_windows()
    data = as_dataset(events, size, window_us)
    return reports, window_features(net, data), data


def as_dataset(events: np.ndarray, size: tuple[int, int], window_us: int) -> LabelledWindows:
    """The windows of ``events`` (half overlapping) as a dataset without a UAV, raw events kept."""
    windows = make_windows(Recording(events, size), window_us, 0.5)
    n = len(windows)
    raw = RawEvents.of_recording(events, np.asarray(windows.t0), window_us, window_us)
    return LabelledWindows(
        windows, np.zeros(n, bool), np.full(n, "none"), np.zeros(n, np.int64),
        np.full((n, 4), np.nan, np.float32), raw=raw,
    )  # fmt: skip


def assert_streaming_equals_batch(
    net: Network, events: np.ndarray, reports: list, batch, data: LabelledWindows
) -> None:
    """Each streamed object's features (rotor, shape, activity and track, as it saw them) equal
    the batch row of the same window and box, and its score is the model's score of them."""
    t = events["t"].astype(np.int64)
    by_t0 = {int(t0): i for i, t0 in enumerate(np.asarray(data.windows.t0))}
    streaming = []
    for r in reports:
        inside = events[np.searchsorted(t, r.t0) : np.searchsorted(t, r.t1)]
        for o in scored_objects(r):
            window = (r.t0, r.t1 - r.t0)
            feats = object_features(o.box, o.spikes, inside, o.rotor, o.track, window=window)
            streaming.append((by_t0[r.t0], o.box, feats))
    assert len(streaming) == len(batch.x) > 3
    for (i, box, x), j, b, y in zip(streaming, batch.window, batch.boxes, batch.x, strict=True):
        assert (i, box) == (int(j), tuple(int(v) for v in b))
        np.testing.assert_array_equal(x, y)
    # The streaming detector scores each object with the model, as the batch path does.
    scored = [(o.uav_score, o.class_guess) for r in reports for o in scored_objects(r)]
    expected = net.identification.scores(batch.x)
    assert [s for s, _ in scored] == expected.tolist()
    threshold = net.identification.threshold
    assert [g for _, g in scored] == ["uav" if s >= threshold else "other" for s in expected]
    # The batch rows carry the streamed track ids and confirmations.
    ids = [(o.track_id or 0, bool(o.track_confirmed)) for r in reports for o in scored_objects(r)]
    assert ids == list(zip(batch.track.tolist(), batch.confirmed.tolist(), strict=True))


def scored_objects(report) -> list:
    """The objects streaming measured and scored: the first MAX_ROTOR_BOXES; the others are
    tracked only (no rotor, no score)."""
    from uavsnn.detector import MAX_ROTOR_BOXES

    for o in report.objects[MAX_ROTOR_BOXES:]:
        assert o.rotor is None and o.uav_score is None
    return [o for o in report.objects[:MAX_ROTOR_BOXES] if o.rotor is not None]


def test_batch_features_equal_what_the_streaming_detector_sees() -> None:
    net = small_net()
    net.identification = model()
    events = scene()
    reports, batch, data = streaming_and_batch(net, events, SIZE)
    assert_streaming_equals_batch(net, events, reports, batch, data)
    # The flickering square's rotor is in the features (log of ~400 Hz, detected).
    rotor = batch.x[:, FEATURES.index("rotor_detected")] == 1
    assert rotor.any()
    hz = np.expm1(batch.x[rotor, FEATURES.index("rotor_log_hz")])
    assert np.all(np.abs(hz - 400) < 12)
    # The track features: the flickering square is one track, a hit per window, confirmed at
    # its third, and it does not move.
    hits = np.expm1(batch.x[:, FEATURES.index("track_log_hits")])
    np.testing.assert_allclose(hits, np.arange(1, len(hits) + 1))
    assert set(batch.track.tolist()) == {1}
    assert batch.confirmed[2:].all() and not batch.confirmed[:2].any()
    assert np.all(batch.x[:, FEATURES.index("track_log_speed")] == 0)
    # The track's mean rotor strength is the running mean of its objects' strengths.
    strength = batch.x[:, FEATURES.index("rotor_strength")]
    running = np.cumsum(strength) / np.arange(1, len(strength) + 1)
    np.testing.assert_allclose(batch.x[:, FEATURES.index("track_rotor_strength")], running)


def features_by_the_first_formulas(obj, events: np.ndarray, t0: int, t1: int) -> np.ndarray:
    """An object's features as first written: its box's events selected by a mask, the rotor
    signature measured on them, the counts taken from them, the rate per 5 ms bin over the
    window ``[t0, t1)`` by a NumPy histogram (the track from the object)."""
    x0, y0, x1, y1 = obj.box
    w, h = x1 - x0, y1 - y0
    x, y = events["x"], events["y"]
    inside = events[(x >= x0) & (x < x1) & (y >= y0) & (y < y1)]
    rotor = rotor_signature(inside, (x0, y0, w, h))
    assert obj.rotor == rotor
    n, on = len(inside), int(np.count_nonzero(inside["p"]))
    edges = np.arange((t1 - t0) // 5000 + 1) * 5000
    rate, _ = np.histogram(inside["t"].astype(np.int64) - t0, bins=edges)
    shape = [math.log(w), math.log(h), math.log(w * h), math.log(w / h), math.log1p(obj.spikes)]
    return np.array(
        [
            math.log1p(rotor.frequency_hz),
            rotor.strength,
            math.log1p(rotor.pixels),
            float(rotor.detected),
            *shape,
            math.log1p(n / (w * h)),
            (2 * on - n) / n if n else 0.0,
            math.log1p(rate_swing(rate)),
            *track_features(obj.track),
        ]
    )


@pytest.mark.parametrize("which", ["scene", "two_blobs"])
def test_features_equal_the_first_formulas_bit_for_bit(which) -> None:
    """The one-pass measurement (rotor and counts together, no selection of the box's events)
    gives the features the first formulas give, in batch and streaming, bit for bit."""
    if which == "scene":
        size, events = SIZE, scene()
        net = small_net()
    else:
        size = (120, 90)
        events = two_blobs(size)
        net = Network({**small_net().config, "width": size[0], "height": size[1]}, seed=3)
    net.identification = model()
    reports, batch, _ = streaming_and_batch(net, events, size)
    t = events["t"].astype(np.int64)
    window = [events[np.searchsorted(t, r.t0) : np.searchsorted(t, r.t1)] for r in reports]
    rows = [
        features_by_the_first_formulas(o, inside, r.t0, r.t1)
        for r, inside in zip(reports, window, strict=True)
        for o in r.objects
    ]
    assert len(rows) == len(batch.x) > 3
    assert np.array_equal(np.array(rows), batch.x)
    expected = net.identification.scores(np.array(rows))
    assert [o.uav_score for r in reports for o in r.objects] == expected.tolist()


def two_blobs(size: tuple[int, int]) -> np.ndarray:
    """Two blobs in opposite corners of the sensor, the second drifting left."""
    rng = np.random.default_rng(1)
    n = 8000
    ev = np.zeros(n, dtype=EVENT_DTYPE)
    ev["t"] = 5_000 + np.arange(n) * 5
    first = rng.random(n) < 0.5
    drift = np.arange(n) * 10 // n
    ev["x"] = np.where(first, 5, size[0] - 20 - drift) + rng.integers(0, 5, n)
    ev["y"] = np.where(first, 5, size[1] - 15) + rng.integers(0, 5, n)
    ev["p"] = rng.random(n) < 0.5
    return ev


def test_streaming_scores_every_object_of_a_window_with_two() -> None:
    """Two objects in one window, each with its own track and score (the streaming path once
    reused a name for the features and failed on the second object)."""
    size = (120, 90)
    config = {**small_net().config, "width": size[0], "height": size[1]}
    net = Network(config, seed=3)
    net.identification = model()
    events = two_blobs(size)
    reports, batch, data = streaming_and_batch(net, events, size)
    assert max(len(r.objects) for r in reports) == 2
    assert len({o.track_id for r in reports for o in r.objects}) >= 2
    assert np.any(batch.x[:, FEATURES.index("track_log_speed")] > 0)
    assert_streaming_equals_batch(net, events, reports, batch, data)


def test_batch_measures_and_scores_only_the_objects_streaming_does(monkeypatch) -> None:
    """Beyond MAX_ROTOR_BOXES objects in a window, streaming measures no rotor and gives no
    score (the cap bounds a window's work); batch gives those objects no row, so both paths
    score the same objects (batch once scored them all)."""
    import uavsnn.detector

    monkeypatch.setattr(uavsnn.detector, "MAX_ROTOR_BOXES", 1)
    size = (120, 90)
    net = Network({**small_net().config, "width": size[0], "height": size[1]}, seed=3)
    net.identification = model()
    events = two_blobs(size)
    reports, batch, data = streaming_and_batch(net, events, size)
    crowded = [r for r in reports if len(r.objects) == 2]
    assert crowded and all(r.objects[1].uav_score is None for r in crowded)
    assert len(batch.x) == sum(min(len(r.objects), 1) for r in reports)
    assert_streaming_equals_batch(net, events, reports, batch, data)


def test_the_detector_scores_with_a_model_over_the_features_in_another_order() -> None:
    """The streaming detector reads an object's features by name, as the batch path does: a
    model over them in another order gives each object the same score and guess."""
    size = (120, 90)
    net = Network({**small_net().config, "width": size[0], "height": size[1]}, seed=3)
    events = two_blobs(size)
    scores = []
    for ident in (with_classes(), reordered(with_classes(), ORDERS["reversed"])):
        net.identification = ident
        reports, _, _ = streaming_and_batch(net, events, size)
        objects = [o for r in reports for o in scored_objects(r)]
        scores.append([(o.uav_score, o.class_probabilities, o.class_guess) for o in objects])
    assert len(scores[0]) > 3
    for (a, pa, ga), (b, pb, gb) in zip(*scores, strict=True):
        assert b == pytest.approx(a, rel=1e-12, abs=1e-15) and ga == gb
        np.testing.assert_allclose(pb, pa, rtol=1e-12, atol=1e-15)


def test_track_features_follow_recordings_in_time_order_whatever_the_dataset_order() -> None:
    """The batch path orders each recording's windows by time and restarts the tracker for
    each recording: the features of a shuffled dataset are the shuffled features; two copies
    of the recording under two ids give two equal sets of tracks; and a window left out of the
    dataset counts as a miss (the tracks' ages keep counting over it)."""
    net = small_net()
    events = scene()
    _, batch, data = streaming_and_batch(net, events, SIZE)
    n = len(data)
    perm = np.random.default_rng(5).permutation(n)
    shuffled = window_features(net, data.select(perm))
    rows = {
        (int(perm[w]), tuple(b)): x.tolist()
        for w, b, x in zip(shuffled.window, shuffled.boxes.tolist(), shuffled.x, strict=True)
    }
    assert rows == {
        (int(w), tuple(b)): x.tolist()
        for w, b, x in zip(batch.window, batch.boxes.tolist(), batch.x, strict=True)
    }
    # Two recordings: the second a copy of the first under another id.
    twice = data.select(np.concatenate([np.arange(n), np.arange(n)]))
    twice = replace(twice, recording=np.repeat([0, 1], n))
    both = window_features(net, twice)
    half = len(batch.x)
    np.testing.assert_array_equal(both.x[:half], both.x[half:])
    np.testing.assert_array_equal(both.track[:half], both.track[half:])
    # Leave out one window with an object: the next object's track is older by the gap and
    # has one hit fewer.
    gone = int(batch.window[3])
    kept = window_features(net, data.select(np.delete(np.arange(n), gone)))
    age = FEATURES.index("track_log_age_ms")
    hits = FEATURES.index("track_log_hits")
    after = np.flatnonzero(kept.window == gone)[0]  # the window after the gap, renumbered
    assert kept.x[after, age] == batch.x[4, age]
    assert np.expm1(kept.x[after, hits]) == pytest.approx(np.expm1(batch.x[4, hits]) - 1)


def test_a_window_twice_in_one_recording_is_refused() -> None:
    net = small_net()
    _, _, data = streaming_and_batch(net, scene(), SIZE)
    with pytest.raises(DatasetError, match="two windows starting at"):
        window_features(net, data.select([0, 1, 1, 2]))


def test_features_of_a_dataset_without_raw_events_are_refused() -> None:
    events = scene()[:2000]
    windows = make_windows(Recording(events, SIZE), 10_000, 0.5)
    n = len(windows)
    data = LabelledWindows(
        windows, np.zeros(n, bool), np.full(n, "none"), np.zeros(n, np.int64),
        np.full((n, 4), np.nan, np.float32),
    )  # fmt: skip
    with pytest.raises(DatasetError, match="raw events"):
        window_features(small_net(), data)
    other = Network({"width": 48, "height": 30}, seed=0)
    with pytest.raises(ShapeError, match="40x30 but the model's input is 48x30"):
        window_features(other, data)


# ---------------------------------------------------------------- the figures


def test_roc_and_detection_at_a_false_alarm_rate_on_hand_made_scores() -> None:
    actual = np.array([True] * 4 + [False] * 4)
    scores = np.array([0.9, 0.8, 0.3, -np.inf, 0.85, 0.2, 0.1, -np.inf])
    fa, pd = roc_curve(scores, actual)
    np.testing.assert_allclose(fa, [0, 0, 0.25, 0.25, 0.25, 0.5, 0.75])
    np.testing.assert_allclose(pd, [0, 0.25, 0.25, 0.5, 0.75, 0.75, 0.75])
    # 25 % of 4 UAV-free windows: one may alarm (0.85), so the threshold sits just above 0.2.
    t = threshold_at_false_alarm(scores, actual, 0.25)
    assert 0.2 < t < 0.3
    assert np.mean(scores[actual] >= t) == 0.75
    assert detection_at_false_alarm(scores, actual, 0.25) == 0.75
    # 0 %: just above the highest UAV-free score.
    assert 0.85 < threshold_at_false_alarm(scores, actual, 0.0) < 0.9
    assert detection_at_false_alarm(scores, actual, 0.0) == 0.25
    # Of the 16 (UAV, other) pairs the UAV wins 4 + 3 + 3, and -inf against -inf is a tie.
    assert roc_area(scores, actual) == 10.5 / 16
    assert roc_area(scores[actual], actual[actual]) is None
    with pytest.raises(ParameterError):
        threshold_at_false_alarm(scores, actual, 1.5)
    with pytest.raises(ShapeError):
        roc_curve(scores[:3], actual)


def test_identification_figures_on_hand_made_windows() -> None:
    n = 200
    rng = np.random.default_rng(2)
    label = np.arange(n) < 100
    cls = np.where(label, "drone", np.where(np.arange(n) % 2, "bird", "ball"))
    size = np.where(label, np.where(np.arange(n) < 50, 4.0, 20.0), np.nan).astype(np.float32)
    # UAVs of 20 px score high, UAVs of 4 px below the birds; the balls low.
    scores = np.where(label, np.where(size > 10, 0.9, 0.3), np.where(cls == "ball", 0.1, 0.5))
    scores = scores + rng.uniform(0, 0.01, n)
    detected = np.ones(n, bool)
    windows = make_windows(Recording(scene()[:50], SIZE), 100_000, 0.0)
    data = LabelledWindows(
        windows.select(np.zeros(n, np.int64)), label, cls, np.arange(n) // 10,
        np.full((n, 4), np.nan, np.float32), size_px=size,
    )  # fmt: skip
    f = identification_figures(detected, scores, data, threshold=0.7)
    assert f["any_spike"]["confusion"] == [[100, 0], [100, 0]]
    assert f["identified"]["confusion"] == [[50, 50], [0, 100]]
    assert f["identified"]["accuracy"] == 0.75
    # Each rule's accuracy with its interval over the recordings, UAV and UAV-free drawn apart:
    # with identification the 20 px UAVs' recordings are all right and the 4 px ones' all
    # wrong, so a draw moves the share; the any-spike rule is right on every UAV window and
    # on no UAV-free one, the same share on every draw (so Clopper-Pearson's over the windows).
    for key, pred in (("any_spike", detected), ("identified", detected & (scores >= 0.7))):
        want = recording_interval(pred == label, data.recording, strata=label)
        assert f[key]["accuracy_interval"] == list(want)
    lo, hi = f["identified"]["accuracy_interval"]
    assert lo < 0.75 < hi
    lo0, hi0 = f["any_spike"]["accuracy_interval"]
    assert lo0 < 0.5 < hi0 and lo0 + hi0 == pytest.approx(1.0)
    # What identification adds: +25 points, on the same draws of recordings (the any-spike
    # rule's share is the same on every draw, so the lead's interval is the share's, shifted).
    lead = f["accuracy_lead"]
    assert lead["lead"] == pytest.approx(0.25)
    pred = detected & (scores >= 0.7)
    assert lead["interval"] == list(
        recording_interval(pred == label, data.recording, against=detected == label, strata=label)
    )
    assert lead["interval"] == pytest.approx([lo - 0.5, hi - 0.5])
    from uavsnn.report import identification_markdown

    text = identification_markdown(f)
    assert f"**75.0 %** ({100 * lo:.1f}–{100 * hi:.1f}) |" in text
    d_lo, d_hi = lead["interval"]
    assert f"+25.0 ({100 * d_lo:+.1f} to {100 * d_hi:+.1f}) points of accuracy" in text
    # Big UAVs, then birds, then small UAVs, then balls: 0.5 * 0.5 + 0.5 * 1.0.
    assert f["roc"]["area_reachable"] == pytest.approx(0.75)
    at1 = f["at_false_alarm"][0]
    assert at1["false_alarm_rate"] <= 0.01
    assert at1["detection_rate"] == 0.5
    sizes = {z["low"]: z["rate"] for z in at1["by_size_px"]}
    assert sizes == {0.0: 0.0, 12.0: 1.0}
    # Each bin counts its recordings beside its windows: ten windows a recording here.
    assert {z["low"]: (z["windows"], z["recordings"]) for z in at1["by_size_px"]} == {
        0.0: (50, 5),
        12.0: (50, 5),
    }
    assert at1["false_alarms_per_class"]["ball"] == 0.0
    at5 = f["at_false_alarm"][1]
    assert at5["false_alarms_per_class"]["bird"] <= 0.1
    assert detection_by_target(f["at_false_alarm"]) == {
        0.01: at1["detection_rate"],
        0.05: at5["detection_rate"],
    }
    with pytest.raises(ShapeError):
        identification_figures(detected[:3], scores, data, 0.5)


@pytest.mark.parametrize("uav", [True, False])
def test_identification_figures_of_one_class(uav: bool) -> None:
    """Drone-only (or UAV-free) footage under --unbalanced: no ROC and no point read off one,
    but both rules' figures, and the measurable rates at thresholds set beforehand."""
    from uavsnn.report import identification_markdown

    n = 40
    label = np.full(n, uav)
    windows = make_windows(Recording(scene()[:50], SIZE), 100_000, 0.0)
    data = LabelledWindows(
        windows.select(np.zeros(n, np.int64)), label, np.full(n, "drone" if uav else "bird"),
        np.arange(n) // 10, np.full((n, 4), np.nan, np.float32),
        size_px=np.full(n, 8.0 if uav else np.nan, np.float32),
    )  # fmt: skip
    scores = np.linspace(0, 1, n)
    f = identification_figures(np.ones(n, bool), scores, data, 0.5, alarm_thresholds=[(0.01, 0.75)])
    assert (f["roc"], f["at_false_alarm"]) == (None, [])
    assert f["identified"]["accuracy"] == 0.5  # half the scores reach 0.5
    (point,) = f["at_tuned_false_alarm"]
    measured, missing = ("detection_rate", "false_alarm_rate")[:: 1 if uav else -1]
    assert point[missing] is None
    assert point[measured] == pytest.approx(0.25)
    text = identification_markdown(f)
    assert "one class only" in text and "| 1 % false alarms | 0.750 | " in text


# ---------------------------------------------------------------- the commands


def test_train_fits_identification_and_evaluate_reports_both_rules(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import json

    from uavsnn.cli import main
    from uavsnn.dataset import SceneSource, build

    data = tmp_path / "set"
    build(
        data, "dvs", n_test=20, n_train=40, seed=11, dvs=SceneSource("dvs", (240, 180), 200.0, 0.3)
    )
    # A tuning set of other recordings (another seed): one of the same is refused.
    tune = tmp_path / "tune"
    build(
        tune, "dvs", n_test=2, n_train=40, seed=12, dvs=SceneSource("dvs", (240, 180), 200.0, 0.3)
    )
    model = tmp_path / "m.npz"
    args = ["train", str(data), "-o", str(model), "--windows-per-layer", "100", "--quiet"]
    assert main([*args, "--set", "conv2.threshold=10", "--tune", str(tune), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)["identify"]
    assert summary["tune"] == "a separate tuning set" and 0 <= summary["threshold"] <= 1
    roc = tmp_path / "roc.png"
    assert main(["evaluate", str(model), str(data), "--json", "--roc", str(roc)]) == 0
    figures = json.loads(capsys.readouterr().out)
    ident = figures["identification"]
    assert ident["any_spike"]["confusion"] == figures["confusion"]
    assert sum(map(sum, ident["identified"]["confusion"])) == 20
    assert [p["false_alarm_target"] for p in ident["at_false_alarm"]] == [0.01, 0.05]
    assert roc.exists() and roc.stat().st_size > 0
    assert list(ident["feature_auc"]) == list(FEATURES)
    # The ablation (tuned on the tuning set), each group with its tracks.
    assert (
        main(["evaluate", str(model), str(data), "--json", "--tracks", "--ablation", str(tune)])
        == 0
    )
    figures = json.loads(capsys.readouterr().out)
    ablation = figures["identification"]["ablation"]
    assert list(ablation) == ["rotor", "shape", "track", "no_track", "no_activity_history", "all"]
    assert ablation["track"]["features"] == len(TRACK_FEATURES)
    assert ablation["no_track"]["features"] == len(FEATURES) - len(TRACK_FEATURES)
    assert ablation["no_activity_history"]["features"] == len(FEATURES) - len(TRACK_ACTIVITY)
    for row in ablation.values():
        assert row["tracks"]["found"] <= figures["tracks"]["uav_recordings"]
    # The ablation's tracks follow --confirm and --track-score as the main figures do: with
    # every feature, fitted and tuned on the sets `train` used, its model is the stored one.
    rule = ["--confirm", "1/2+3/5", "--track-score", "max"]
    assert (
        main(
            [
                "evaluate",
                str(model),
                str(data),
                "--json",
                "--tracks",
                *rule,
                "--ablation",
                str(tune),
            ]
        )
        == 0
    )
    figures = json.loads(capsys.readouterr().out)
    assert figures["tracks"]["confirm"] == "1/2+3/5"
    assert (
        figures["identification"]["ablation"]["all"]["tracks"]
        == (figures["tracks"]["rules"]["identified"])
    )
    # Without identification: the any-spike rule, a note, and --roc refused.
    bare = tmp_path / "bare.npz"
    assert main([*args, "-o", str(bare), "--no-identify"]) == 0
    capsys.readouterr()
    assert main(["evaluate", str(bare), str(data)]) == 0
    assert "only the any-spike rule" in capsys.readouterr().out
    assert main(["evaluate", str(bare), str(data), "--roc", str(roc)]) == 2


def test_feature_auc_on_hand_made_objects() -> None:
    from uavsnn.identify import WindowFeatures, feature_auc

    k = len(FEATURES)
    x = np.zeros((6, k))
    x[:, 0] = [3, 4, 5, 0, 1, 2]  # the UAVs larger: 1
    x[:, 1] = [0, 1, 2, 3, 4, 5]  # smaller: 0
    x[:, 2] = [1, 0, 1, 0, 1, 0]  # two of three either way, ties halved: 0.5 + ...
    label = np.array([True, True, True, False, False, False])
    usable = np.ones(6, bool)
    feats = WindowFeatures(x, np.arange(6), np.zeros((6, 4)), 6, label, usable)
    auc = feature_auc(feats)
    assert auc[FEATURES[0]] == 1.0 and auc[FEATURES[1]] == 0.0
    # Pairs (UAV, other): 1 > 0 in 2x2 = 4... of 9 pairs: wins 4, ties 4 (halved), losses 1.
    assert auc[FEATURES[2]] == pytest.approx((4 + 0.5 * 4) / 9)
    assert auc[FEATURES[3]] == 0.5  # all equal
    # An unusable object does not count; without both kinds there is no area.
    assert feature_auc(replace(feats, usable=label))[FEATURES[0]] is None


def test_rate_swing_is_the_swing_of_the_rate_beyond_shot_noise() -> None:
    """A steady or steadily rising rate does not swing; a rate that rises and falls by a share
    ``a`` of its mean swings by about ``a / sqrt(2)``; Poisson counts of a steady rate swing
    by little, and less the more events they hold; too few bins or no event give 0."""
    k = np.arange(10)
    assert rate_swing(np.full(10, 40)) == 0.0
    assert rate_swing(20 + 6 * k) == pytest.approx(0.0, abs=1e-6)
    for a in (0.3, 0.6):
        wave = 1e6 * (1 + a * np.sin(2 * np.pi * k / 4))  # 20 ms periods in 5 ms bins
        assert rate_swing(wave.astype(np.int64)) == pytest.approx(a / np.sqrt(2), rel=0.1)
    rng = np.random.default_rng(4)
    for mean, bound in ((20, 0.2), (2000, 0.02)):
        swings = [rate_swing(rng.poisson(mean, 10)) for _ in range(200)]
        assert np.median(swings) < bound
    wing = 20 * (1 + 0.5 * np.sin(2 * np.pi * k / 4))
    assert np.median([rate_swing(rng.poisson(wing)) for _ in range(200)]) > 0.2
    assert rate_swing([]) == rate_swing([5, 9]) == rate_swing(np.zeros(10)) == 0.0
    for bad in ([-1, 3, 4], [0.5, 2, 3], [2**32, 1, 1]):
        with pytest.raises(ParameterError, match="rate counts"):
            rate_swing(bad)


@given(st.lists(st.integers(0, 2**32 - 1), min_size=0, max_size=40))
def test_rate_swing_is_finite_and_not_negative(counts) -> None:
    s = rate_swing(counts)
    assert np.isfinite(s) and s >= 0.0


def test_evaluate_prints_the_ablation_rows_aligned(capsys: pytest.CaptureFixture[str]) -> None:
    """The text of `uavsnn evaluate --ablation`: one line per group, the names padded to the
    longest so that the figures line up."""
    from uavsnn.cli.evaluate import _print_identification
    from uavsnn.identify import GROUPS

    row = {"accuracy": 0.5, "detection_at_0.01": 0.1, "detection_at_0.05": 0.25}
    _print_identification({"rotor_coverage": [], "ablation": dict.fromkeys(GROUPS, row)})
    lines = [line for line in capsys.readouterr().out.splitlines() if "ablation" in line]
    assert len(lines) == len(GROUPS)
    assert len({line.index(": accuracy") for line in lines}) == 1
    assert lines[0].endswith("accuracy 50.0 %, detection at 1 % / 5 % false alarms 10.0 / 25.0 %")
