"""Time to first alarm against false tracks, for several track confirmation rules.

The network runs once over the windows of a split; its objects are linked by the tracker once
(:func:`uavsnn.identify.window_features`); each confirmation rule is then applied to the same
tracks' hits (:class:`uavsnn.track_eval.Confirm`: confirmation is a function of a track's hit
windows, and of its running mean UAV score for the score-aware rules, so one tracking pass
serves every rule). For each rule and both alarm rules (any-spike; any-spike +
identification) it prints the UAV recordings found, the time to first alarm (median, 90th
percentile), the false tracks and their rate per minute of UAV-free recording with the
one-sided 95 % Poisson bound.

``--split tune`` (the default) scores the tuning recordings: the quarter of the training
split's recordings :func:`uavsnn.identify.split_by_recording` holds out (identification is
fitted on the other three quarters). Choose a rule on these only; ``--split test`` then
reports the chosen rule's figures on the test split once.

Run from the repository root::

    python benches/python/confirm_rules.py MODEL DATASET [--split tune|test]
        [--rules 3/5,2/3,2/2,4/5,2/3+3/5,2/2+3/5] [--threads 1] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from uavsnn.dataset import load
from uavsnn.identify import split_by_recording, window_features
from uavsnn.network import MAX_THREADS, Network
from uavsnn.track_eval import Confirm, track_figures

DEFAULT_RULES = "3/5,2/3,2/2,4/5,2/3+3/5,2/2+3/5"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model", type=Path)
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--split", choices=("tune", "test"), default="tune")
    parser.add_argument("--rules", default=DEFAULT_RULES, help=f"({DEFAULT_RULES})")
    parser.add_argument("--threads", type=int, default=1, help="network threads (1)")
    parser.add_argument("--json", type=Path, help="also write the figures to this JSON file")
    args = parser.parse_args()
    if not 1 <= args.threads <= MAX_THREADS:
        parser.error(f"--threads must be from 1 to {MAX_THREADS}")
    rules = [Confirm.parse(text) for text in args.rules.split(",")]
    network = Network.load(args.model)
    if args.split == "tune":
        _, data = split_by_recording(load(args.dataset, "train"))
    else:
        data = load(args.dataset, "test")
    start = time.perf_counter()
    inference = network.infer(data.windows, threads=args.threads)
    feats = window_features(network, data, inference)
    ident = network.identification
    scores = None if ident is None else ident.scores(feats.x)
    threshold = None if ident is None else ident.threshold
    print(
        f"{args.dataset.name}/{args.split}: {len(data)} windows, {len(feats.window)} objects "
        f"({time.perf_counter() - start:.0f} s); identification threshold "
        f"{'-' if threshold is None else f'{threshold:.3f}'}"
    )
    out = {}
    header = (
        "| rule | alarm | UAV recordings found | time to first alarm, median / p90 (ms) "
        "| false tracks | per minute (95 % bound) |"
    )
    print(header)
    print("|---|---|---|---|---|---|")
    for rule in rules:
        f = track_figures(data, feats, scores, threshold, confirm=rule)
        out[str(rule)] = f
        for name, r in f["rules"].items():
            t = r["time_to_alarm_ms"]
            med = "-" if t["median"] is None else f"{t['median']:.0f}"
            p90 = "-" if t["p90"] is None else f"{t['p90']:.0f}"
            print(
                f"| {rule} | {name} | {r['found']} of {f['uav_recordings']} | {med} / {p90} "
                f"| {r['false_tracks']} | {r['false_tracks_per_minute']:.2f} "
                f"({r['false_tracks_per_minute_upper95']:.2f}) |"
            )
    print(f"UAV-free recording: {60 * f['uav_free_minutes']:.1f} s; {f['recordings']} recordings")
    if args.json:
        args.json.write_text(json.dumps(out, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
