"""Where a tuned threshold comes from: a model's identification on each of its tuning sets alone.

For each ``--tune`` dataset (its train split: the tuning windows ``uavsnn reproduce`` draws
from, e.g. ``data/tune-dvs`` and ``data/tune-sim`` for the combined network), prints the
any-spike rule's balanced accuracy, the threshold ``identify.best_threshold`` would choose on
that set alone and its balanced accuracy, the balanced accuracy at the model's own threshold,
and the shares of UAV and UAV-free windows the network fires on. Then how flat the best is:
the range of candidate thresholds whose balanced accuracy is within ``--within`` (default one
point) of the best, and the balanced accuracy at each ``--at`` threshold (another run's, say).
Tuning data only: no test split is read.

    python benches/python/tune_halves.py runs/reproduce/model-combined.npz \\
        --tune runs/reproduce/data/tune-dvs --tune runs/reproduce/data/tune-sim [--at 0.608]
"""

from __future__ import annotations

import argparse

import numpy as np

from uavsnn import Network, identify
from uavsnn.dataset import load
from uavsnn.identify import Identifier


def load_identified(path: str) -> tuple[Network, Identifier]:
    """The model at ``path`` and its identification; exits with why when it has none."""
    net = Network.load(path)
    if net.identification is None:
        raise SystemExit(f"{path}: no identification to look at")
    return net, net.identification


def tuning_scores(net: Network, path: str, *, held_out: bool = False) -> tuple[np.ndarray, ...]:
    """A dataset's train split through ``net``: per window the any-spike rule's call, the score
    of "any-spike AND UAV score" that ``identify.fit`` sets its thresholds on (-1 where the rule
    does not fire), the truth, the recording and the class. ``held_out``: only the quarter of
    the split's recordings that ``uavsnn train`` holds out to tune on when given no tuning set
    (``identify.split_by_recording``), as the real network of ``reproduce`` is tuned."""
    ident = net.identification
    if ident is None:
        raise SystemExit("the model has no identification to look at")
    data = load(path, "train")
    if held_out:
        data = identify.split_by_recording(data)[1]
    fired = np.asarray(net.infer(data.windows).detected, bool)
    score = np.where(fired, ident.window_scores(identify.window_features(net, data)), -1.0)
    label, cls = np.asarray(data.label, bool), np.asarray(data.cls).astype(str)
    return fired, score, label, np.asarray(data.recording), cls


def balanced(call: np.ndarray, label: np.ndarray) -> float:
    """The mean of the share of UAV windows called and of UAV-free windows not called."""
    return float(0.5 * (call[label].mean() + (~call[~label]).mean()))


def near_best(score: np.ndarray, label: np.ndarray, within: float) -> tuple[float, float, int]:
    """The lowest and highest of ``identify.best_threshold``'s candidates whose balanced
    accuracy is within ``within`` of the best, and how many candidates that is."""
    candidates, acc = identify.threshold_accuracies(score, label)
    near = candidates[acc >= acc.max() - within]
    return float(near.min()), float(near.max()), len(near)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("--tune", action="append", required=True, metavar="DIR")
    parser.add_argument("--at", type=float, action="append", default=[], metavar="THRESHOLD")
    parser.add_argument("--within", type=float, default=0.01, help="of the best (0.01)")
    args = parser.parse_args()
    if not 0 <= args.within < 1:
        raise SystemExit(f"--within must be in [0, 1), got {args.within}")
    net, ident = load_identified(args.model)
    print(f"{args.model}: {identify.model_name(ident)}, threshold {ident.threshold:.3f}")
    for path in args.tune:
        fired, score, label, _, _ = tuning_scores(net, path)
        best = identify.best_threshold(score, label)
        print(
            f"  {path}: any-spike {balanced(fired, label):.3f}; best threshold on it alone "
            f"{best:.3f} -> {balanced(score >= best, label):.3f}; at the model's "
            f"{balanced(score >= ident.threshold, label):.3f}; fired on {fired[label].mean():.3f}"
            f" of UAV windows, {fired[~label].mean():.3f} of UAV-free ones"
        )
        lo, hi, n = near_best(score, label, args.within)
        at = "; ".join(f"at {t:.3f} {balanced(score >= t, label):.3f}" for t in args.at)
        print(
            f"    within {args.within:g} of the best: thresholds {lo:.3f}-{hi:.3f} ({n} "
            f"candidates){'; ' + at if at else ''}"
        )


if __name__ == "__main__":
    main()
