"""Does identification learn the rare classes from more training recordings, and does a false-alarm
share set on one draw of recordings hold on another?

Fits a network's identification as ``uavsnn train --tune`` does (``identify.fit_network``: L2,
threshold and the operating points set beforehand on the tuning windows), with each ``--model``
(``identify.MODELS``; default ``auto``) and each ``--group`` of features (``identify.GROUPS``;
default ``all``), once on each list of
``--fit`` datasets (their train splits, mixed whole), tuned on the ``--tune`` dataset's train
split, and scores each fit on every ``--score`` dataset's train split (recordings of other
seeds, that no fit or tuning saw). For each it prints the any-spike rule's accuracy and the
combined rule's, the detection where 1 % and 5 % of the scored set's UAV-free windows alarm
(read off its ROC), and at the thresholds set beforehand for 1 % and 5 %: the false-alarm share
on the scored set (with its 95 % interval over the set's recordings), the detection, and the
false alarms per class of other object.

    python benches/python/identify_draws.py MODEL.npz --tune runs/tune1 \\
        --fit runs/reproduce/data/dvs --fit runs/reproduce/data/dvs,runs/tune2 \\
        --score runs/tune3 [--json]

A ``--fit`` or ``--tune`` value is one dataset or several joined by commas (their windows
concatenated, each recording kept apart). Choose on the ``--score`` sets, never on a test
split.
"""

from __future__ import annotations

import os

for _var in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import itertools  # noqa: E402
import json  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from uavsnn import Network, identify  # noqa: E402
from uavsnn.dataset import LabelledWindows, load  # noqa: E402
from uavsnn.evaluation import detection_by_target  # noqa: E402
from uavsnn.experiments import both_rules, mix_windows  # noqa: E402
from uavsnn.report import interval_text  # noqa: E402


def joined(spec: str) -> LabelledWindows:
    """The train splits of the comma-separated datasets of ``spec``, concatenated whole."""
    parts = [load(d, "train") for d in spec.split(",") if d]
    if len(parts) == 1:
        return parts[0]
    if len({len(p) for p in parts}) != 1:
        raise SystemExit(f"--fit {spec}: the joined train splits must be of one size")
    return mix_windows(parts, None, seed=0)


def scored(net: Network, ident: identify.Identifier, data: LabelledWindows) -> dict[str, Any]:
    """Both rules on ``data`` with ``ident`` (:func:`identification_figures`), trimmed to what
    this script prints."""
    inference = net.infer(data.windows, threads=1)
    scoring = net.copy()
    scoring.identification = ident
    f = both_rules(scoring, data, inference)
    assert f is not None
    uav_free = ~np.asarray(data.label, bool)
    return {
        "any_spike": f["any_spike"]["accuracy"],
        "identified": f["identified"]["accuracy"],
        "roc": detection_by_target(f["at_false_alarm"]),
        "set_beforehand": [
            {
                "target": p["false_alarm_target"],
                "false_alarms": p["false_alarm_rate"],
                "false_alarm_interval": p["false_alarm_interval"],
                "detection": p["detection_rate"],
                "per_class": p["false_alarms_per_class"],
            }
            for p in f["at_tuned_false_alarm"]
        ],
        "uav_free_recordings": len(np.unique(np.asarray(data.recording)[uav_free])),
        "uav_free_windows": {
            str(c): int(np.sum(uav_free & (data.cls == c))) for c in np.unique(data.cls[uav_free])
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("--fit", action="append", required=True, metavar="DIR[,DIR...]")
    parser.add_argument("--tune", required=True, metavar="DIR[,DIR...]")
    parser.add_argument("--score", action="append", required=True, metavar="DIR")
    parser.add_argument(
        "--model",
        dest="models",
        action="append",
        choices=identify.MODELS,
        help="the UAV score's model (identify.fit's; repeat to compare; default auto)",
    )
    parser.add_argument(
        "--group",
        dest="groups",
        action="append",
        choices=list(identify.GROUPS),
        help="the features fitted, a group of identify.GROUPS (repeat to compare; default all)",
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    net = Network.load(args.model)
    tune = joined(args.tune)
    tune_inference = net.infer(tune.windows, threads=1)
    tune_feats = identify.window_features(net, tune, tune_inference)
    scores = {d: load(d, "train") for d in args.score}
    out: dict[str, Any] = {}
    for spec in args.fit:
        train = joined(spec)
        train_feats = identify.window_features(net, train)
        for kind, group in itertools.product(args.models or ["auto"], args.groups or ["all"]):
            # as identify.fit_network fits, with the features computed once for every model
            ident = identify.fit(
                train_feats,
                tune_feats,
                tune_detected=tune_inference.detected,
                tune_label=np.asarray(tune.label, dtype=bool),
                features=identify.GROUPS[group],
                model=kind,
            )
            out[f"{spec} [{kind}]" + ("" if group == "all" else f" [{group}]")] = {
                "train_windows": len(train),
                "features": list(ident.features),
                "model": identify.model_name(ident),
                "l2": ident.l2,
                "threshold": ident.threshold,
                "alarm_thresholds": [list(pair) for pair in ident.alarm_thresholds],
                "scored": {d: scored(net, ident, data) for d, data in scores.items()},
            }
    if args.json:
        print(json.dumps(out, indent=2))
        return
    for spec, fit in out.items():
        print(
            f"fitted on {spec} ({fit['train_windows']} windows; {fit['model']}): L2 "
            f"{fit['l2']:g}, threshold "
            f"{fit['threshold']:.3f}, set beforehand "
            + ", ".join(f"{100 * r:g} % at {t:.3f}" for r, t in fit["alarm_thresholds"])
        )
        for d, s in fit["scored"].items():
            print(
                f"  on {d}: accuracy {100 * s['any_spike']:.1f} -> {100 * s['identified']:.1f} %, "
                f"ROC-read detection {100 * s['roc'][0.01]:.1f} / {100 * s['roc'][0.05]:.1f} %"
            )
            for p in s["set_beforehand"]:
                classes = ", ".join(
                    f"{c} {100 * v:.1f} % of {s['uav_free_windows'][c]}"
                    for c, v in p["per_class"].items()
                    if v > 0
                )
                # No interval from fewer than MIN_INTERVAL_RECORDINGS UAV-free recordings.
                drawn = interval_text(p["false_alarm_interval"])
                print(
                    f"    set for {100 * p['target']:g} %: false alarms "
                    f"{100 * p['false_alarms']:.1f} % ({drawn}; "
                    f"{s['uav_free_recordings']} UAV-free recordings), detection "
                    f"{100 * p['detection']:.1f} % ({classes})"
                )


if __name__ == "__main__":
    main()
