"""Sweep the network's thresholds on a tuning dataset: train conv2 and conv3 by STDP for each
setting and score the any-spike rule on the tuning set's own test split.

The tuning set is built with a seed that no reported test set uses (101 by default; `uavsnn
demo` and `uavsnn reproduce` use 0), so choosing settings here does not touch the figures
they report::

    python benches/python/sweep_training.py --data /tmp/tune            # builds it if absent
    python benches/python/sweep_training.py --data /tmp/tune --set conv2.threshold=10,15,45

With ``--noise``, each trained network is also scored with uniform noise on those shares of
the pixels (``uavsnn.experiments.noise_sweep``), under PENT and under the static threshold that
``uavsnn reproduce`` compares it with (``static_twin``); ``--network-seeds`` trains each
setting from several initial weights, since one STDP run's accuracy moves by a few points::

    python benches/python/sweep_training.py --data /tmp/tune --set conv2.threshold=10 \
        --set pent.max_density=null,0.6,0.7 --noise 0.005,0.02,0.05,0.1,0.2 --network-seeds 0,1

With ``--ray [ADDRESS]`` every setting trains and scores as a Ray task (a local cluster, or the
one at ADDRESS; docs/distributed.md); the rows are the same, printed in the same order.
"""

from __future__ import annotations

import argparse
import itertools
import json
import time
from pathlib import Path
from typing import Any

from uavsnn.dataset import LabelledWindows, build, load, read_manifest
from uavsnn.distributed import add_ray_option, runner_for
from uavsnn.errors import DatasetError
from uavsnn.evaluation import evaluate
from uavsnn.experiments import noise_sweep, static_twin
from uavsnn.network import Network, default_config
from uavsnn.training import apply_overrides, train


def run_setting(
    settings: list[str],
    net_seed: int,
    train_set: LabelledWindows,
    test_set: LabelledWindows,
    windows_per_layer: int,
    fractions: list[float],
) -> dict[str, Any]:
    """Train one setting from one initial weight and score it (one task under --ray)."""
    started = time.perf_counter()
    net = Network(apply_overrides(default_config(), settings), seed=net_seed)
    train(net, train_set.windows, windows_per_layer=windows_per_layer, snapshots=0)
    e = evaluate(net, test_set)
    noisy: dict[str, list[float]] = {}
    if fractions:
        static, _ = static_twin(net, train_set.windows)
        points = noise_sweep({"pent": net, "static": static}, test_set, fractions, seed=0)
        for point in points:
            noisy.setdefault(point.mode, []).append(point.evaluation.accuracy)
    return {
        "settings": settings,
        "network_seed": net_seed,
        "accuracy": e.accuracy,
        "confusion": e.confusion.tolist(),
        "called_uav": {k: round(c.called_uav_rate, 3) for k, c in sorted(e.per_class.items())},
        "noise": fractions,
        "noisy_accuracy": noisy,
        "seconds": round(time.perf_counter() - started, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, required=True, help="tuning dataset folder")
    parser.add_argument("--seed", type=int, default=101, help="tuning dataset seed (101)")
    parser.add_argument("--n-train", type=int, default=1600)
    parser.add_argument("--n-test", type=int, default=600)
    parser.add_argument("--windows-per-layer", type=int, default=8000)
    parser.add_argument(
        "--set",
        dest="grid",
        action="append",
        default=[],
        metavar="KEY=V1,V2,...",
        help="a config field and the values to try (repeatable; default conv2.threshold=15,45)",
    )
    parser.add_argument(
        "--noise",
        default="",
        metavar="F1,F2,...",
        help="also score with noise on these shares of the pixels, PENT and static",
    )
    parser.add_argument(
        "--network-seeds", default="0", metavar="S1,S2,...", help="initial weights' seeds (0)"
    )
    parser.add_argument("--json", action="store_true", help="one JSON line per setting")
    add_ray_option(parser, "each setting as a task")
    args = parser.parse_args()
    runner = runner_for(args.ray)
    try:
        if read_manifest(args.data)["seed"] != args.seed:
            raise SystemExit(f"{args.data} holds a dataset of another seed")
    except DatasetError:
        build(
            args.data, "dvs", n_train=args.n_train, n_test=args.n_test, seed=args.seed,
            runner=runner,
        )  # fmt: skip
    train_set, test_set = load(args.data, "train"), load(args.data, "test")
    grid = [g.split("=", 1) for g in (args.grid or ["conv2.threshold=15,45"])]
    keys = [k for k, _ in grid]
    fractions = [float(f) for f in args.noise.split(",") if f]
    seeds = [int(s) for s in args.network_seeds.split(",") if s]
    jobs = [
        ([f"{k}={v}" for k, v in zip(keys, values, strict=True)], net_seed)
        for values, net_seed in itertools.product(
            itertools.product(*[v.split(",") for _, v in grid]), seeds
        )
    ]
    shared_train, shared_test = runner.put(train_set), runner.put(test_set)
    rows = runner.imap(
        run_setting,
        (
            (settings, net_seed, shared_train, shared_test, args.windows_per_layer, fractions)
            for settings, net_seed in jobs
        ),
    )
    for (settings, net_seed), row in zip(jobs, rows, strict=True):
        noisy = row["noisy_accuracy"]
        if args.json:
            print(json.dumps(row), flush=True)
        else:
            rates = " ".join(f"{k} {v:.2f}" for k, v in row["called_uav"].items())
            print(
                f"{' '.join(settings):50s} seed {net_seed} "
                f"accuracy {100 * row['accuracy']:5.1f} %  called UAV: {rates}"
            )
            for mode, accuracies in noisy.items():
                figures = "  ".join(
                    f"{100 * f:g} %: {100 * a:.1f}"
                    for f, a in zip(fractions, accuracies, strict=True)
                )
                print(f"    noise, {mode:6s} {figures}")


if __name__ == "__main__":
    main()
