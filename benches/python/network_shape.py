"""Do the network's own spikes describe an object's shape well enough to help identification?

For each object of each window (as ``uavsnn.identify.window_features`` finds them), counts the
conv3 spikes of each conv3 map whose causal box lies inside the object's box, and the conv2
spikes of each conv2 map whose position (the centre of its pool1 cell, in sensor pixels) lies
inside it. Then fits the UAV score as ``uavsnn train`` does (on the train split less a quarter
of its recordings, L2 and threshold tuned on that quarter) with the identification's features
alone and with each set of spike columns added, and scores each on the test split: accuracy of
the combined rule at the tuned threshold, detection where 1 % and 5 % of the UAV-free test
windows alarm, and the object-level ROC area on the test objects.

    python benches/python/network_shape.py MODEL.npz DATASET [--json]
"""

from __future__ import annotations

import os

for _var in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
from dataclasses import dataclass  # noqa: E402

import numpy as np  # noqa: E402
from track_window_score import window_scores  # noqa: E402

from uavsnn import Network, identify  # noqa: E402
from uavsnn.dataset import LabelledWindows, load  # noqa: E402
from uavsnn.evaluation import (  # noqa: E402
    FALSE_ALARM_RATES,
    detection_at_false_alarm,
    roc_area,
)


@dataclass(frozen=True)
class Objects:
    """The objects of one split: their features, per-map spike counts, and the split's calls."""

    feats: identify.WindowFeatures
    conv3: np.ndarray
    conv2: np.ndarray
    detected: np.ndarray
    label: np.ndarray


def _per_window(spikes: np.ndarray, windows: int) -> tuple[np.ndarray, np.ndarray]:
    spikes = spikes[np.argsort(spikes["window"], kind="stable")]
    return spikes, np.searchsorted(spikes["window"], np.arange(windows + 1))


#: Windows whose spikes of every layer are recorded at once (conv1's are many at 640x480).
CHUNK = 256


def conv2_spikes(net: Network, data: LabelledWindows) -> np.ndarray:
    """Every conv2 spike of ``data``'s windows (``window``: the index in ``data``)."""
    parts = []
    for chunk in np.array_split(np.arange(len(data)), max(1, -(-len(data) // CHUNK))):
        spikes = net.infer(data.select(chunk).windows, spikes=True).spikes
        assert spikes is not None
        c2 = spikes["conv2"].copy()
        c2["window"] = chunk[c2["window"]]
        parts.append(c2)
    return np.concatenate(parts)


def objects(net: Network, data: LabelledWindows) -> Objects:
    inference = net.infer(data.windows)
    feats = identify.window_features(net, data, inference)
    n3, n2 = int(net.config["conv3"]["maps"]), int(net.config["conv2"]["maps"])
    stride = int(net.config["pool1"]["stride"])
    det, det_at = _per_window(inference.detections, len(data))
    c2, c2_at = _per_window(conv2_spikes(net, data), len(data))
    conv3, conv2 = np.zeros((len(feats.x), n3)), np.zeros((len(feats.x), n2))
    for row, (i, (x0, y0, x1, y1)) in enumerate(zip(feats.window, feats.boxes, strict=True)):
        d = det[det_at[i] : det_at[i + 1]]
        inside = (d["x0"] >= x0) & (d["y0"] >= y0) & (d["x1"] <= x1) & (d["y1"] <= y1)
        conv3[row] = np.bincount(d["map"][inside], minlength=n3)
        s = c2[c2_at[i] : c2_at[i + 1]]
        cx, cy = (s["col"] + 0.5) * stride, (s["row"] + 0.5) * stride
        inside = (cx >= x0) & (cx < x1) & (cy >= y0) & (cy < y1)
        conv2[row] = np.bincount(s["map"][inside], minlength=n2)
    return Objects(feats, conv3, conv2, inference.detected, np.asarray(data.label, dtype=bool))


def _shares(counts: np.ndarray) -> np.ndarray:
    total = counts.sum(axis=1, keepdims=True)
    return counts / np.maximum(total, 1)


#: The spike columns added to the identification's features, by name.
VARIANTS = {
    "features alone": lambda o: np.zeros((len(o.feats.x), 0)),
    "+ conv3 map shares": lambda o: _shares(o.conv3),
    "+ conv2 map shares": lambda o: _shares(o.conv2),
    "+ conv3 and conv2 map shares": lambda o: np.hstack([_shares(o.conv3), _shares(o.conv2)]),
    "+ conv2 counts per map (log)": lambda o: np.log1p(o.conv2),
    "+ conv2 spikes in the box (log)": lambda o: np.log1p(o.conv2.sum(axis=1, keepdims=True)),
}


def score_variant(extra, train, tune, test, base=None) -> dict[str, float]:
    """The figures of a score fitted on ``base(o)`` (default: every feature, ``o.feats.x``)
    with ``extra(o)``'s columns added; ``train``, ``tune`` and ``test`` are :class:`Objects`
    or any object with ``feats``, ``detected`` and ``label``."""

    def columns(o) -> np.ndarray:
        return np.hstack([o.feats.x if base is None else base(o), extra(o)])

    xs = {name: columns(o) for name, o in (("train", train), ("tune", tune), ("test", test))}
    tr, tu, te = train.feats, tune.feats, test.feats
    mean, scale, coef, l2 = identify.fit_score(
        xs["train"][tr.usable], tr.label[tr.usable], xs["tune"][tu.usable], tu.label[tu.usable]
    )

    def window_score(o, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        objects = identify.predict_logistic(coef, (x - mean) / scale)
        return window_scores(o.feats, objects, o.detected), objects

    threshold = identify.best_threshold(window_score(tune, xs["tune"])[0], tune.label)
    score, objects = window_score(test, xs["test"])
    row = {
        "columns": xs["test"].shape[1],
        "l2": l2,
        "threshold": threshold,
        "accuracy": float(np.mean((score >= threshold) == test.label)),
    }
    for rate in FALSE_ALARM_RATES:
        row[f"detection_at_{rate:g}"] = detection_at_false_alarm(score, test.label, rate)
    row["object_auc"] = roc_area(objects[te.usable], te.label[te.usable])
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("dataset")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    net = Network.load(args.model)
    train, tune = identify.split_by_recording(load(args.dataset, "train"))
    parts = {name: objects(net, d) for name, d in (("train", train), ("tune", tune))}
    parts["test"] = objects(net, load(args.dataset, "test"))
    rows = {name: score_variant(extra, *parts.values()) for name, extra in VARIANTS.items()}
    if args.json:
        print(json.dumps({"objects": {k: len(v.feats.x) for k, v in parts.items()}, **rows}))
        return
    print(", ".join(f"{k}: {len(v.feats.x)} objects" for k, v in parts.items()))
    print("| columns | | L2 | accuracy | detection at 1 % / 5 % false alarms | object ROC area |")
    print("|---|---|---|---|---|---|")
    for name, r in rows.items():
        print(
            f"| {name} | {r['columns']} | {r['l2']:g} | {100 * r['accuracy']:.1f} % | "
            f"{100 * r['detection_at_0.01']:.1f} / {100 * r['detection_at_0.05']:.1f} % | "
            f"{r['object_auc']:.3f} |"
        )


if __name__ == "__main__":
    main()
