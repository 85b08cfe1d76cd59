"""Time of one noise level of the Table 3 sweep (``uavsnn.experiments.noise_level``) with its
identification features reading only the raw noise inside the boxes they measure (as
``uavsnn.features.window_features`` does) against all of the window's raw noise (as it did
before), and whether the points are the same.

Runs the model and its static-threshold twin on DATASET's test split at each ``--fractions``
level, each way ``--repeat`` times in turn, and prints the fastest time of each and their ratio
(the same process, the same machine). The model needs identification (``uavsnn train``
without ``--no-identify``); the dataset raw events (format 2). Not part of the test suite.

    python benches/python/raw_noise_cost.py MODEL DATASET [--fractions 0.005,0.05,0.2]
        [--repeat 3] [--seed 5]
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from uavsnn import features
from uavsnn.dataset import load
from uavsnn.experiments import noise_level, static_twin
from uavsnn.network import Network


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("dataset")
    parser.add_argument("--fractions", default="0.005,0.05,0.2")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--seed", type=int, default=5)
    args = parser.parse_args()

    net = Network.load(args.model)
    if net.identification is None:
        parser.error(f"{args.model} has no identification: nothing reads raw noise")
    test, train = load(args.dataset, "test"), load(args.dataset, "train")
    static, _ = static_twin(net, train.windows)
    nets = {"pent": net, "static": static}
    in_boxes = features.raw_noise_events

    def all_noise(*a: Any, boxes: Any = None, **k: Any) -> Any:
        return in_boxes(*a, **k)

    width, height = test.windows.sensor_size
    print(f"{args.dataset}: {len(test)} test windows of {width}x{height}, two networks")
    for fraction in (float(f) for f in args.fractions.split(",")):
        best: dict[str, float] = {}
        points: dict[str, Any] = {}
        for _ in range(args.repeat):
            for name, fn in (("all", all_noise), ("boxes", in_boxes)):
                features.raw_noise_events = fn
                start = time.perf_counter()
                points[name] = noise_level(nets, test, fraction, seed=args.seed)
                best[name] = min(best.get(name, float("inf")), time.perf_counter() - start)
        features.raw_noise_events = in_boxes
        same = all(
            a.to_dict() == b.to_dict() and a.identified == b.identified
            for a, b in zip(points["all"], points["boxes"], strict=True)
        )
        print(
            f"  {fraction:.2%} noise: all the raw noise {best['all']:.3f} s, in the boxes "
            f"{best['boxes']:.3f} s, ratio {best['boxes'] / best['all']:.2f}; "
            f"the same points: {same}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
