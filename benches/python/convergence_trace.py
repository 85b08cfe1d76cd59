"""Why the demo's convergence C = mean(w(1-w)) rises: the weights of conv2 and conv3, snapshot
by snapshot, as ``uavsnn demo`` trains them (the demo set, the recipe's settings, seed 0), and
then for ``--long`` times as many windows.

For each snapshot it prints C, the mean weight and the share of weights above 0.9, in
(0.5, 0.9], in [0.1, 0.5] and below 0.1. Weights start at 0.8 ± 0.08 (``init``), where
w(1-w) = 0.16; C is largest (0.25) when weights sit at 0.5, so weights leaving 0.8 for 0 raise
C on the way, and C only falls once most have passed 0.5. Usage:

    python benches/python/convergence_trace.py [--data DIR] [--long 10]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from uavsnn.cli.demo import DEMO_WINDOWS_PER_LAYER
from uavsnn.dataset import build_demo, load
from uavsnn.experiments import recipe_config
from uavsnn.network import Network
from uavsnn.training import train


def describe(w: np.ndarray) -> str:
    w = w.ravel()
    shares = [
        (w > 0.9).mean(),
        ((w > 0.5) & (w <= 0.9)).mean(),
        ((w >= 0.1) & (w <= 0.5)).mean(),
        (w < 0.1).mean(),
    ]
    return (
        f"C={np.mean(w * (1 - w)):.3f} mean w={w.mean():.3f} shares >0.9 {shares[0]:.2f}, "
        f"(0.5,0.9] {shares[1]:.2f}, [0.1,0.5] {shares[2]:.2f}, <0.1 {shares[3]:.2f}"
    )


def trace(windows: object, per_layer: int, seed: int) -> None:
    network = Network(recipe_config(), seed=seed)
    result = train(network, windows, windows_per_layer=per_layer, seed=seed, snapshots=6)
    for layer, r in result.layers.items():
        print(f"{layer}, {per_layer} windows:")
        for seen, weights in r.snapshots:
            print(f"  after {seen:6d} windows: {describe(weights)}")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, help="the demo set (built here when absent)")
    p.add_argument("--long", type=int, default=10, help="times the demo's windows, second run")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        data = args.data or Path(tmp) / "data"
        if not (data / "manifest.json").exists():
            build_demo(data, args.seed, overwrite=True)
        windows = load(data, "train").windows
        trace(windows, DEMO_WINDOWS_PER_LAYER, args.seed)
        if args.long > 1:
            trace(windows, args.long * DEMO_WINDOWS_PER_LAYER, args.seed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
