"""Track level, the whole trade-off: UAV recordings found against false tracks per minute.

For thresholds of the identified track rule (a confirmed track alarms once the running mean of
its objects' UAV scores reaches the threshold), prints the UAV recordings of a dataset split
found and their time to first alarm (``uavsnn.track_eval.track_figures``, as ``uavsnn evaluate
--tracks`` follows them), beside the false tracks per minute of streamed UAV-free recording
(the ``track_peaks`` of ``benches/python/false_alarms.py --json`` files, one per ``--free``).
The thresholds: the model's own track alarm thresholds (set beforehand on other recordings,
``uavsnn train --track-minutes``) and window operating points (set on the tuning windows), and
for each ``--rate`` the threshold read off the first
``--free`` file (``false_alarms.track_alarm_threshold``), as a ROC's points are read off the
set they are measured on: no user can set those beforehand.

    python benches/python/false_alarms.py MODEL --minutes 10 --seed 0 --json > free0.json
    python benches/python/track_roc.py MODEL DATASET --free free0.json [--free free2.json]
"""

from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np
from tune_halves import load_identified

from uavsnn import identify
from uavsnn.dataset import load
from uavsnn.false_alarms import track_alarm_threshold
from uavsnn.track_eval import Confirm, track_figures
from uavsnn.tracks import tracker_for

#: False tracks per minute read off the first streamed set by default.
RATES = (0.1, 0.2, 0.5, 1.0, 2.0, 5.0)


def load_streamed(paths: list[str], key: str) -> list[dict[str, Any]]:
    """The ``false_alarms.py --json`` files at ``paths``, each of which must hold ``key``
    (``track_peaks`` or ``window_peaks``: written by this uavsnn)."""
    out = []
    for path in paths:
        with open(path, encoding="utf-8") as f:
            out.append(json.load(f))
        if key not in out[-1]:
            raise SystemExit(f"{path}: no {key} (false_alarms.py --json of this uavsnn)")
    return out


def false_tracks(free: dict[str, Any], threshold: float) -> float:
    """False tracks per minute of one streamed set at ``threshold``: its confirmed tracks
    whose peak score reaches it."""
    return sum(p >= threshold for p in free["track_peaks"]) / free["minutes"]


def rows(
    found: Any, frees: list[dict[str, Any]], points: list[tuple[str, float]]
) -> list[dict[str, Any]]:
    """One row per ``(name, threshold)`` of ``points``: ``found(threshold)`` (the dataset's
    track rule at it) and each streamed set's false tracks per minute."""
    out = []
    for name, threshold in points:
        rule = found(threshold)
        out.append(
            {
                "point": name,
                "threshold": threshold,
                "found": rule["found"],
                "time_to_alarm_ms": rule["time_to_alarm_ms"],
                "false_tracks_per_minute": [false_tracks(f, threshold) for f in frees],
            }
        )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("dataset")
    parser.add_argument("--split", default="test")
    parser.add_argument("--free", action="append", required=True, metavar="JSON")
    parser.add_argument("--rate", type=float, action="append", help=f"per minute ({RATES})")
    parser.add_argument(
        "--confirm",
        default="3/5",
        metavar="HITS/WINDOWS",
        help="the tracker's confirmation rule, as the --free files were streamed (3/5)",
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    net, ident = load_identified(args.model)
    frees = load_streamed(args.free, "track_peaks")
    rule = Confirm.parse(args.confirm)
    if rule.fast is not None:
        raise SystemExit("--confirm takes HITS/WINDOWS")
    for path, free in zip(args.free, frees, strict=True):
        if free.get("confirm", "3/5") != str(rule):
            raise SystemExit(f"{path} was streamed with --confirm {free.get('confirm')}")
    data = load(args.dataset, args.split)
    tracker = tracker_for(net, confirm_hits=rule.hits, confirm_windows=rule.windows)
    feats = identify.window_features(net, data, tracker=tracker)
    scores = ident.scores(feats.x)
    uav = int(np.unique(np.asarray(data.recording)[np.asarray(data.label, bool)]).size)

    def found(threshold: float) -> dict[str, Any]:
        return track_figures(data, feats, scores, threshold)["rules"]["identified"]

    first = frees[0]
    points = [(f"set for {r:g} per minute", t) for r, t in ident.track_alarm_thresholds]
    points += [(f"set for {100 * r:g} % of windows", t) for r, t in ident.alarm_thresholds]
    points += [
        (f"read off for {r:g} per minute", track_alarm_threshold(first["track_peaks"],
                                                                  first["minutes"], r))
        for r in (args.rate or RATES)
    ]  # fmt: skip
    table = rows(found, frees, points)
    if args.json:
        print(json.dumps({"uav_recordings": uav, "rows": table}, indent=2))
        return
    seeds = ", ".join(f"seed {f.get('seed')}" for f in frees)
    print(f"| threshold | UAV recordings found (of {uav}) | time to first alarm, median / 90th "
          f"pct (ms) | false tracks per minute ({seeds}) |")  # fmt: skip
    print("|---|---|---|---|")
    for row in table:
        t = row["time_to_alarm_ms"]
        med = "–" if t["median"] is None else f"{t['median']:.0f} / {t['p90']:.0f}"
        fa = " / ".join(f"{v:.1f}" for v in row["false_tracks_per_minute"])
        print(f"| {row['point']}: {row['threshold']:.3f} | {row['found']} | {med} | {fa} |")


if __name__ == "__main__":
    main()
