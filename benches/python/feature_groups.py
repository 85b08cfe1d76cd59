"""Identification fitted on each feature group, judged on the tuning set and scored on other draws.

``uavsnn evaluate --ablation`` fits the UAV score on each feature group of
``uavsnn.identify.GROUPS`` (rotor, shape, track, all but the track, ...) and scores each on a
test split. This script asks whether the tuning set could have chosen among them: for each
group, a model fitted as ``uavsnn.identify.fit`` fits one (on ``--train``'s train split, tuned on
``--tune``'s), with what the tuning set shows of it (the ROC area of the UAV score over the
tuning objects, which ``fit``'s ``auto`` compares to choose trees or logistic, and on the tuning
windows the balanced accuracy at the tuned threshold and the detection where 1 % and 5 % of
the UAV-free windows alarm), and on each ``--score`` set's test split the same window figures.
A ``--score`` set must be one no fit or tuning has seen (a draw of another seed), not the test
set a reported figure is read on.

    python benches/python/feature_groups.py runs/reproduce/model-combined.npz \\
        --train runs/reproduce/data/dvs --tune runs/reproduce/data/tune-dvs \\
        --score runs/val2-dvs --score runs/val3-dvs
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from typing import Any

import numpy as np

from uavsnn import Network, identify
from uavsnn.dataset import LabelledWindows, load
from uavsnn.evaluation import FALSE_ALARM_RATES, detection_at_false_alarm, roc_area
from uavsnn.identify import GROUPS, Identifier, WindowFeatures
from uavsnn.tracks import Tracker


def window_figures(
    ident: Identifier, feats: WindowFeatures, detected: np.ndarray, label: np.ndarray
) -> dict[str, float]:
    """The combined rule on these windows: balanced accuracy at ``ident``'s threshold, and
    the detection where each of :data:`FALSE_ALARM_RATES` of the UAV-free windows alarm."""
    label = np.asarray(label, dtype=bool)
    score = ident.combined_scores(feats, detected)
    called = score >= ident.threshold
    out = {"balanced_accuracy": float((called[label].mean() + (~called[~label]).mean()) / 2)}
    for rate in FALSE_ALARM_RATES:
        out[f"detection_at_{rate:g}"] = detection_at_false_alarm(score, label, rate)
    return out


def measure(
    network: Network,
    train: LabelledWindows,
    tune: LabelledWindows,
    scored: dict[str, LabelledWindows],
    groups: Sequence[str] = tuple(GROUPS),
) -> dict[str, dict[str, Any]]:
    """For each of ``groups``: the model fitted on ``train``, tuned on ``tune``; what ``tune``
    shows of it (``tune``) and its figures on each of ``scored`` (by name)."""
    tracker = Tracker.for_sensor(int(network.config["width"]))
    tune_inf = network.infer(tune.windows)
    train_f = identify.window_features(network, train, tracker=tracker)
    tune_f = identify.window_features(network, tune, tune_inf, tracker=tracker)
    sets = {}
    for name, data in scored.items():
        inf = network.infer(data.windows)
        sets[name] = (identify.window_features(network, data, inf, tracker=tracker), inf, data)
    out: dict[str, dict[str, Any]] = {}
    for group in groups:
        ident = identify.fit(
            train_f,
            tune_f,
            tune_detected=tune_inf.detected,
            tune_label=np.asarray(tune.label, dtype=bool),
            features=GROUPS[group],
            classes=False,
        )
        objects = tune_f.usable
        row: dict[str, Any] = {
            "features": len(GROUPS[group]),
            "model": identify.model_name(ident),
            "tune": {
                "object_roc_area": roc_area(ident.scores(tune_f.x[objects]), tune_f.label[objects]),
                **window_figures(ident, tune_f, tune_inf.detected, tune.label),
            },
        }
        for name, (feats, inf, data) in sets.items():
            row[name] = window_figures(ident, feats, inf.detected, data.label)
        out[group] = row
    return out


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("model", help="a model file with a network")
    p.add_argument("--train", required=True, help="dataset whose train split it is fitted on")
    p.add_argument("--tune", required=True, help="dataset whose train split tunes it")
    p.add_argument(
        "--score", action="append", default=[], help="a dataset whose test split scores it"
    )
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = p.parse_args(argv)
    network = Network.load(args.model)
    scored = {s: load(s, "test") for s in args.score}
    rows = measure(network, load(args.train, "train"), load(args.tune, "train"), scored)
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    for group, row in rows.items():
        t = row["tune"]
        cells = [
            f"{group:20s} tune: area {t['object_roc_area'] or float('nan'):.3f}, balanced "
            f"{100 * t['balanced_accuracy']:.1f} %, at 1/5 % {100 * t['detection_at_0.01']:.1f}"
            f"/{100 * t['detection_at_0.05']:.1f} %"
        ]
        for name in scored:
            r = row[name]
            cells.append(
                f"{name}: {100 * r['balanced_accuracy']:.1f} %, {100 * r['detection_at_0.01']:.1f}"
                f"/{100 * r['detection_at_0.05']:.1f} %"
            )
        print(" | ".join(cells))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
