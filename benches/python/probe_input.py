"""Probe what a window's input spikes hold about drone against other object, given where the
object is: supervised classifiers on the input spikes inside the labelled box, fitted on the
training windows and scored on the test windows of a dataset, beside the object's size alone
and, with ``--model``, beside a trained network's any-spike rule on the same windows.

This is a reference for the detector, not a detector: it is told the labelled box (which the
network must find), and it is fitted with labels (which STDP never sees). Where it cannot tell
a drone from a bird, a ball or an insect of the same size, neither can features learned without
labels from the same spikes; where it can, the network's features are what is missing::

    python benches/python/sweep_training.py --data /tmp/tune      # builds the tuning set
    python benches/python/probe_input.py /tmp/tune
    python benches/python/probe_input.py runs/reproduce/data/dvs \\
        --model runs/reproduce/model-dvs.npz
    uavsnn dataset build /tmp/more --domain dvs --seed 7 --n-train 16000 --n-test 200
    python benches/python/probe_input.py runs/reproduce/data/dvs --more-train /tmp/more

Only windows with a labelled object take part (drones against the other classes; empty
windows, which a box cannot be drawn for, are left out). Each window's crop is the square
around the box's centre, 1.2 times its longer side (at least 4.8 px), on a ``G × G`` grid:
the share of each cell's pixels that spiked, and their mean spike time in the window; plus the
logarithm of the box's size and the number of spikes in the crop. Readouts: ridge regression on
the standardised features, k nearest neighbours and, where scikit-learn is installed
(``pip install -e ".[probe]"``), gradient-boosted trees; the grid, ridge's penalty, k and the
trees' learning rate chosen on a quarter of the training recordings held out; the chosen ones
are refitted on all training windows and scored once on the test windows.

``--more-train`` adds the training windows with an object of other datasets of the same domain
(built with other seeds, so from other recordings) to every fit, held-out choice included: how
far the readouts climb with more labelled windows.
"""

from __future__ import annotations

import argparse
import itertools
import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
from probe_readout import nearest, standardised

from uavsnn.dataset import LabelledWindows, load
from uavsnn.network import Network

GRIDS = (8, 16)
PENALTIES = (10.0, 100.0, 1000.0, 10000.0)
NEIGHBOURS = (5, 15, 45)
LEARNING_RATES = (0.05, 0.1)

#: A readout: (training features, their labels, test features, its knob) -> test calls.
Fit = Callable[[np.ndarray, np.ndarray, np.ndarray, float], np.ndarray]


def objects(data: LabelledWindows) -> np.ndarray:
    """Indices of the windows with a labelled object box."""
    return np.flatnonzero(~np.isnan(np.asarray(data.box, dtype=float)).any(axis=1))


def crop_cells(
    x: np.ndarray, y: np.ndarray, box: tuple[float, float, float, float], grid: int
) -> tuple[np.ndarray, np.ndarray, float]:
    """Which pixels ``(x, y)`` (indices; their centres count) fall in the crop around ``box``
    (the square around its centre, 1.2 times its longer side, at least 4.8 px), their cell on
    the ``grid × grid`` grid over it, and the crop's side in pixels."""
    x0, y0, x1, y1 = box
    side = max(x1 - x0, y1 - y0, 4.0) * 1.2
    u = (x + 0.5 - (x0 + x1 - side) / 2) / side * grid
    v = (y + 0.5 - (y0 + y1 - side) / 2) / side * grid
    inside = (u >= 0) & (u < grid) & (v >= 0) & (v < grid)
    return inside, v[inside].astype(np.int64) * grid + u[inside].astype(np.int64), side


def crop_features(
    x: np.ndarray,
    y: np.ndarray,
    t: np.ndarray,
    box: tuple[float, float, float, float],
    grid: int,
    time_bins: int = 0,
) -> np.ndarray:
    """One window's ``2·grid² + 2`` features (see the module's text) from its spikes
    ``(x, y, t)``, ``t`` in window lengths from the window's start; with ``time_bins``, a
    histogram of the crop's spike times (shares of its spikes) goes before the last two."""
    inside, cell, side = crop_cells(x, y, box, grid)
    n = int(inside.sum())
    count = np.bincount(cell, minlength=grid * grid).astype(float)
    times = np.bincount(cell, t[inside], minlength=grid * grid)
    hist = np.histogram(t[inside], bins=time_bins, range=(0.0, 1.0))[0] if time_bins else []
    return np.r_[
        count / max(1.0, (side / grid) ** 2),
        times / np.maximum(count, 1.0),
        np.asarray(hist, dtype=float) / max(1, n),
        np.log(side),
        np.log1p(n),
    ]


def crops(data: LabelledWindows, which: np.ndarray, grid: int) -> np.ndarray:
    """``(len(which), 2·grid² + 2)`` features of the windows ``which`` (see the module's text)."""
    w = data.windows
    offsets, t0 = np.asarray(w.offsets), np.asarray(w.t0)
    out = np.zeros((len(which), 2 * grid * grid + 2))
    for row, i in enumerate(which):
        a, b = offsets[i], offsets[i + 1]
        x0, y0, x1, y1 = (float(v) for v in data.box[i])
        out[row] = crop_features(
            np.asarray(w.x[a:b], dtype=float),
            np.asarray(w.y[a:b], dtype=float),
            (np.asarray(w.t[a:b], dtype=float) - float(t0[i])) / w.length_us,
            (x0, y0, x1, y1),
            grid,
        )
    return out


def ridge(train: np.ndarray, labels: np.ndarray, test: np.ndarray, penalty: float) -> np.ndarray:
    """Calls on ``test`` of a ridge regression onto ±1 fitted on standardised ``train``."""
    a, b = standardised(train, test)
    a, b = np.c_[a, np.ones(len(a))], np.c_[b, np.ones(len(b))]
    target = np.where(labels, 1.0, -1.0)
    w = np.linalg.solve(a.T @ a + penalty * np.eye(a.shape[1]), a.T @ target)
    return np.asarray(b @ w > 0)


def knn(train: np.ndarray, labels: np.ndarray, test: np.ndarray, k: float) -> np.ndarray:
    """:func:`nearest` with ``k`` given as a knob."""
    return nearest(train, labels, test, int(k))


def boosted(train: np.ndarray, labels: np.ndarray, test: np.ndarray, rate: float) -> np.ndarray:
    """Calls on ``test`` of gradient-boosted trees (scikit-learn's histogram ones, early-stopped
    on a tenth of ``train``) with learning rate ``rate``."""
    from sklearn.ensemble import HistGradientBoostingClassifier

    model = HistGradientBoostingClassifier(
        learning_rate=rate, max_iter=400, early_stopping=True, random_state=0
    )
    return np.asarray(model.fit(train, labels).predict(test), dtype=bool)


def has_sklearn() -> bool:
    """Whether scikit-learn, which :func:`boosted` needs, is installed."""
    try:
        import sklearn  # noqa: F401
    except ImportError:
        return False
    return True


def held_out(recording: np.ndarray, seed: int) -> np.ndarray:
    """A mask over rows of the given recordings: the rows of a quarter of the recordings."""
    recordings = np.unique(recording)
    rng = np.random.default_rng(seed)
    chosen = rng.choice(recordings, size=max(1, len(recordings) // 4), replace=False)
    return np.isin(recording, chosen)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", type=Path, help="a dataset folder with train and test splits")
    parser.add_argument("--model", type=Path, help="a model whose any-spike rule to show beside")
    parser.add_argument(
        "--more-train",
        type=Path,
        action="append",
        default=[],
        help="another dataset of the same domain whose training windows join every fit",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the held-out recordings")
    parser.add_argument("--json", action="store_true", help="one JSON line")
    args = parser.parse_args()
    train, test = load(args.data, "train"), load(args.data, "test")
    tr, te = objects(train), objects(test)
    y_tr, y_te = np.asarray(train.label)[tr], np.asarray(test.label)[te]
    val = held_out(train.recording[tr], args.seed)
    more = [load(path, "train") for path in args.more_train]
    y_more = np.concatenate([np.asarray(m.label)[objects(m)] for m in more] + [y_tr[:0]])

    def more_crops(grid: int) -> np.ndarray:
        empty = np.zeros((0, 2 * grid * grid + 2))
        return np.concatenate([crops(m, objects(m), grid) for m in more] + [empty])

    features = {g: (crops(train, tr, g), crops(test, te, g), more_crops(g)) for g in GRIDS}

    def chosen(fit: Fit, knobs: tuple[float, ...]) -> tuple[int, float, float]:
        """The grid and knob with the best held-out accuracy, and the test accuracy once
        refitted on all training windows."""
        options = list(itertools.product(GRIDS, knobs))
        scores = []
        for grid, knob in options:
            x, extra = features[grid][0], features[grid][2]
            fitted = fit(np.r_[x[~val], extra], np.r_[y_tr[~val], y_more], x[val], knob)
            scores.append(float(np.mean(fitted == y_tr[val])))
        grid, knob = options[int(np.argmax(scores))]
        x, test_x, extra = features[grid]
        calls = fit(np.r_[x, extra], np.r_[y_tr, y_more], test_x, knob)
        return grid, knob, float(np.mean(calls == y_te))

    size_tr = np.r_[features[GRIDS[0]][0], features[GRIDS[0]][2]][:, -2:-1]
    size_te, y_size = features[GRIDS[0]][1][:, -2:-1], np.r_[y_tr, y_more]
    size_val = np.r_[val, np.zeros(len(y_more), dtype=bool)]
    size_scores = [
        float(
            np.mean(knn(size_tr[~size_val], y_size[~size_val], size_tr[size_val], k) == y_tr[val])
        )
        for k in (15, 45, 135)
    ]
    k_size = (15, 45, 135)[int(np.argmax(size_scores))]
    row: dict[str, object] = {
        "data": str(args.data),
        "train_windows": len(tr) + len(y_more),
        "test_windows": len(te),
        "test_drone_share": float(np.mean(y_te)),
        "size alone": {
            "k": k_size,
            "test": float(np.mean(knn(size_tr, y_size, size_te, k_size) == y_te)),
        },
    }
    g, penalty, acc = chosen(ridge, PENALTIES)
    row["ridge"] = {"grid": g, "penalty": penalty, "test": acc}
    g, k, acc = chosen(knn, tuple(float(k) for k in NEIGHBOURS))
    row["nearest"] = {"grid": g, "k": int(k), "test": acc}
    if has_sklearn():
        g, rate, acc = chosen(boosted, LEARNING_RATES)
        row["boosted trees"] = {"grid": g, "learning rate": rate, "test": acc}
    if args.model is not None:
        net = Network.load(args.model)
        detected = np.asarray(net.infer(test.windows).detected, dtype=bool)[te]
        row["any-spike rule"] = {"test": float(np.mean(detected == y_te))}
    if args.json:
        print(json.dumps(row))
        return
    print(
        f"{args.data}: {len(tr) + len(y_more)} training and {len(te)} test windows with a "
        f"labelled object ({100 * float(np.mean(y_te)):.1f} % of the test ones drones)"
    )
    for key, value in row.items():
        if isinstance(value, dict):
            knobs = ", ".join(f"{k} {v}" for k, v in value.items() if k != "test")
            print(f"  {key:15s} {100 * value['test']:5.1f} % on test  {knobs}")


if __name__ == "__main__":
    main()
