"""How each UAV score model ranks the UAVs above each class of other object, on tuning objects.

For a network (``model``), its identification is fitted on ``--fit`` (a train split) with each
score model (``identify.fit``'s ``logistic`` and ``trees``), and the ROC area of UAV objects
against the objects of each other class is printed, on ``--tune``'s usable objects (the set a
model choice may look at; never a test split), beside the area over all of them, which is what
``auto`` compares. A class whose area is low is one the score calls UAV. With ``--score``, the
same models' areas on another set (another seed's train split) too: whether a class's ranking
carries from one draw of recordings to the next. With ``--feature-areas CLASS``, instead, each
feature's own ROC area of UAVs against that class's objects, on every set named (the training
split too): which cues separate the class, and whether the training split teaches them.

    python benches/python/class_ranking.py runs/dvs640/model.npz --fit runs/dvs640 \\
        --tune runs/tune640st --score runs/tune640s2
"""

from __future__ import annotations

import argparse

import numpy as np

from uavsnn import Network, identify
from uavsnn.dataset import load
from uavsnn.evaluation import roc_area


def class_areas(
    score: np.ndarray, label: np.ndarray, cls: np.ndarray, usable: np.ndarray
) -> dict[str, float | None]:
    """ROC area of the usable UAV objects (``label``) against the usable objects of each other
    class of ``cls`` (unnamed objects, ``""``, left out); ``None`` where either side is empty."""
    score, label, usable = np.asarray(score), np.asarray(label, bool), np.asarray(usable, bool)
    cls = np.asarray(cls)
    out: dict[str, float | None] = {}
    for c in sorted(set(cls[usable & ~label].tolist()) - {""}):
        pick = usable & (label | (cls == c))
        out[str(c)] = roc_area(score[pick], label[pick])
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("--fit", required=True, metavar="DIR")
    parser.add_argument("--tune", required=True, metavar="DIR")
    parser.add_argument("--score", action="append", default=[], metavar="DIR")
    parser.add_argument("--feature-areas", metavar="CLASS")
    args = parser.parse_args()
    net = Network.load(args.model)
    train = identify.window_features(net, load(args.fit, "train"))
    sets = {path: identify.window_features(net, load(path, "train")) for path in args.score}
    tune = identify.window_features(net, load(args.tune, "train"))
    if args.feature_areas is not None:
        every = {args.fit: train, args.tune: tune, **sets}
        print(f"ROC area of UAV objects against {args.feature_areas} objects, by feature")
        print("objects: " + ", ".join(
            f"{path} {int((f.usable & (f.cls == args.feature_areas)).sum())}"
            for path, f in every.items()
        ))  # fmt: skip
        for j, name in enumerate(identify.FEATURES):
            cells = []
            for feats in every.values():
                area = class_areas(feats.x[:, j], feats.label, feats.cls, feats.usable).get(
                    args.feature_areas
                )
                cells.append("-" if area is None else f"{area:.3f}")
            print(f"  {name:22s} " + " ".join(f"{c:>7}" for c in cells))
        return
    for model in ("logistic", "trees"):
        ident = identify.fit(train, tune, model=model, classes=False)
        print(identify.model_name(ident))
        for path, feats in {args.tune: tune, **sets}.items():
            score = ident.scores(feats.x)
            every = roc_area(score[feats.usable], feats.label[feats.usable])
            areas = class_areas(score, feats.label, feats.cls, feats.usable)
            cells = ", ".join(f"{c} {a:.3f}" for c, a in areas.items() if a is not None)
            print(f"  {path}: all {every:.3f}; {cells}")


if __name__ == "__main__":
    main()
