"""How well one tuning draw sets an operating point: the thresholds for 1 % and 5 % false alarms
set again on the tuning set's UAV-free recordings drawn again, and what they give elsewhere.

A model's identification sets its operating points on its tuning windows: the threshold on
"any-spike AND UAV score" at which at most 1 % (5 %) of their UAV-free windows alarm
(``identify.fit``). Those windows come in recordings, and a recording of an insect alarms in
most of its windows or in none, so the point is only as good as the few dozen recordings
behind it. This script computes the tuning windows' scores once, draws the tuning set's
UAV-free recordings again with replacement (``--draws`` times, whole recordings), sets each
point again on every draw as ``identify.fit`` does, and prints the 95 % spread of the thresholds.
For each ``--score`` dataset (other recordings: another seed's train split; never a test
split) it prints the false-alarm share at the model's own threshold and the spread of the
shares at the redrawn thresholds, beside that set's own recording interval
(``evaluation.recording_interval``): the first spread is the tuning draw's, the second the
scored set's. The fit itself (L2 weight, trees) is not redone; only the operating point.

    python benches/python/tune_spread.py runs/reproduce/model-dvs.npz \\
        --tune runs/reproduce/data/tune-dvs --score runs/tune2 --score runs/tune3
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from uavsnn import identify
from uavsnn.evaluation import FALSE_ALARM_RATES, recording_interval
from uavsnn.identify import alarm_threshold

sys.path.insert(0, str(Path(__file__).resolve().parent))
from tune_halves import load_identified, tuning_scores


def redrawn_thresholds(
    score: np.ndarray,
    label: np.ndarray,
    recording: np.ndarray,
    rates: tuple[float, ...],
    draws: int,
    seed: int = 0,
) -> np.ndarray:
    """``(draws, len(rates))`` thresholds, each set on the UAV-free windows of the UAV-free
    recordings drawn again with replacement (as many as there are)."""
    neg = ~np.asarray(label, bool)
    scores, recs = np.asarray(score, np.float64)[neg], np.asarray(recording)[neg]
    names, which = np.unique(recs, return_inverse=True)
    groups = [scores[which == k] for k in range(len(names))]
    rng = np.random.default_rng(seed)
    out = np.empty((draws, len(rates)))
    for d in range(draws):
        pick = np.concatenate([groups[k] for k in rng.integers(0, len(groups), len(groups))])
        alarm = np.zeros(len(pick), bool)
        out[d] = [alarm_threshold(pick, alarm, rate) for rate in rates]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("--tune", required=True, metavar="DIR", help="the model's tuning set")
    parser.add_argument("--score", action="append", default=[], metavar="DIR")
    parser.add_argument("--draws", type=int, default=200, help="redraws of the tuning set (200)")
    args = parser.parse_args()
    if not 1 <= args.draws <= 10_000:
        raise SystemExit(f"--draws must be in 1..10000, got {args.draws}")
    net, ident = load_identified(args.model)
    rates = tuple(FALSE_ALARM_RATES)
    _, score, label, recording, _ = tuning_scores(net, args.tune)
    own = [alarm_threshold(score, label, rate) for rate in rates]
    again = redrawn_thresholds(score, label, recording, rates, args.draws)
    free = len(np.unique(recording[~label]))
    print(
        f"{args.model}: {identify.model_name(ident)}; {args.tune}: {int((~label).sum())} "
        f"UAV-free windows of {free} recordings, {args.draws} redraws"
    )
    for k, rate in enumerate(rates):
        lo, hi = np.percentile(again[:, k], [2.5, 97.5])
        print(f"  set for {100 * rate:g} %: threshold {own[k]:.3f} (redrawn: {lo:.3f}-{hi:.3f})")
    for path in args.score:
        _, s, y, rec, _ = tuning_scores(net, path)
        print(
            f"  {path}: {int((~y).sum())} UAV-free windows of {len(np.unique(rec[~y]))} recordings"
        )
        for k, rate in enumerate(rates):
            at_own = s[~y] >= own[k]
            shares = np.array([(s[~y] >= t).mean() for t in again[:, k]])
            lo, hi = np.percentile(shares, [2.5, 97.5])
            rlo, rhi = recording_interval(at_own, rec[~y])
            print(
                f"    set for {100 * rate:g} %: false alarms {100 * at_own.mean():.1f} % "
                f"(this set's recordings drawn again: {100 * rlo:.1f}-{100 * rhi:.1f}; "
                f"the tuning set's: {100 * lo:.1f}-{100 * hi:.1f})"
            )


if __name__ == "__main__":
    main()
