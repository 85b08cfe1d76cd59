"""Which threshold of a flat best: the rule of ``identify.best_threshold``, on other draws.

The balanced accuracy of the combined rule on the tuning windows is flat near its best; a
threshold rule picks one point of that ridge. For a model and its tuning set (``--tune``: the
train split ``uavsnn reproduce`` tunes on, e.g. ``data/tune-dvs``), this sets the threshold by
each rule — the smallest of the best (the rule before), and the highest within ``--within`` of
the best (``best_threshold``'s, ``THRESHOLD_WITHIN`` by default) for each value given — and
reads each on the test splits of datasets built with other seeds (``VALIDATION``, pooled; never
the seed of a reported test set): accuracy, the shares of UAV and UAV-free windows called UAV,
per class, and each one's difference from the smallest of the best with its paired 95 %
interval over the validation recordings (``evaluation.recording_interval``). ``--class-share S``
adds the rule of SPEC's per-class target: the lowest threshold at which no class of other
object on the tuning windows is called UAV more than ``S`` of the time. Then how far each
``--within`` rule's threshold moves when the tuning recordings are drawn again (``--draws``;
the UAV and the UAV-free ones apart).

    python benches/python/threshold_rule.py runs/reproduce/model-combined.npz \\
        --tune runs/reproduce/data/tune-dvs runs/val2-dvs runs/val3-dvs

The real clips have no second draw, and their network is tuned on a quarter of its training
recordings held out (``--held-out``); read on the real test split, this measures what the rule,
chosen on the synthetic seeds, costs or gains there, and chooses nothing:

    python benches/python/threshold_rule.py runs/reproduce/model-real.npz --within 0.01 \\
        --tune runs/reproduce/data/real --held-out runs/reproduce/data/real
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from uavsnn import identify
from uavsnn.dataset import load
from uavsnn.evaluation import recording_interval

sys.path.insert(0, str(Path(__file__).resolve().parent))
from tune_halves import balanced, load_identified, tuning_scores

#: The rule before ``best_threshold`` took the highest within a point.
SMALLEST = "smallest of the best"


def rule_thresholds(
    score: np.ndarray, label: np.ndarray, withins: Sequence[float]
) -> dict[str, float]:
    """Each rule's threshold on tuning scores: the smallest of the best, then the highest
    within each of ``withins`` of the best (named ``within W``)."""
    candidates, acc = identify.threshold_accuracies(score, label)
    rules = {SMALLEST: float(candidates[int(np.argmax(acc))])}
    for w in withins:
        rules[f"within {w:g}"] = identify.best_threshold(score, label, w)
    return rules


def highest_class_share(
    score: np.ndarray, label: np.ndarray, cls: np.ndarray, threshold: float
) -> float:
    """The largest share of its windows that any class of the UAV-free windows (``cls`` of the
    windows ``label`` calls UAV-free; ``none`` for empty scenes) has scoring at or above
    ``threshold``."""
    free = ~np.asarray(label, bool)
    return max((score[free & (cls == c)] >= threshold).mean() for c in np.unique(cls[free]))


def class_share_threshold(
    score: np.ndarray, label: np.ndarray, cls: np.ndarray, share: float
) -> float:
    """The smallest of ``identify.threshold_accuracies``' candidates at which no class of the
    UAV-free windows has more than ``share`` of its windows scoring at or above it
    (:func:`highest_class_share`): SPEC's per-class target (5 %) as a rule set on the tuning
    windows. Above every score when none is low enough."""
    candidates, _ = identify.threshold_accuracies(score, label)
    for t in candidates:
        if highest_class_share(score, label, cls, t) <= share:
            return float(t)
    return float(np.nextafter(score.max(), np.inf))


def redrawn_thresholds(
    score: np.ndarray,
    label: np.ndarray,
    recording: np.ndarray,
    withins: Sequence[float],
    draws: int,
    seed: int = 0,
) -> dict[str, np.ndarray]:
    """Each rule's threshold on ``draws`` redraws of the tuning recordings: whole recordings
    with replacement, those of the UAV windows and those of the UAV-free ones apart (each as
    many as there are), so every draw holds both kinds."""
    label = np.asarray(label, bool)
    members = []
    for kind in (True, False):
        rows = np.flatnonzero(label == kind)
        names, which = np.unique(np.asarray(recording)[rows], return_inverse=True)
        members.append([rows[which == k] for k in range(len(names))])
    rng = np.random.default_rng(seed)
    out: dict[str, list[float]] = {}
    for _ in range(draws):
        pick = np.concatenate(
            [group[k] for group in members for k in rng.integers(0, len(group), len(group))]
        )
        for rule, t in rule_thresholds(score[pick], label[pick], withins).items():
            out.setdefault(rule, []).append(t)
    return {rule: np.array(ts) for rule, ts in out.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("validation", nargs="+", metavar="VALIDATION")
    parser.add_argument("--tune", required=True, metavar="DIR")
    parser.add_argument(
        "--within",
        type=float,
        action="append",
        metavar="W",
        help=f"of the best (default: identify.THRESHOLD_WITHIN, {identify.THRESHOLD_WITHIN:g})",
    )
    parser.add_argument("--draws", type=int, default=200, help="redraws of the tuning set (200)")
    parser.add_argument(
        "--class-share",
        type=float,
        action="append",
        default=[],
        metavar="S",
        help="also the rule that no class of other object on the tuning set exceeds S",
    )
    parser.add_argument(
        "--held-out",
        action="store_true",
        help="tune on the quarter of --tune's training recordings that 'uavsnn train' holds "
        "out when given no tuning set (the real network of 'reproduce')",
    )
    args = parser.parse_args()
    withins = args.within or [identify.THRESHOLD_WITHIN]
    if any(not 0 <= w < 1 for w in withins):
        raise SystemExit(f"--within must be in [0, 1), got {withins}")
    if any(not 0 <= c < 1 for c in args.class_share):
        raise SystemExit(f"--class-share must be in [0, 1), got {args.class_share}")
    if not 1 <= args.draws <= 10_000:
        raise SystemExit(f"--draws must be in 1..10000, got {args.draws}")
    net, ident = load_identified(args.model)
    _, score, label, recording, tune_cls = tuning_scores(net, args.tune, held_out=args.held_out)
    rules = rule_thresholds(score, label, withins)
    for share in args.class_share:
        rules[f"classes within {share:g}"] = class_share_threshold(score, label, tune_cls, share)
    tuned_on = f"{args.tune} (its held-out training recordings)" if args.held_out else args.tune
    print(f"{args.model}: model threshold {ident.threshold:.3f}; tuned on {tuned_on}")

    parts: list[tuple[np.ndarray, ...]] = []
    for k, path in enumerate(args.validation):
        data = load(path, "test")
        print(f"  validation {path}: seed {data.manifest.get('seed')}, {len(data)} windows")
        fired = np.asarray(net.infer(data.windows).detected, bool)
        feats = identify.window_features(net, data)
        s = np.where(fired, ident.window_scores(feats), -1.0)
        rec = np.char.add(f"{k}:", np.asarray(data.recording).astype(str))
        parts.append((s, np.asarray(data.label, bool), np.asarray(data.cls).astype(str), rec))
    s, lab, cls, rec = (np.concatenate(p) for p in zip(*parts, strict=True))
    classes = [c for c in np.unique(cls) if c]
    base = s >= rules[SMALLEST]
    for rule, t in rules.items():
        call = s >= t
        worst = highest_class_share(score, label, tune_cls, t)
        print(
            f"  {rule:21s} threshold {t:.3f} (tuning balanced {balanced(score >= t, label):.3f},"
            f" highest class {worst:.3f}): accuracy {(call == lab).mean():.3f}, UAV windows "
            f"called {call[lab].mean():.3f}, UAV-free {call[~lab].mean():.3f}"
        )
        print("    called UAV: " + ", ".join(f"{c} {call[cls == c].mean():.3f}" for c in classes))
        if rule == SMALLEST:
            continue
        # accuracy on the set balanced by design: its UAV and UAV-free recordings drawn apart
        for name, mine, theirs, rows, strata in (
            ("accuracy", call == lab, base == lab, np.ones_like(lab), lab),
            ("UAV called", call, base, lab, None),
            ("UAV-free called", call, base, ~lab, None),
        ):
            lo, hi = recording_interval(
                mine[rows],
                rec[rows],
                against=theirs[rows],
                strata=None if strata is None else strata[rows],
            )
            lead = mine[rows].mean() - theirs[rows].mean()
            print(
                f"    {name} against the smallest: {100 * lead:+.2f} ({100 * lo:+.2f} to "
                f"{100 * hi:+.2f}) points"
            )
    print(f"  the threshold over {args.draws} redraws of the tuning recordings:")
    for rule, ts in redrawn_thresholds(score, label, recording, withins, args.draws).items():
        p5, p50, p95 = np.percentile(ts, [5, 50, 95])
        print(f"    {rule:21s} median {p50:.3f}, 5-95 % {p5:.3f}-{p95:.3f}, sd {ts.std():.3f}")


if __name__ == "__main__":
    main()
