"""Window operating points set on streamed recording instead of the tuning windows: do they hold?

A model's operating points (``Identifier.alarm_thresholds``) are set where 1 % and 5 % of the
tuning set's UAV-free windows alarm: some 80 recordings of 1 s. Here the same rule
(``identify.alarm_threshold``) is applied to the windows of a streamed UAV-free set (the
``window_peaks`` of ``benches/python/false_alarms.py --tune-key --json``: hundreds of
recordings, drawn under a key no measured set uses), and both kinds of point are measured on
other streamed sets (``--free``) and on a dataset split (``--dataset``: the share of its
UAV-free windows that alarm and of its UAV windows detected, as RESULTS.md's points set
beforehand).

    python benches/python/false_alarms.py MODEL --minutes 10 --seed 1 --tune-key --json > t.json
    python benches/python/false_alarms.py MODEL --minutes 10 --seed 0 --json > f0.json
    python benches/python/stream_points.py MODEL --tune t.json --free f0.json --dataset DIR
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np
from track_roc import load_streamed
from tune_halves import load_identified

from uavsnn import identify
from uavsnn.dataset import load
from uavsnn.evaluation import FALSE_ALARM_RATES


def window_scores(free: dict[str, Any]) -> np.ndarray:
    """One score per window of a streamed set: its ``window_peaks``, and -1 (never alarms) for
    its other windows (not detected, or without a scored object)."""
    peaks = np.asarray(free["window_peaks"], dtype=np.float64)
    rest = int(free["windows"]) - len(peaks)
    if rest < 0:
        raise ValueError("more window peaks than windows")
    return np.concatenate([peaks, np.full(rest, -1.0)])


def stream_point(free: dict[str, Any], rate: float) -> float:
    """The threshold at which at most ``rate`` of a streamed set's windows alarm, by the rule
    of ``identify.fit``'s points (``identify.alarm_threshold``)."""
    scores = window_scores(free)
    return identify.alarm_threshold(scores, np.zeros(len(scores), bool), rate)


def share(free: dict[str, Any], threshold: float) -> float:
    """The share of a streamed set's windows that alarm at ``threshold``."""
    return float(np.mean(window_scores(free) >= threshold))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("--tune", required=True, metavar="JSON")
    parser.add_argument("--free", action="append", default=[], metavar="JSON")
    parser.add_argument("--dataset", help="a dataset whose --split is measured too")
    parser.add_argument("--split", default="test")
    args = parser.parse_args()
    net, ident = load_identified(args.model)
    tune, *frees = load_streamed([args.tune, *args.free], "window_peaks")
    if not tune.get("tune_key"):
        raise SystemExit(f"{args.tune}: not streamed with --tune-key")
    test = None
    if args.dataset:
        data = load(args.dataset, args.split)
        fired = np.asarray(net.infer(data.windows).detected, bool)
        score = np.where(fired, ident.window_scores(identify.window_features(net, data)), -1.0)
        test = (score, np.asarray(data.label, bool), np.asarray(data.recording))
    columns = [f"seed {f['seed']}" for f in frees]
    if test is not None:
        columns.append(f"{args.split}: false alarms / detection")
        columns.append(f"{args.split}: UAV-free windows alarming (recordings)")
    print(f"| point | threshold | {' | '.join(columns)} |")
    print("|---|---|" + "---|" * len(columns))
    points = [(f"tuning windows, {100 * r:g} %", t) for r, t in ident.alarm_thresholds]
    points += [
        (f"streamed seed {tune['seed']}, {100 * r:g} %", stream_point(tune, r))
        for r in FALSE_ALARM_RATES
    ]
    for name, threshold in points:
        cells = [f"{100 * share(f, threshold):.2f} %" for f in frees]
        if test is not None:
            score, label, recording = test
            alarm = score >= threshold
            cells.append(f"{100 * alarm[~label].mean():.1f} % / {100 * alarm[label].mean():.1f} %")
            hot = np.unique(recording[alarm & ~label])
            free = np.unique(recording[~label])
            cells.append(f"{int((alarm & ~label).sum())} ({len(hot)} of {len(free)})")
        print(f"| {name} | {threshold:.3f} | {' | '.join(cells)} |")


if __name__ == "__main__":
    main()
