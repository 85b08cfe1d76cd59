"""Boosted oblivious trees (uavsnn.trees), the second light model of identification."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uavsnn.errors import ParameterError, ShapeError
from uavsnn.linear import fit_logistic, predict_logistic
from uavsnn.trees import Trees, fit_trees


def xor(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 4))
    return x, (x[:, 0] > 0) != (x[:, 1] > 0)  # columns 2 and 3 are noise


def test_trees_learn_an_interaction_a_logistic_fit_cannot() -> None:
    x, y = xor(2000, 0)
    xt, yt = xor(1000, 1)
    xs, ys = xor(1000, 2)
    model = fit_trees(x, y, x_tune=xt, y_tune=yt, depth=3, trees=100)
    assert np.mean((model.predict(xs) > 0.5) == ys) > 0.95
    assert np.mean((predict_logistic(fit_logistic(x, y), xs) > 0.5) == ys) < 0.6
    # every split is at a value of the training data
    for t, f in zip(model.threshold.ravel(), model.feature.ravel(), strict=True):
        assert t in x[:, f]


def test_a_fit_is_repeatable() -> None:
    x, y = xor(500, 3)
    a = fit_trees(x, y, depth=3, trees=20)
    b = fit_trees(x, y, depth=3, trees=20)
    for name in ("feature", "threshold", "leaf"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.base == b.base


def test_the_tuning_set_chooses_how_many_trees_are_kept() -> None:
    rng = np.random.default_rng(4)
    x = rng.normal(size=(400, 3))
    y = rng.random(400) < 0.3  # labels unrelated to x: every tree only fits noise
    xt = rng.normal(size=(400, 3))
    yt = rng.random(400) < 0.3
    kept = fit_trees(x, y, x_tune=xt, y_tune=yt, depth=3, trees=200)
    assert len(kept.feature) < 20
    assert len(fit_trees(x, y, depth=3, trees=200).feature) == 200  # no tuning: all of them
    # the base is the training set's log odds
    assert kept.base == pytest.approx(np.log(y.mean() / (1 - y.mean())))


def test_raw_scores_follow_the_trees_by_hand() -> None:
    # one tree of depth 2: column 0 above 0 (first bit), then column 1 above 1 (second bit)
    model = Trees(
        np.array([[0, 1]]), np.array([[0.0, 1.0]]), np.array([[1.0, 2.0, 3.0, 4.0]]), -0.5
    )
    x = np.array([[-1.0, 0.0], [-1.0, 2.0], [1.0, 0.0], [1.0, 2.0], [0.0, 1.0]])
    np.testing.assert_array_equal(model.raw(x), [0.5, 1.5, 2.5, 3.5, 0.5])
    np.testing.assert_allclose(model.predict(x), 1 / (1 + np.exp(-model.raw(x))))
    assert model.columns == 2
    with pytest.raises(ShapeError):
        model.raw(np.zeros((3, 1)))


def test_constant_columns_give_the_base_rate() -> None:
    x = np.ones((50, 2))
    y = np.arange(50) < 10
    p = fit_trees(x, y, depth=2, trees=5).predict(x)
    np.testing.assert_allclose(p, 0.2, atol=1e-9)


@pytest.mark.parametrize(
    ("args", "kwargs", "error"),
    [
        ((np.zeros((3, 2)), np.zeros(4, bool)), {}, ShapeError),
        ((np.zeros((3, 2)), np.zeros(3)), {}, ParameterError),
        ((np.full((3, 2), np.nan), np.zeros(3, bool)), {}, ParameterError),
        ((np.zeros((0, 2)), np.zeros(0, bool)), {}, ParameterError),
        ((np.zeros((3, 2)), np.zeros(3, bool)), {"depth": 0}, ParameterError),
        ((np.zeros((3, 2)), np.zeros(3, bool)), {"depth": 9}, ParameterError),
        ((np.zeros((3, 2)), np.zeros(3, bool)), {"trees": -1}, ParameterError),
        ((np.zeros((3, 2)), np.zeros(3, bool)), {"bins": 1}, ParameterError),
        ((np.zeros((3, 2)), np.zeros(3, bool)), {"learning_rate": 0.0}, ParameterError),
        ((np.zeros((3, 2)), np.zeros(3, bool)), {"l2": 0.0}, ParameterError),
        (
            (np.zeros((3, 2)), np.zeros(3, bool)),
            {"x_tune": np.zeros((2, 3)), "y_tune": np.zeros(2, bool)},
            ShapeError,
        ),
        (
            (np.zeros((3, 2)), np.zeros(3, bool)),
            {"x_tune": np.zeros((2, 2)), "y_tune": np.zeros(2)},
            ParameterError,
        ),
    ],
)
def test_bad_fit_inputs_are_typed_errors(args, kwargs, error) -> None:
    with pytest.raises(error):
        fit_trees(*args, **kwargs)


@pytest.mark.parametrize(
    ("feature", "threshold", "leaf", "base", "error"),
    [
        (np.zeros((2, 2), int), np.zeros((2, 2)), np.zeros((2, 3)), 0.0, ShapeError),
        (np.zeros((2, 2), int), np.zeros((2, 1)), np.zeros((2, 4)), 0.0, ShapeError),
        (-np.ones((1, 1), int), np.zeros((1, 1)), np.zeros((1, 2)), 0.0, ParameterError),
        (np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 2)), 0.0, ParameterError),
        (np.zeros((1, 1), int), np.full((1, 1), np.inf), np.zeros((1, 2)), 0.0, ParameterError),
        (np.zeros((1, 1), int), np.zeros((1, 1)), np.zeros((1, 2)), np.nan, ParameterError),
        (np.zeros((1, 9), int), np.zeros((1, 9)), np.zeros((1, 512)), 0.0, ParameterError),
    ],
)
def test_inconsistent_trees_are_refused(feature, threshold, leaf, base, error) -> None:
    with pytest.raises(error):
        Trees(feature, threshold, leaf, base)


@settings(max_examples=40, deadline=None)
@given(
    st.integers(2, 60),
    st.integers(1, 4),
    st.integers(1, 4),
    st.integers(0, 2**31 - 1),
)
def test_any_fit_predicts_probabilities_and_lowers_the_training_loss(n, d, depth, seed) -> None:
    rng = np.random.default_rng(seed)
    x = np.round(rng.normal(size=(n, d)), 1)  # ties, as binned features have
    y = rng.random(n) < 0.5
    model = fit_trees(x, y, depth=depth, trees=10)
    p = model.predict(x)
    assert np.all((p >= 0) & (p <= 1)) and p.shape == (n,)

    def loss(raw: np.ndarray) -> float:
        return float(np.mean(np.logaddexp(0.0, np.where(y, -raw, raw))))

    assert loss(model.raw(x)) <= loss(np.full(n, model.base)) + 1e-12


def test_rows_of_another_width_than_the_fit_are_refused() -> None:
    # Rows of five columns scored by trees fitted on four gave probabilities, silently wrong.
    x, y = xor(200, 1)
    model = fit_trees(x, y, trees=5)
    assert model.width == 4 and model.predict(x).shape == (200,)
    for rows in (np.zeros((2, 5)), np.zeros((2, 3)), np.zeros(4)):
        with pytest.raises(ShapeError, match=r"x must be \(n, 4\)"):
            model.predict(rows)
    # without a width (a model file's trees) rows need the columns split on, and may have more
    loaded = Trees(model.feature, model.threshold, model.leaf, model.base)
    assert np.array_equal(loaded.predict(np.hstack([x, x])), model.predict(x))
    with pytest.raises(ParameterError, match="width must be an integer >= 2"):
        Trees(np.array([[1]]), np.zeros((1, 1)), np.zeros((1, 2)), 0.0, width=1)


def test_logistic_and_softmax_coefficients_of_another_width_are_refused() -> None:
    from uavsnn.linear import fit_softmax, predict_softmax

    x, y = xor(50, 2)
    coef = fit_logistic(x, y)
    assert predict_logistic(coef, x).shape == (50,)
    soft = fit_softmax(x, y.astype(np.int64), 2)
    assert predict_softmax(soft, x).shape == (50, 2)
    # NumPy's ValueError from the product came out before
    for rows in (x[:, :3], x[0]):
        with pytest.raises(ShapeError, match="coefficients"):
            predict_logistic(coef, rows)
        with pytest.raises(ShapeError, match="coefficients"):
            predict_softmax(soft, rows)
    with pytest.raises(ShapeError, match="coefficients"):
        predict_logistic(soft, x)
    with pytest.raises(ShapeError, match="coefficients"):
        predict_softmax(coef, x)
