"""A track's UAV evidence: the running mean of its objects' scores against their summed log-odds.

The tracker alarms on a track's running mean UAV score (``WindowObject.track_score``): a
track of forty windows at 0.7 alarms no sooner than one of three. A sequential test would
sum each object's evidence instead, ``Σ (logit(s_i) − d)`` with a drift ``d``, so that a
long track of moderately UAV-like objects alarms where a short one does not. Whether that
finds more UAV recordings at the same false-track rate is measured here, as `reproduce`
measures the tracker's rule:

1. ``--minutes`` of fresh UAV-free dvs recording of ``--tune-seed`` under the tuning key
   (``uavsnn.false_alarms.TUNE_KEY``, the recordings `reproduce` sets track alarm thresholds
   on), streamed through the detector; each statistic's threshold for each of ``--rates``
   false tracks per minute is read off its confirmed tracks' peaks
   (``uavsnn.false_alarms.track_alarm_threshold`` with no floor: a summed log-odds may be
   negative);
2. the same minutes of ``--seed`` under the measuring key (``FREE_KEY``, the recordings of
   RESULTS.md's false alarms): the false tracks per minute at that threshold;
3. the recordings of DATASET's ``--split`` (test) streamed whole (``uavsnn.clips``): the
   UAV recordings found (an alarming track meets the labelled UAV) and the other recordings
   alarmed. ``--split train`` on a tuning set of another seed (``data/tune-dvs``) chooses a
   drift on recordings that no reported figure uses.

Every statistic reads the same streams: the detector runs once per recording, and each
statistic is recomputed from the objects' UAV scores in stream order. The running mean is
checked against the detector's own ``track_score``.

Run from the repository root::

    python benches/python/track_evidence.py MODEL DATASET [--split test] [--minutes 10] [--seed 0]
        [--tune-seed 1] [--drifts 0,1,2] [--rates 0.1,1,5] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from uavsnn import Network
from uavsnn.clips import StreamedClip, clip_alarms, clip_set, clip_stream
from uavsnn.false_alarms import (
    FREE_KEY,
    TUNE_KEY,
    count_alarms,
    scene_batches,
    scene_reports,
    track_alarm_threshold,
)
from uavsnn.grouping import WindowReport

#: Scores are clipped to [EPS, 1 − EPS] before their log-odds are taken.
EPS = 1e-4


def logit(p: float) -> float:
    p = min(max(p, EPS), 1 - EPS)
    return math.log(p / (1 - p))


def statistic_name(drift: float | None) -> str:
    return "running mean" if drift is None else f"summed log-odds, drift {drift:g}"


def rescore(reports: Sequence[WindowReport], drift: float | None) -> list[WindowReport]:
    """``reports`` with each tracked, scored object's ``track_score`` replaced by its track's
    statistic so far: the running mean of the scores (``drift`` None; it must equal the
    detector's) or ``Σ (logit(s) − drift)``."""
    state: dict[int, tuple[int, float]] = {}
    out = []
    for report in reports:
        objects = []
        for o in report.objects:
            if o.track_id is None or o.uav_score is None:
                objects.append(o)
                continue
            n, total = state.get(o.track_id, (0, 0.0))
            step = o.uav_score if drift is None else logit(o.uav_score) - drift
            n, total = n + 1, total + step
            state[o.track_id] = (n, total)
            value = total / n if drift is None else total
            if drift is None and o.track_score is not None and abs(value - o.track_score) > 1e-9:
                raise AssertionError(f"running mean {value} is not the detector's {o.track_score}")
            objects.append(replace(o, track_score=value))
        out.append(replace(report, objects=tuple(objects)))
    return out


def free_streams(
    network: Network, minutes: float, seed: int, key: int
) -> list[tuple[float, list[WindowReport]]]:
    """Each UAV-free recording of ``minutes`` (``scene_batches``) streamed: (seconds, reports)."""
    return [
        (lr.end_us / 1e6, reports)
        for batch in scene_batches(minutes, seed, key)
        for lr, reports in scene_reports(network, batch)
    ]


def test_streams(network: Network, dataset: Path, split: str = "test") -> list[StreamedClip]:
    """Each recording of ``dataset``'s ``split`` made again and streamed whole
    (``uavsnn.clips.clip_stream``)."""
    clips = clip_set(dataset, split)
    return [clip_stream(network, clips, k) for k in range(len(clips.clips))]


def measure(
    tune: list[tuple[float, list[WindowReport]]],
    free: list[tuple[float, list[WindowReport]]],
    tests: list[StreamedClip],
    drifts: Sequence[float | None],
    rates: Sequence[float],
) -> list[dict[str, Any]]:
    tune_minutes = sum(s for s, _ in tune) / 60
    free_minutes = sum(s for s, _ in free) / 60
    rows = []
    for drift in drifts:
        tune_r = [rescore(r, drift) for _, r in tune]
        free_r = [rescore(r, drift) for _, r in free]
        test_r = [rescore(t.reports, drift) for t in tests]
        peaks = [p for r in tune_r for p in count_alarms(r, {})["track_peaks"]]
        for rate in rates:
            threshold = track_alarm_threshold(peaks, tune_minutes, rate, floor=-math.inf)
            rules: dict[str, float | None] = {"r": threshold}
            false = sum(count_alarms(r, rules)["tracks"]["r"] for r in free_r)
            found = other = 0
            for t, reports in zip(tests, test_r, strict=True):
                got = clip_alarms(reports, rules, t.report_uav, t.report_boxes)["rules"]["r"]
                found += t.uav and got["found_us"] is not None
                other += (not t.uav) and got["alarmed"]
            rows.append(
                {
                    "statistic": statistic_name(drift),
                    "drift": drift,
                    "rate": rate,
                    "threshold": threshold,
                    "free_false_tracks": false,
                    "free_false_tracks_per_minute": false / free_minutes,
                    "uav_found": found,
                    "uav_recordings": sum(t.uav for t in tests),
                    "other_alarmed": other,
                    "other_recordings": sum(not t.uav for t in tests),
                }
            )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model", type=Path)
    parser.add_argument("dataset", type=Path, help="a dvs dataset whose --split is streamed")
    parser.add_argument(
        "--split",
        default="test",
        help="the split whose recordings are streamed whole (test; train on a tuning set of "
        "another seed, to choose a drift on recordings no reported figure uses)",
    )
    parser.add_argument("--minutes", type=float, default=10.0, help="UAV-free minutes (10)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the measured minutes (0)")
    parser.add_argument("--tune-seed", type=int, default=1, help="seed of the tuning minutes (1)")
    parser.add_argument("--drifts", default="0,1,2", help="drifts of the summed log-odds (0,1,2)")
    parser.add_argument("--rates", default="0.1,1,5", help="false tracks per minute (0.1,1,5)")
    parser.add_argument("--json", type=Path, help="also write the rows to this JSON file")
    args = parser.parse_args()
    network = Network.load(args.model)
    if network.identification is None:
        parser.error("the model has no identification: its objects have no UAV score")
    drifts: list[float | None] = [None, *(float(d) for d in args.drifts.split(",") if d)]
    rates = [float(r) for r in args.rates.split(",") if r]
    rows = measure(
        free_streams(network, args.minutes, args.tune_seed, TUNE_KEY),
        free_streams(network, args.minutes, args.seed, FREE_KEY),
        test_streams(network, args.dataset, args.split),
        drifts,
        rates,
    )
    print(
        f"{args.minutes:g} minutes of UAV-free recording to set each threshold on (seed "
        f"{args.tune_seed}) and {args.minutes:g} to measure (seed {args.seed}); the "
        f"{args.split} recordings of {args.dataset} streamed whole.\n"
    )
    print(
        "| statistic | set for (false tracks per minute) | threshold | false tracks per minute "
        "(measured) | UAV recordings found | other recordings alarmed |"
    )
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['statistic']} | {r['rate']:g} | {r['threshold']:.3f} "
            f"| {r['free_false_tracks_per_minute']:.2f} ({r['free_false_tracks']}) "
            f"| {r['uav_found']} of {r['uav_recordings']} "
            f"| {r['other_alarmed']} of {r['other_recordings']} |"
        )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
