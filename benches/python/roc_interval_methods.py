"""Other ways of reading an interval off the same draws of recordings, for a point read off a
test set's ROC: do any cover better than ``evaluation.roc_point_interval``'s percentile
interval?

``roc_point_coverage.py`` measured the percentile interval of the detection at 1 % false
alarms covering less than its 95 % (docs/identification.md, "How well a point read off the ROC
is known"). This script takes the same pool (a model scored on several datasets' splits, the
recordings pooled, each recording's UAV-free and UAV windows two units) and the same drawn test
sets, draws each set's recordings again (``evaluation.roc_point_draws``, the draws the
percentile interval reads) and reads four intervals off them:

- **percentile**: the middle 95 % of the draws (what ``roc_point_interval`` reports);
- **basic**: the draws' spread reflected about the set's point (2θ − q97.5, 2θ − q2.5);
- **bc**: the percentiles moved by the draws' median bias (bias-corrected);
- **bca**: bc with the acceleration of a delete-one-recording jackknife, each kind of unit
  apart (Efron and Tibshirani's BCa for several samples).

For each it prints the coverage of the pool's point, the mean width, and the share of sets
whose interval lies above the pool's point (and below): where the misses fall. Beside them, the
drawn sets' points: their mean against the pool's point is the point's own bias.

    python benches/python/roc_interval_methods.py runs/reproduce/model-combined.npz \\
        runs/reproduce/data/dvs runs/val2-dvs runs/val3-dvs [--draws 300] [--json]

The datasets must be of the model's sensor size; use sets no fit or tuning of the model saw.
"""

from __future__ import annotations

import os

for _var in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
from statistics import NormalDist  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from roc_point_coverage import combined_scores, draw_set, units  # noqa: E402

from uavsnn import Network  # noqa: E402
from uavsnn.evaluation import FALSE_ALARM_RATES, detection_at_false_alarm, roc_point_draws  # noqa: E402

METHODS = ("percentile", "basic", "bc", "bca")
_NORMAL = NormalDist()


def acceleration(
    scores: np.ndarray, actual: np.ndarray, recording: np.ndarray, rate: float
) -> float:
    """BCa's acceleration for the detection at ``rate``: a delete-one-unit jackknife within
    each kind of unit (a recording's UAV-free windows, its UAV windows), combined as for
    several independent samples. 0 where no unit moves the point."""
    num = den = 0.0
    for kind in (False, True):
        ids = np.unique(recording[actual == kind])
        if len(ids) < 2:
            continue
        left_out = np.array(
            [
                detection_at_false_alarm(scores[keep], actual[keep], rate)
                for keep in (~((recording == r) & (actual == kind)) for r in ids)
            ]
        )
        n = len(ids)
        u = (n - 1) * (left_out.mean() - left_out)
        num += float((u**3).sum()) / n**3
        den += float((u**2).sum()) / n**2
    return 0.0 if den == 0 else num / (6 * den**1.5)


def intervals(
    scores: np.ndarray,
    actual: np.ndarray,
    recording: np.ndarray,
    rate: float,
    resamples: int,
    seed: int,
    level: float = 0.95,
) -> dict[str, tuple[float, float]]:
    """Each method's ``level`` interval of the set's detection at ``rate``, all read off the
    same draws of its recordings."""
    point = detection_at_false_alarm(scores, actual, rate)
    draws = roc_point_draws(scores, actual, recording, rate, resamples=resamples, seed=seed)
    tails = (50 * (1 - level), 50 * (1 + level))
    lo, hi = (float(q) for q in np.percentile(draws, tails))
    out = {"percentile": (lo, hi), "basic": (2 * point - hi, 2 * point - lo)}
    # The draws' median bias, as a normal quantile (ties count half), kept off 0 and 1.
    below = (np.sum(draws < point) + 0.5 * np.sum(draws == point)) / len(draws)
    z0 = _NORMAL.inv_cdf(min(max(below, 0.5 / len(draws)), 1 - 0.5 / len(draws)))
    accel = acceleration(scores, actual, recording, rate)
    for name, a in (("bc", 0.0), ("bca", accel)):
        qs = [
            100 * _NORMAL.cdf(z0 + (z0 + z) / (1 - a * (z0 + z)))
            for z in (_NORMAL.inv_cdf((1 - level) / 2), _NORMAL.inv_cdf((1 + level) / 2))
        ]
        q_lo, q_hi = (float(q) for q in np.percentile(draws, qs))
        out[name] = (q_lo, q_hi)
    return out


def compare(
    sets: list[dict[str, np.ndarray]], rate: float, draws: int, resamples: int, seed: int
) -> dict[str, Any]:
    """Each method's coverage of the pool's point at ``rate`` over ``draws`` sets drawn from
    the pool (as ``roc_point_coverage.coverage`` draws them), its mean width and where its
    misses fall; and the drawn sets' points against the pool's."""
    free, uav = units(sets)
    pooled = np.concatenate(free + uav, axis=1)
    pooled_a = np.repeat(
        [False, True], [sum(f.shape[1] for f in free), sum(u.shape[1] for u in uav)]
    )
    truth = detection_at_false_alarm(pooled[0], pooled_a, rate)
    n_free = max(1, round(len(free) / len(sets)))
    n_uav = max(1, round(len(uav) / len(sets)))
    rng = np.random.default_rng(seed)
    tally = {m: {"held": 0, "above": 0, "below": 0, "width": 0.0} for m in METHODS}
    points = []
    for i in range(draws):
        s, a, rec = draw_set(rng, free, uav, n_free, n_uav)
        points.append(detection_at_false_alarm(s[0], a, rate))
        for method, (lo, hi) in intervals(s[0], a, rec, rate, resamples, i).items():
            t = tally[method]
            t["held"] += lo <= truth <= hi
            t["above"] += lo > truth
            t["below"] += hi < truth
            t["width"] += hi - lo
    return {
        "rate": rate,
        "pool_point": truth,
        "draws": draws,
        "points": {"mean": float(np.mean(points)), "median": float(np.median(points))},
        "methods": {
            m: {
                "coverage": t["held"] / draws,
                "above_pool": t["above"] / draws,
                "below_pool": t["below"] / draws,
                "mean_width": t["width"] / draws,
            }
            for m, t in tally.items()
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("datasets", nargs="+", metavar="DATASET")
    parser.add_argument("--split", default="test")
    parser.add_argument("--draws", type=int, default=300, help="drawn test sets (300)")
    parser.add_argument(
        "--resamples", type=int, default=1000, help="bootstrap draws per interval (1000)"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.draws < 1 or args.resamples < 1:
        raise SystemExit("--draws and --resamples must be at least 1")
    net = Network.load(args.model)
    sets = [combined_scores(net, d, args.split) for d in args.datasets]
    out = [compare(sets, rate, args.draws, args.resamples, args.seed) for rate in FALSE_ALARM_RATES]
    if args.json:
        print(json.dumps({"model": args.model, "rates": out}, indent=1))
        return
    for r in out:
        p = r["points"]
        print(
            f"detection at {100 * r['rate']:g} % false alarms: the pool's "
            f"{100 * r['pool_point']:.1f} %; {r['draws']} drawn sets' points: mean "
            f"{100 * p['mean']:.1f} %, median {100 * p['median']:.1f} %"
        )
        for method, m in r["methods"].items():
            print(
                f"  {method:10s} coverage {100 * m['coverage']:5.1f} % (nominal 95 %), mean "
                f"width {100 * m['mean_width']:.1f}; above the pool's point "
                f"{100 * m['above_pool']:.1f} %, below {100 * m['below_pool']:.1f} %"
            )


if __name__ == "__main__":
    main()
