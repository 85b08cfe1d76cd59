"""Probe what a trained network's spikes hold about the label: fit light supervised readouts
over each window's spikes on the training windows, score them on the test windows, and print
them beside the paper's any-spike rule.

SPEC §3 allows an optional light readout over conv3's spikes "only where it measurably helps".
This probe is how to tell. It reads the output of `uavsnn reproduce` (its datasets and models)
and, for the dvs and the combined network, fits on that network's own training windows and
scores on the dvs test set, which no network or readout was fitted on::

    uavsnn reproduce --out runs/reproduce --no-real
    python benches/python/probe_readout.py runs/reproduce

Features per window (all from the network's spikes, no input pixels): spikes per map of conv3,
conv2 and pool1 (log1p), the spatial spread of each of those layers' spikes, the size of the
first detection's box, the time of the first conv3 spike from the window's start, and the
spike count of every layer and of the input. Readouts: L2-regularised logistic regression on
conv3's features alone and on all of them, and k nearest neighbours on all of them (a
nonlinear bound on what the features separate).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from uavsnn.dataset import LabelledWindows, load
from uavsnn.evaluation import first_detection_boxes
from uavsnn.experiments import mix_windows
from uavsnn.network import Network

LAYERS = ("conv3", "conv2", "pool1")


def features(net: Network, data: LabelledWindows) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each window's features (all, ``(n, F)``), a mask of conv3's own, and the rule's calls."""
    inference = net.infer(data.windows, spikes=True)
    assert inference.spikes is not None
    n = len(inference)
    columns: list[np.ndarray] = []
    conv3: list[bool] = []
    for layer in LAYERS:
        spikes = inference.spikes[layer]
        window = spikes["window"]
        maps = net.shapes[layer][0]
        per_map = np.zeros((n, maps))
        np.add.at(per_map, (window, spikes["map"].astype(np.int64)), 1.0)
        columns.append(np.log1p(per_map))
        count = np.bincount(window, minlength=n).astype(float)
        for axis in ("row", "col"):
            at = spikes[axis].astype(float)
            mean = np.bincount(window, at, minlength=n) / np.maximum(count, 1)
            square = np.bincount(window, at * at, minlength=n) / np.maximum(count, 1)
            columns.append(np.sqrt(np.maximum(square - mean * mean, 0.0))[:, None])
        conv3 += [layer == "conv3"] * (maps + 2)
    box = np.nan_to_num(first_detection_boxes(inference, n).astype(float))
    columns.append(np.log1p(np.maximum(box[:, 2:] - box[:, :2], 0.0)))
    t0 = np.asarray(data.windows.t0, dtype=float)
    first = (inference.first_detection_t.astype(float) - t0) / data.windows.length_us
    columns.append(np.where(inference.detected, first, 2.0)[:, None])
    conv3 += [True] * 3
    columns.append(np.log1p(inference.counts.astype(float)))
    columns.append(np.log1p(np.diff(np.asarray(data.windows.offsets)).astype(float))[:, None])
    conv3 += [False] * 6
    return np.hstack(columns), np.array(conv3), np.asarray(inference.detected, dtype=bool)


def standardised(train: np.ndarray, test: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both feature sets centred and scaled by the training windows' mean and spread only."""
    mean, scale = train.mean(axis=0), train.std(axis=0) + 1e-9
    return (train - mean) / scale, (test - mean) / scale


def logistic(
    train: np.ndarray, labels: np.ndarray, test: np.ndarray, *, l2: float = 1e-3
) -> tuple[np.ndarray, np.ndarray]:
    """Calls on the training and the test windows of a logistic regression fitted by full-batch
    gradient descent on standardised features (:func:`standardised`)."""
    a, b = standardised(train, test)
    w, bias, y = np.zeros(a.shape[1]), 0.0, labels.astype(float)
    for _ in range(4000):
        p = 1.0 / (1.0 + np.exp(-(a @ w + bias)))
        w -= 0.1 * (a.T @ (p - y) / len(y) + l2 * w)
        bias -= 0.1 * float(np.mean(p - y))
    return a @ w + bias > 0, b @ w + bias > 0


def nearest(train: np.ndarray, labels: np.ndarray, test: np.ndarray, k: int) -> np.ndarray:
    """Majority calls of the ``k`` nearest training windows (:func:`standardised` features)."""
    a, b = standardised(train, test)
    calls = np.empty(len(b), dtype=bool)
    a_sq = (a * a).sum(axis=1)
    for start in range(0, len(b), 256):
        # Squared distances up to each test row's own norm, which does not change the order.
        d = a_sq[None, :] - 2.0 * (b[start : start + 256] @ a.T)
        idx = np.argpartition(d, k, axis=1)[:, :k]
        calls[start : start + 256] = labels[idx].mean(axis=1) > 0.5
    return calls


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="the output folder of `uavsnn reproduce`")
    parser.add_argument("--seed", type=int, default=0, help="reproduce's seed (0)")
    parser.add_argument("--n-train", type=int, default=4000, help="reproduce's --n-train")
    parser.add_argument("--json", action="store_true", help="one JSON line per network")
    args = parser.parse_args()
    dvs_train, test = load(args.out / "data/dvs", "train"), load(args.out / "data/dvs", "test")
    sim_train = load(args.out / "data/sim", "train")
    trained = {
        "dvs": dvs_train,
        "combined": mix_windows([dvs_train, sim_train], args.n_train, seed=args.seed),
    }
    truth = np.asarray(test.label, dtype=bool)
    for name, train_set in trained.items():
        net = Network.load(args.out / f"model-{name}.npz")
        x_train, conv3, rule_train = features(net, train_set)
        x_test, _, rule_test = features(net, test)
        y = np.asarray(train_set.label, dtype=bool)
        row: dict[str, object] = {
            "network": name,
            "features": int(x_train.shape[1]),
            "rule": {
                "train": float(np.mean(rule_train == y)),
                "test": float(np.mean(rule_test == truth)),
            },
        }
        for readout, cols in (("logistic conv3", conv3), ("logistic all", slice(None))):
            on_train, on_test = logistic(x_train[:, cols], y, x_test[:, cols])
            row[readout] = {
                "train": float(np.mean(on_train == y)),
                "test": float(np.mean(on_test == truth)),
            }
        for k in (5, 15, 45):
            row[f"{k} nearest"] = {"test": float(np.mean(nearest(x_train, y, x_test, k) == truth))}
        if args.json:
            print(json.dumps(row))
            continue
        print(f"{name} network, {row['features']} features, fitted on {len(y)} training windows:")
        for key, value in row.items():
            if isinstance(value, dict):
                figures = ", ".join(f"{part} {100 * acc:.1f} %" for part, acc in value.items())
                print(f"  {key:16s} {figures}")


if __name__ == "__main__":
    main()
