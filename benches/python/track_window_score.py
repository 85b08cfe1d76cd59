"""A window's UAV score from its objects' tracks: the object's own score against its track's.

With identification a window is called UAV when its best object's UAV score reaches the
threshold (``Identifier.window_scores``). The tracker alarms on a track's running mean of its
objects' scores instead (``WindowObject.track_score``). This bench scores each window by the
best of its objects' *track* statistics, causal (each object reads its track's scores up to its
own window), and measures what that does to detection at fixed false-alarm rates:

- ``own``: the object's own score (identification's rule, the reference);
- ``mean``: the running mean of its track's scores so far (the tracker's ``track_score``);
- ``last3``, ``last5``: the mean of its track's last 3 or 5 scores;
- ``logit``: the mean of their log-odds, mapped back to [0, 1].

An object without a track keeps its own score. A window the any-spike rule does not call UAV
never alarms. The objects and their tracks are those of ``uavsnn evaluate`` (each recording's
windows followed in time order, ``identify.window_features``). For each rule, on the train
split of the ``--tune`` set (recordings of another seed: where a rule would be chosen; several
sets are mixed as `reproduce` mixes the combined network's tuning windows) and on
DATASET's ``--split``:

- detection where 1 % and 5 % of the UAV-free windows alarm, read off that set's own ROC, how
  many UAV-free recordings the windows alarming there come from, and the ROC's area;
- on the measured split, the false alarms and detection at the operating points set on the
  tuning windows by ``identify.alarm_threshold`` (as ``Identifier.alarm_thresholds`` are).

Run from the repository root::

    python benches/python/track_window_score.py MODEL DATASET --tune DIR [--tune DIR]
        [--split test] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from typing import Any

import numpy as np
from track_evidence import EPS  # scores clipped to [EPS, 1 − EPS] before their log-odds
from tune_halves import load_identified

from uavsnn import identify
from uavsnn.dataset import LabelledWindows, load
from uavsnn.evaluation import FALSE_ALARM_RATES, roc_area, threshold_at_false_alarm
from uavsnn.experiments import mix_windows
from uavsnn.features import WindowFeatures
from uavsnn.identifier import Identifier
from uavsnn.network import Network

RULES = ("own", "mean", "last3", "last5", "logit")


def track_scores(
    feats: WindowFeatures, recording: np.ndarray, t0: np.ndarray, scores: np.ndarray, rule: str
) -> np.ndarray:
    """Each object's score under ``rule`` (one of :data:`RULES`): its track's statistic over
    the track's objects up to and including it, in time order. ``recording`` and ``t0`` are
    per window of the dataset; objects without a track (id 0) keep their own score."""
    if rule not in RULES:
        raise ValueError(f"rule must be one of {RULES}, got {rule!r}")
    s = np.asarray(scores, dtype=np.float64)
    out = s.copy()
    if rule == "own" or len(s) == 0:
        return out
    rec = np.asarray(recording)[feats.window]
    start = np.asarray(t0, dtype=np.int64)[feats.window]
    tracked = np.flatnonzero(feats.track != 0)
    # Each track's objects together, in time order (a track has one object per window).
    order = tracked[np.lexsort((start[tracked], feats.track[tracked], rec[tracked]))]
    key = np.stack([rec[order], feats.track[order]], axis=1)
    first = np.r_[True, np.any(key[1:] != key[:-1], axis=1)]
    # Each object's place in the order, and where its track's run of objects starts.
    at = np.arange(len(order))
    head = np.flatnonzero(first)[np.cumsum(first) - 1]
    pos = at - head
    value = s[order]
    if rule == "logit":
        p = np.clip(value, EPS, 1 - EPS)
        value = np.log(p / (1 - p))
    total = np.cumsum(value)
    before = np.r_[0.0, total][head]
    if rule in ("mean", "logit"):
        stat = (total - before) / (pos + 1)
    else:
        k = int(rule[4:])
        back = np.maximum(at - k, head - 1)
        lagged = np.where(back >= 0, total[np.maximum(back, 0)], 0.0)
        stat = (total - lagged) / np.minimum(pos + 1, k)
    if rule == "logit":
        stat = 1 / (1 + np.exp(-stat))
    out[order] = stat
    return out


def window_scores(feats: WindowFeatures, objects: np.ndarray, fired: np.ndarray) -> np.ndarray:
    """Per window, its objects' best score; -1 (never an alarm) where the any-spike rule does
    not fire, 0 for a detected window without a scored object."""
    out = np.zeros(feats.windows)
    if len(objects):
        np.maximum.at(out, feats.window, objects)
    return np.where(np.asarray(fired, dtype=bool), out, -1.0)


def split_scores(
    net: Network, ident: Identifier, data: LabelledWindows
) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per rule, the window scores of ``data`` through ``net`` and its identification
    ``ident``, its labels and its windows' recordings."""
    inference = net.infer(data.windows)
    feats = identify.window_features(net, data, inference)
    own = ident.scores(feats.x)
    label = np.asarray(data.label, dtype=bool)
    fired = np.asarray(inference.detected, dtype=bool)
    out = {}
    for rule in RULES:
        objects = track_scores(feats, data.recording, data.windows.t0, own, rule)
        out[rule] = (window_scores(feats, objects, fired), label, np.asarray(data.recording))
    return out


def roc_points(score: np.ndarray, label: np.ndarray, recording: np.ndarray) -> dict[str, Any]:
    """Detection at each of ``FALSE_ALARM_RATES`` read off the set's own ROC, how many
    UAV-free recordings hold the windows that alarm there, and the ROC's area."""
    at = {r: threshold_at_false_alarm(score, label, r) for r in FALSE_ALARM_RATES}
    return {
        "detection": {str(r): float(np.mean(score[label] >= t)) for r, t in at.items()},
        "false_recordings": {
            str(r): len(np.unique(recording[~label & (score >= t)])) for r, t in at.items()
        },
        "roc_area": roc_area(score, label),
    }


def tuning_windows(tune: Sequence[str], seed: int = 1) -> LabelledWindows:
    """The train split of the one ``tune`` set, or of several mixed as `reproduce` mixes the
    combined network's (``experiments.mix_windows``, as many windows as the first holds, drawn
    with the tuning ``seed``)."""
    parts = [load(path, "train") for path in tune]
    if len(parts) == 1:
        return parts[0]
    return mix_windows(parts, len(parts[0]), seed=seed)


def measure(
    model: str, dataset: str, tune: Sequence[str], split: str = "test", tune_seed: int = 1
) -> dict[str, dict[str, Any]]:
    """Every rule's figures on the tuning windows and on ``dataset``'s ``split``."""
    net, ident = load_identified(model)
    tuned = split_scores(net, ident, tuning_windows(tune, tune_seed))
    measured = split_scores(net, ident, load(dataset, split))
    out: dict[str, dict[str, Any]] = {}
    for rule in RULES:
        t_score, t_label, t_recording = tuned[rule]
        score, label, recording = measured[rule]
        points = {}
        for rate in FALSE_ALARM_RATES:
            threshold = identify.alarm_threshold(t_score, t_label, rate)
            alarm = score >= threshold
            points[str(rate)] = {
                "threshold": threshold,
                "false_alarms": float(alarm[~label].mean()),
                "detection": float(alarm[label].mean()),
            }
        out[rule] = {
            "tune": roc_points(t_score, t_label, t_recording),
            "measured": roc_points(score, label, recording),
            "set_beforehand": points,
        }
    return out


def table(figures: dict[str, dict[str, Any]]) -> str:
    pct = [f"{r:.0%}" for r in FALSE_ALARM_RATES]
    lines = [
        "| rule | tuning sets: detection at "
        + " / ".join(pct)
        + " false alarms (ROC area; UAV-free recordings alarming) | measured: detection at "
        + " / ".join(pct)
        + " (ROC area; recordings) | "
        + " | ".join(f"set beforehand for {p}: false alarms / detection" for p in pct)
        + " |",
        "|---" * (3 + len(pct)) + "|",
    ]
    for rule, f in figures.items():

        def roc(part: dict[str, Any]) -> str:
            d = " / ".join(f"{100 * v:.1f}" for v in part["detection"].values())
            n = " / ".join(str(v) for v in part["false_recordings"].values())
            return f"{d} % ({part['roc_area']:.3f}; {n})"

        points = [
            f"{100 * p['false_alarms']:.1f} / {100 * p['detection']:.1f} %"
            for p in f["set_beforehand"].values()
        ]
        lines.append(
            f"| {rule} | {roc(f['tune'])} | {roc(f['measured'])} | " + " | ".join(points) + " |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("dataset")
    parser.add_argument("--tune", action="append", required=True, metavar="DIR")
    parser.add_argument("--split", default="test")
    parser.add_argument("--tune-seed", type=int, default=1, help="the draw of mixed --tune sets")
    parser.add_argument("--json", metavar="OUT", help="also write the figures as JSON")
    args = parser.parse_args()
    figures = measure(args.model, args.dataset, args.tune, args.split, args.tune_seed)
    print(table(figures))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(figures, f, indent=1)


if __name__ == "__main__":
    main()
