"""How well is a point read off a test set's ROC known? The coverage of
``evaluation.roc_point_interval``, measured.

``uavsnn evaluate`` and ``reproduce`` report the detection where 1 % and 5 % of the test set's
UAV-free windows alarm, with a 95 % interval when the recordings are drawn again and the
threshold read again on each draw. This script scores a model with identification on several
datasets' splits (draws of recordings of other seeds), then measures two things:

- **across the draws**: each set's point and interval, and whether each interval holds the
  other sets' points;
- **coverage**: the recordings of all the sets pooled (the UAV-free windows of a recording and
  its UAV windows as two units, as the interval draws them) are a population whose point is
  known. ``--draws`` test sets, each of as many units of each kind as one scored set has on
  average, are drawn from it with replacement; the share of their 95 % intervals that hold the
  population's point is the interval's coverage (the nominal is 95 %), beside the spread of
  the drawn sets' points and the intervals' mean width. ``--scale K`` draws sets of K times as
  many units: how the spread narrows with a test set of more recordings.

``--against OTHER`` scores a second model on the same sets and gives, for each set, the first
model's detection minus the other's with the interval of that difference on the same draws of
recordings (``roc_point_interval(..., against=...)``): whether one model's lead on a set is more
than the draw of its recordings; the coverage is then that of this paired interval, of the
pool's lead.

Beside the points on the ROC, the same for the accuracy at the model's own threshold (the
share of windows the combined rule decides right): each set's accuracy with its interval over
the recordings, UAV and UAV-free drawn apart (``recording_interval(..., strata=labels)``), and
with ``--against`` the accuracy lead with the paired interval (``against=``), each with its
coverage measured on the same pool (``--any-spike``: the any-spike rule's accuracy instead).

``--static-threshold THETA`` compares the model with its static twin instead of another model
(PENT off, conv1's threshold ``THETA``: ``results.json``'s ``static_threshold``), and
``--noise SHARE`` adds noise to every set as a Table 3 level adds it: PENT's lead over static
at that level, and how well its paired interval covers.

    python benches/python/roc_point_coverage.py runs/reproduce/model-combined.npz \\
        runs/reproduce/data/dvs runs/val2-dvs runs/val3-dvs [--split test] [--json]
    python benches/python/roc_point_coverage.py runs/reproduce/model-combined.npz \\
        runs/reproduce/data/dvs runs/val2-dvs runs/val3-dvs --static-threshold 3.024791717529297 \\
        --noise 0.01 [--any-spike]

The datasets must be of the model's sensor size; use sets no fit or tuning of the model saw.
"""

from __future__ import annotations

import os

for _var in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from uavsnn import Network, identify  # noqa: E402
from uavsnn.dataset import load  # noqa: E402
from uavsnn.evaluation import (  # noqa: E402
    FALSE_ALARM_RATES,
    detection_at_false_alarm,
    recording_interval,
    roc_point_interval,
)
from uavsnn.experiments import noise_seed, with_config  # noqa: E402
from uavsnn.windows import add_noise  # noqa: E402


def combined_scores(
    net: Network,
    data_dir: str,
    split: str,
    *,
    noise: float = 0.0,
    seed: int = 0,
    any_spike: bool = False,
) -> dict[str, np.ndarray]:
    """The combined score of each window of ``data_dir``'s ``split`` (the UAV score where the
    network detects, ``-inf`` where it does not), its label, its recording, and whether the
    combined rule at the model's threshold decides it right (``any_spike``: whether the
    any-spike rule does). ``noise``: uniform noise on that share of the pixels, as a Table 3
    level adds it (drawn from ``experiments.noise_seed(seed, noise)``; the raw events
    identification measures get noise of the same density)."""
    ident = net.identification
    if ident is None:
        raise SystemExit(f"{net}: the model has no identification part")
    data = load(data_dir, split)
    windows, raw_noise = data.windows, None
    if noise > 0:
        level_seed = noise_seed(seed, noise)
        windows, _ = add_noise(data.windows, noise, seed=level_seed)
        raw_noise = (noise, level_seed)
    inference = net.infer(windows, threads=1)
    feats = identify.window_features(net, data, inference, raw_noise=raw_noise)
    scores = ident.combined_scores(feats, inference.detected)
    actual = np.asarray(data.label, bool)
    decided = np.asarray(inference.detected, bool) if any_spike else scores >= ident.threshold
    return {
        "scores": scores,
        "actual": actual,
        "recording": np.asarray(data.recording),
        "right": decided == actual,
    }


def _keys(sets: list[dict[str, np.ndarray]], measure: str = "scores") -> tuple[str, ...]:
    """What each window carries for ``measure`` (``"scores"`` or ``"right"``): its model's, and
    the other model's where compared (``"against"``, ``"right_against"``)."""
    paired = "against" if measure == "scores" else f"{measure}_against"
    return (measure, paired) if all(paired in s for s in sets) else (measure,)


def units(
    sets: list[dict[str, np.ndarray]], measure: str = "scores"
) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The pool: each set's recordings' UAV-free windows, and UAV windows, one unit per
    recording and kind: an array of what the windows carry for ``measure``, one row per model
    (the other model's where the sets hold it, :func:`_keys`)."""
    keys = _keys(sets, measure)
    free: list[np.ndarray] = []
    uav: list[np.ndarray] = []
    for s in sets:
        for r in np.unique(s["recording"]):
            mine = s["recording"] == r
            for pool, kind in ((free, False), (uav, True)):
                part = mine & (s["actual"] == kind)
                if part.any():
                    pool.append(np.stack([s[k][part] for k in keys]))
    return free, uav


def draw_set(
    rng: np.random.Generator, free: list[np.ndarray], uav: list[np.ndarray], n_free: int, n_uav: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A test set of ``n_free`` UAV-free and ``n_uav`` UAV units drawn with replacement from the
    pool: its scores (a row per score the units carry), labels and recording ids (one id per
    unit drawn)."""
    picks = [free[i] for i in rng.integers(0, len(free), n_free)]
    picks += [uav[i] for i in rng.integers(0, len(uav), n_uav)]
    scores = np.concatenate(picks, axis=1)
    sizes = [p.shape[1] for p in picks]
    actual = np.repeat(np.arange(len(picks)) >= n_free, sizes)
    return scores, actual, np.repeat(np.arange(len(picks)), sizes)


def _figure(scores: np.ndarray, actual: np.ndarray, rate: float) -> float:
    """The point of a set: its model's detection at ``rate``, less the other's where there is
    one."""
    point = detection_at_false_alarm(scores[0], actual, rate)
    if len(scores) > 1:
        point -= detection_at_false_alarm(scores[1], actual, rate)
    return point


def _accuracy(right: np.ndarray) -> float:
    """The share of windows decided right, less the other model's where there is one."""
    point = float(right[0].mean())
    if len(right) > 1:
        point -= float(right[1].mean())
    return point


def accuracy_interval(
    right: np.ndarray, actual: np.ndarray, recording: np.ndarray, resamples: int, seed: int
) -> tuple[float, float]:
    """:func:`_accuracy`'s interval over the recordings, UAV and UAV-free drawn apart (paired
    where ``right`` holds two rows)."""
    against = right[1] if len(right) > 1 else None
    return recording_interval(
        right[0], recording, against=against, strata=actual, resamples=resamples, seed=seed
    )


def coverage(
    sets: list[dict[str, np.ndarray]],
    rate: float | None,
    draws: int,
    resamples: int,
    seed: int,
    scale: float = 1.0,
) -> dict[str, Any]:
    """The interval's coverage of the pool's point at ``rate`` over ``draws`` drawn sets, each
    of ``scale`` times a scored set's units. Where the sets hold ``"against"``, the point is
    the lead over the other model and the interval the paired one (``against=``). ``rate``
    ``None``: the accuracy at the model's threshold instead (:func:`accuracy_interval`)."""
    measure = "scores" if rate is not None else "right"
    free, uav = units(sets, measure)
    pooled = np.concatenate(free + uav, axis=1)
    pooled_a = np.repeat(
        [False, True], [sum(f.shape[1] for f in free), sum(u.shape[1] for u in uav)]
    )
    truth = _accuracy(pooled) if rate is None else _figure(pooled, pooled_a, rate)
    # The pool as one test set of all the scored sets' recordings, with its own interval.
    unit_ids = np.repeat(np.arange(len(free) + len(uav)), [u.shape[1] for u in free + uav])
    if rate is None:
        pool_interval = accuracy_interval(pooled.astype(bool), pooled_a, unit_ids, resamples, seed)
    else:
        pool_interval = roc_point_interval(
            pooled[0],
            pooled_a,
            unit_ids,
            rate,
            against=pooled[1] if len(pooled) > 1 else None,
            resamples=resamples,
            seed=seed,
        )
    n_free = max(1, round(scale * len(free) / len(sets)))
    n_uav = max(1, round(scale * len(uav) / len(sets)))
    rng = np.random.default_rng(seed)
    points, held, widths = [], 0, []
    for i in range(draws):
        s, a, rec = draw_set(rng, free, uav, n_free, n_uav)
        if rate is None:
            points.append(_accuracy(s))
            lo, hi = accuracy_interval(s.astype(bool), a, rec, resamples, i)
        else:
            points.append(_figure(s, a, rate))
            against = s[1] if len(s) > 1 else None
            lo, hi = roc_point_interval(
                s[0], a, rec, rate, against=against, resamples=resamples, seed=i
            )
        held += lo <= truth <= hi
        widths.append(hi - lo)
    return {
        "rate": rate,
        "paired": len(_keys(sets, measure)) > 1,
        "pool": {
            "uav_free_units": len(free),
            "uav_units": len(uav),
            "point": truth,
            "interval": list(pool_interval),
        },
        "units_per_set": {"uav_free": n_free, "uav": n_uav},
        "draws": draws,
        "coverage": held / draws,
        "point_spread": {
            "sd": float(np.std(points)),
            "p2.5": float(np.percentile(points, 2.5)),
            "p97.5": float(np.percentile(points, 97.5)),
        },
        "mean_width": float(np.mean(widths)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("datasets", nargs="+", metavar="DATASET")
    parser.add_argument("--split", default="test")
    parser.add_argument("--draws", type=int, default=1000, help="drawn test sets (1000)")
    parser.add_argument(
        "--resamples", type=int, default=1000, help="bootstrap draws per interval (1000)"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--scale", type=float, default=1.0, help="units per drawn set, times a scored set's (1)"
    )
    parser.add_argument("--against", metavar="MODEL", help="a second model to compare with")
    parser.add_argument(
        "--static-threshold",
        type=float,
        metavar="THETA",
        help="compare with the model's static twin (conv1 threshold THETA, PENT off: "
        "results.json's static_threshold), as Table 3 does",
    )
    parser.add_argument(
        "--noise",
        type=float,
        default=0.0,
        metavar="SHARE",
        help="noise on this share of the pixels, as a Table 3 level (0)",
    )
    parser.add_argument(
        "--any-spike",
        action="store_true",
        help="the accuracy of the any-spike rule, not of the combined rule",
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.draws < 1 or args.resamples < 1 or not args.scale > 0:
        raise SystemExit("--draws and --resamples must be at least 1, --scale above 0")
    if not 0 <= args.noise <= 1:
        raise SystemExit("--noise is a share of the pixels, in [0, 1]")
    if args.against is not None and args.static_threshold is not None:
        raise SystemExit("give --against or --static-threshold, not both")
    how = {"noise": args.noise, "seed": args.seed, "any_spike": args.any_spike}
    net = Network.load(args.model)
    sets = [combined_scores(net, d, args.split, **how) for d in args.datasets]
    other = None
    if args.against is not None:
        other = Network.load(args.against)
    elif args.static_threshold is not None:
        other = with_config(
            net, pent={"mode": "static"}, conv1={"threshold": args.static_threshold}
        )
    if other is not None:
        for d, s in zip(args.datasets, sets, strict=True):
            theirs = combined_scores(other, d, args.split, **how)
            s["against"], s["right_against"] = theirs["scores"], theirs["right"]
    out: dict[str, Any] = {
        "model": args.model,
        "split": args.split,
        "noise": args.noise,
        "accuracy_rule": "any_spike" if args.any_spike else "identified",
        "rates": [],
    }
    # Each false-alarm rate's point on the ROC, then (None) the accuracy at the model's threshold.
    for rate in [*FALSE_ALARM_RATES, None]:
        per_set = []
        for d, s in zip(args.datasets, sets, strict=True):
            if rate is None:
                right = np.stack([s["right"]])
                point = _accuracy(right)
                lo, hi = accuracy_interval(
                    right, s["actual"], s["recording"], args.resamples, args.seed
                )
            else:
                point = detection_at_false_alarm(s["scores"], s["actual"], rate)
                lo, hi = roc_point_interval(s["scores"], s["actual"], s["recording"], rate)
            per_set.append({"dataset": d, "point": point, "interval": [lo, hi]})
            if "against" not in s:
                continue
            if rate is None:
                both = np.stack([s["right"], s["right_against"]])
                lead = _accuracy(both)
                d_lo, d_hi = accuracy_interval(
                    both, s["actual"], s["recording"], args.resamples, args.seed
                )
            else:
                lead = point - detection_at_false_alarm(s["against"], s["actual"], rate)
                d_lo, d_hi = roc_point_interval(
                    s["scores"], s["actual"], s["recording"], rate, against=s["against"]
                )
            per_set[-1]["lead"] = {"point": lead, "interval": [d_lo, d_hi]}
        for one in per_set:
            one["holds_others"] = [
                o["dataset"]
                for o in per_set
                if o is not one and one["interval"][0] <= o["point"] <= one["interval"][1]
            ]
        cov = coverage(sets, rate, args.draws, args.resamples, args.seed, args.scale)
        out["rates"].append({"rate": rate, "sets": per_set, "coverage": cov})
    if args.json:
        print(json.dumps(out, indent=1))
        return
    for r in out["rates"]:
        rule = "by the any-spike rule" if args.any_spike else "at the model's threshold"
        what = f"accuracy {rule}" if r["rate"] is None else "detection"
        print(what if r["rate"] is None else f"{what} at {100 * r['rate']:g} % false alarms")
        for one in r["sets"]:
            lo, hi = one["interval"]
            print(
                f"  {one['dataset']}: {100 * one['point']:.1f} % ({100 * lo:.1f}–{100 * hi:.1f}); "
                f"holds {len(one['holds_others'])} of {len(r['sets']) - 1} other sets' points"
            )
            if "lead" in one:
                d_lo, d_hi = one["lead"]["interval"]
                them = args.against or "the static twin"
                print(
                    f"    minus {them}: {100 * one['lead']['point']:+.1f} points "
                    f"({100 * d_lo:+.1f} to {100 * d_hi:+.1f})"
                )
        c = r["coverage"]
        what = "lead" if c["paired"] else "point"
        print(
            f"  pool of {c['pool']['uav_free_units']} UAV-free and {c['pool']['uav_units']} UAV "
            f"units, {what} {100 * c['pool']['point']:.1f} % "
            f"({100 * c['pool']['interval'][0]:.1f}–{100 * c['pool']['interval'][1]:.1f}); "
            f"{c['draws']} sets of "
            f"{c['units_per_set']['uav_free']} + {c['units_per_set']['uav']} units drawn: "
            f"coverage {100 * c['coverage']:.1f} % (nominal 95 %), {what}s "
            f"{100 * c['point_spread']['p2.5']:.1f}–{100 * c['point_spread']['p97.5']:.1f} "
            f"(sd {100 * c['point_spread']['sd']:.1f}), mean width {100 * c['mean_width']:.1f}"
        )


if __name__ == "__main__":
    main()
