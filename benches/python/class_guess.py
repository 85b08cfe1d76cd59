"""How the class guess fares: fit a network's identification (UAV score and class part) as
``uavsnn train`` does — on the dataset's train split, tuned on a quarter of its recordings held
out — and score the class guess on the test objects of a known class.

Prints, per true class, its test objects, the share guessed right and the confusion row; the
accuracy and the balanced accuracy over the model's classes; and, for comparison, detection at
1 % and 5 % false alarms with the binary UAV score (what uavsnn uses) and with the class part's
probability of ``uav`` as the window score.

    python benches/python/class_guess.py MODEL.npz DATASET [--json]
"""

from __future__ import annotations

import os

for _var in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from uavsnn import Network, identify, report  # noqa: E402
from uavsnn.dataset import load  # noqa: E402
from uavsnn.evaluation import FALSE_ALARM_RATES, detection_at_false_alarm  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from track_window_score import window_scores  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("dataset")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    net = Network.load(args.model)
    ident, _ = identify.fit_network(net, load(args.dataset, "train"))
    test = load(args.dataset, "test")
    inference = net.infer(test.windows)
    feats = identify.window_features(net, test, inference)
    figures = identify.class_figures(ident, feats)
    label = np.asarray(test.label, dtype=bool)
    detection = {}
    uav = ident.classes.index(identify.UAV_CLASS) if identify.UAV_CLASS in ident.classes else None
    scores = {"binary": ident.scores(feats.x)}
    if uav is not None:
        scores["class_part"] = ident.class_probabilities(feats.x)[:, uav]
    for name, s in scores.items():
        w = window_scores(feats, s, inference.detected)
        detection[name] = {
            f"{r:g}": detection_at_false_alarm(w, label, r) for r in FALSE_ALARM_RATES
        }
    out = {"classes": list(ident.classes), "figures": figures, "detection": detection}
    if args.json:
        print(json.dumps(out, indent=1))
        return
    print(
        f"{args.model}: {figures['objects']} test objects of a known class, "
        f"{100 * figures['accuracy']:.1f} % right, balanced "
        f"{report.percent(figures['balanced_accuracy'])} over {len(ident.classes)} classes"
    )
    for cls, row in figures["per_class"].items():
        print(
            f"  {cls:10s} {row['objects']:5d} {100 * row['recall']:5.1f} %  "
            f"{figures['confusion'][cls]}"
        )
    for name, d in detection.items():
        rates = " / ".join(f"{100 * v:.1f}" for v in d.values())
        print(f"  window score {name}: detection {rates} % at {'/'.join(d)} false alarms")


if __name__ == "__main__":
    main()
