"""What does the swing of an object's event rate add to identification, and over which span?

``log_rate_swing`` (``uavsnn.features.rate_swing``) is how strongly an object's event rate
rises and falls within its window, beyond shot noise: its events in the network's box, in
bins of 5 ms over the window ``[t0, t0 + L)``. This script fits the UAV score as
``uavsnn train`` does (the train split less a quarter of its recordings; L2 and threshold
tuned on that quarter) on the identification's features without it and with it, and with
each of three longer spans added instead, all causal and from the network's own box:

- ``100 ms``: the same swing over ``[t0 - L, t0 + L)`` (the window and the one before it,
  the raw events a format-2 dataset keeps), 20 bins;
- ``track mean``: the mean window swing of the object's track so far;
- ``track series``: along the track, the counts in 5 ms bins inside the box of the track's
  latest hit covering each bin (each hit fills the bins of its ``[t0 - L, t0 + L)``), over at
  most the last 500 ms, around a 250 ms running mean, in 3–40 Hz (where a bird's wing beat
  lies; ``wingbeat_probe.spectrum``); zero while the series is shorter than 200 ms or has a
  gap.

It prints the swing of the test split's objects by class (median, the share with none, and
the median events in their boxes),
each column's ROC area alone on the three parts (UAV objects against the others;
below 0.5 means UAV objects swing less, so it gives ``1 - area`` of the swing), then, on the
test split, the accuracy of the combined rule at the tuned threshold, detection where 1 % and
5 % of the UAV-free windows alarm, and the object ROC area; and last the same fits' detection
and ROC area on the tuning part, where the spans are compared.

    python benches/python/rate_swing.py MODEL.npz DATASET [--json]
"""

from __future__ import annotations

import os

for _var in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

from network_shape import score_variant  # noqa: E402
from wingbeat_probe import swing  # noqa: E402

from uavsnn import Network, identify  # noqa: E402
from uavsnn.dataset import LabelledWindows, load  # noqa: E402
from uavsnn.evaluation import roc_area  # noqa: E402
from uavsnn.experiments import mix_windows  # noqa: E402
from uavsnn.features import FEATURES, RATE_BIN_US, rate_swing  # noqa: E402

SERIES_US = 500_000
MIN_SERIES_US = 200_000
#: The longer spans measured, in the order of :attr:`Objects.spans`' columns.
SPANS = ("100 ms", "track mean", "track series")


@dataclass(frozen=True)
class Objects:
    feats: identify.WindowFeatures
    spans: np.ndarray
    detected: np.ndarray
    label: np.ndarray


def _counts(events: np.ndarray, box, lo: int, n_bins: int) -> np.ndarray:
    x0, y0, x1, y1 = box
    m = (events["x"] >= x0) & (events["x"] < x1) & (events["y"] >= y0) & (events["y"] < y1)
    b = (events["t"][m].astype(np.int64) - lo) // RATE_BIN_US
    b = b[(b >= 0) & (b < n_bins)]
    return np.bincount(b, minlength=n_bins).astype(np.float64)


def objects(net: Network, data: LabelledWindows) -> Objects:
    inference = net.infer(data.windows)
    feats = identify.window_features(net, data, inference)
    raw = data.raw
    assert raw is not None
    length = int(data.windows.length_us)
    t0s = np.asarray(data.windows.t0, dtype=np.int64)
    rec = np.asarray(data.recording, dtype=np.int64)
    rows = np.lexsort((np.arange(len(feats.window)), t0s[feats.window], rec[feats.window]))
    out = np.zeros((len(feats.window), len(SPANS)))
    history: dict[tuple[int, int], list[float]] = {}
    series: dict[tuple[int, int], dict[int, float]] = {}
    n_bins = (raw.before_us + length) // RATE_BIN_US
    own = raw.before_us // RATE_BIN_US
    for r in rows.tolist():
        i = int(feats.window[r])
        t0 = int(t0s[i])
        lo = t0 - raw.before_us
        counts = _counts(raw.window(i), feats.boxes[r], lo, n_bins)
        out[r, 0] = rate_swing(counts)
        key = (int(rec[i]), int(feats.track[r]))
        if key[1] == 0:
            continue
        past = history.setdefault(key, [])
        past.append(rate_swing(counts[own:]))
        out[r, 1] = float(np.mean(past))
        bins = series.setdefault(key, {})
        first = lo // RATE_BIN_US
        for k, c in enumerate(counts):
            bins[first + k] = c
        end = (t0 + length) // RATE_BIN_US
        keys = range(max(min(bins), end - SERIES_US // RATE_BIN_US), end)
        if len(keys) * RATE_BIN_US >= MIN_SERIES_US and all(k in bins for k in keys):
            rate = np.array([bins[k] for k in keys])
            out[r, 2] = swing(rate, RATE_BIN_US / 1000, (3.0, 40.0), 250.0)
    return Objects(feats, out, inference.detected, np.asarray(data.label, dtype=bool))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("dataset")
    parser.add_argument(
        "--mix",
        metavar="DIR",
        help="fit on DATASET's training windows mixed with DIR's, as `uavsnn reproduce` fits "
        "the combined network (DIR: its sim dataset)",
    )
    parser.add_argument(
        "--other",
        metavar="DIR",
        help="also score the fits without and with the swing on DIR's train split (recordings "
        "of another seed, that no fit saw)",
    )
    parser.add_argument(
        "--tune",
        metavar="DIR",
        help="tune on DIR's train split (as `uavsnn train --tune DIR`) instead of a quarter of "
        "the training recordings held out",
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    net = Network.load(args.model)
    fit_on = load(args.dataset, "train")
    if args.mix:
        fit_on = mix_windows([fit_on, load(args.mix, "train")], len(fit_on), seed=0)
    if args.tune:
        train, tune = fit_on, load(args.tune, "train")
    else:
        train, tune = identify.split_by_recording(fit_on)
    parts = {name: objects(net, d) for name, d in (("train", train), ("tune", tune))}
    parts["test"] = objects(net, load(args.dataset, "test"))
    k = FEATURES.index("log_rate_swing")
    without = [i for i in range(len(FEATURES)) if i != k]

    def alone(o: Objects, column: np.ndarray) -> float | None:
        area = roc_area(-column[o.feats.usable], o.feats.label[o.feats.usable])
        return None if area is None else float(area)

    aucs = {
        split: {
            "window (log_rate_swing)": alone(o, o.feats.x[:, k]),
            **{n: alone(o, o.spans[:, j]) for j, n in enumerate(SPANS)},
        }
        for split, o in parts.items()
    }
    nothing = lambda o: np.zeros((len(o.feats.x), 0))  # noqa: E731
    base = lambda o: o.feats.x[:, without]  # noqa: E731
    columns = {"without log_rate_swing": (nothing, base), "FEATURES (with it)": (nothing, None)}
    for j, n in enumerate(SPANS):
        columns[f"+ {n}"] = (lambda o, j=j: np.log1p(o.spans[:, [j]]), None)
    train_part, tune_part = parts["train"], parts["tune"]
    variants = {n: score_variant(e, *parts.values(), base=b) for n, (e, b) in columns.items()}
    # The same fits scored on the tuning part, where the spans are compared (its thresholds
    # are its own, so only the ROC figures mean anything there).
    on_tune = {
        n: score_variant(e, train_part, tune_part, tune_part, base=b)
        for n, (e, b) in columns.items()
    }
    on_other = {}
    if args.other:
        other = objects(net, load(args.other, "train"))
        any_spike = float(np.mean(other.detected == other.label))
        on_other = {"any-spike accuracy": any_spike}
        for n in ("without log_rate_swing", "FEATURES (with it)"):
            e, b = columns[n]
            on_other[n] = score_variant(e, train_part, tune_part, other, base=b)
    test_feats = parts["test"].feats
    swing = np.expm1(test_feats.x[:, k])
    events = np.expm1(test_feats.x[:, FEATURES.index("log_events_per_px")]) * np.exp(
        test_feats.x[:, FEATURES.index("log_area")]
    )
    by_class = {
        str(c): {
            "objects": int(m.sum()),
            "median": float(np.median(swing[m])),
            "zero": float(np.mean(swing[m] == 0)),
            "events": float(np.median(events[m])),
        }
        for c in np.unique(test_feats.cls[test_feats.cls != ""])
        for m in [test_feats.cls == c]
    }
    if args.json:
        print(
            json.dumps(
                {
                    "auc_alone": aucs,
                    **variants,
                    "on_tune": on_tune,
                    "on_other": on_other,
                    "test": by_class,
                }
            )
        )
        return
    print(", ".join(f"{k}: {len(v.feats.x)} objects" for k, v in parts.items()))
    print(
        "| test objects of each class | objects | swing, median | share with no swing "
        "| events in the box, median |"
    )
    print("|---|---|---|---|---|")
    for c, v in by_class.items():
        print(
            f"| {c} | {v['objects']} | {v['median']:.3f} | {100 * v['zero']:.0f} % "
            f"| {v['events']:.0f} |"
        )
    print()
    print("| swing over | " + " | ".join(aucs) + " |")
    print("|---|" + "---|" * len(aucs))
    for n in aucs["train"]:
        print(f"| {n} | " + " | ".join(f"{aucs[s][n]:.3f}" for s in aucs) + " |")
    print()
    print("| columns | | L2 | accuracy | detection at 1 % / 5 % false alarms | object ROC area |")
    print("|---|---|---|---|---|---|")
    for name, r in variants.items():
        print(
            f"| {name} | {r['columns']} | {r['l2']:g} | {100 * r['accuracy']:.1f} % | "
            f"{100 * r['detection_at_0.01']:.1f} / {100 * r['detection_at_0.05']:.1f} % | "
            f"{r['object_auc']:.3f} |"
        )
    if on_other:
        print()
        print(
            f"On {args.other}'s train split (any-spike {100 * on_other['any-spike accuracy']:.1f}"
            " %): | columns | threshold | accuracy | detection at 1 % / 5 % false alarms "
            "| object ROC area |"
        )
        for name in ("without log_rate_swing", "FEATURES (with it)"):
            r = on_other[name]
            print(
                f"| {name} | {r['threshold']:.3f} | {100 * r['accuracy']:.1f} % | "
                f"{100 * r['detection_at_0.01']:.1f} / {100 * r['detection_at_0.05']:.1f} % | "
                f"{r['object_auc']:.3f} |"
            )
    print()
    print("On the tuning part: | columns | detection at 1 % / 5 % false alarms | object ROC area |")
    for name, r in on_tune.items():
        print(
            f"| {name} | {100 * r['detection_at_0.01']:.1f} / "
            f"{100 * r['detection_at_0.05']:.1f} % | {r['object_auc']:.3f} |"
        )


if __name__ == "__main__":
    main()
