"""Networks of several sensor sizes side by side, from their ``uavsnn evaluate --tracks --json``.

Each argument is ``LABEL=FILE``: the JSON that ``uavsnn evaluate MODEL DATASET --tracks --json``
printed for one network on its test split (one sensor size each, e.g. the dvs network of
``uavsnn reproduce`` at 240x180 and networks trained the same way at 640x480 and 1280x720).
Prints, one column per file, the figures of SPEC §5 that docs/identification.md compares across
sizes: accuracy of both rules, drones and other objects called UAV by each rule (identification
at the model's own threshold), detection at 1 % and 5 % false alarms (read off the test ROC, and
at the points set beforehand on the tuning set, with the false alarms they gave), drones
detected at 1 % false alarms by size, the other objects' false alarms at 1 %, and the tracks.
Reads the files only.

    python benches/python/size_table.py 240x180=eval-240.json 640x480=eval-640.json
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
from collections.abc import Callable, Sequence
from typing import Any

from uavsnn.evaluation import SIZE_BINS_PX, detection_by_target


def pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.1f} %"


def _point(figures: dict[str, Any], key: str, target: float) -> dict[str, Any] | None:
    """The operating point of ``figures["identification"][key]`` set for ``target``."""
    points = figures["identification"].get(key, [])
    return next((p for p in points if p["false_alarm_target"] == target), None)


def _set_beforehand(target: float) -> Callable[[dict[str, Any]], str]:
    def cell(f: dict[str, Any]) -> str:
        p = _point(f, "at_tuned_false_alarm", target)
        return "–" if p is None else f"{pct(p['detection_rate'])} ({pct(p['false_alarm_rate'])})"

    return cell


def _called_uav(cls: str) -> Callable[[dict[str, Any]], str]:
    def cell(f: dict[str, Any]) -> str:
        c = f["per_class"].get(cls)
        return "–" if c is None else f"{pct(c['called_uav_rate'])} of {c['windows']}"

    return cell


def _identified(cls: str) -> Callable[[dict[str, Any]], str]:
    def cell(f: dict[str, Any]) -> str:
        return pct(f["identification"]["identified"]["per_class"].get(cls))

    return cell


def _size_at_1(low: float) -> Callable[[dict[str, Any]], str]:
    def cell(f: dict[str, Any]) -> str:
        p = _point(f, "at_false_alarm", 0.01)
        hit = None if p is None else next((b for b in p["by_size_px"] if b["low"] == low), None)
        return "–" if hit is None else f"{pct(hit['rate'])} of {hit['windows']}"

    return cell


def _false_alarms_at_1(f: dict[str, Any]) -> str:
    p = _point(f, "at_false_alarm", 0.01)
    if p is None:
        return "–"
    shares = {c: r for c, r in p["false_alarms_per_class"].items() if r > 0}
    return ", ".join(f"{c} {pct(r)}" for c, r in sorted(shares.items())) or "none"


def _tracks(rule: str) -> Callable[[dict[str, Any]], str]:
    def cell(f: dict[str, Any]) -> str:
        t = f.get("tracks")
        r = None if t is None else t["rules"].get(rule)
        if r is None:
            return "–"
        return f"{r['found']} of {t['uav_recordings']}; {r['false_tracks_per_minute']:.1f}"

    return cell


def _roc(target: float) -> Callable[[dict[str, Any]], str]:
    def cell(f: dict[str, Any]) -> str:
        return pct(detection_by_target(f["identification"]["at_false_alarm"]).get(target))

    return cell


ROWS: tuple[tuple[str, Callable[[dict[str, Any]], str]], ...] = (
    ("any-spike rule", lambda f: pct(f["accuracy"])),
    ("with identification", lambda f: pct(f["identification"]["identified"]["accuracy"])),
    ("drones called UAV (any-spike)", _called_uav("drone")),
    *(
        (f"{c}s called UAV (any-spike)", _called_uav(c))
        for c in ("ball", "bird", "insect", "helicopter", "airplane")
    ),
    *(
        (f"{c}s called UAV with identification", _identified(c))
        for c in ("drone", "ball", "bird", "insect", "helicopter", "airplane")
    ),
    ("detection at 1 % false alarms (test ROC)", _roc(0.01)),
    ("detection at 5 % false alarms (test ROC)", _roc(0.05)),
    ("set beforehand for 1 %: detection (false alarms)", _set_beforehand(0.01)),
    ("set beforehand for 5 %", _set_beforehand(0.05)),
    # The size bins of `uavsnn evaluate` from 6 px (the target counts those).
    *(
        (
            f"drones of {lo:g}–{hi:g} px at 1 %"
            if math.isfinite(hi)
            else f"drones of ≥ {lo:g} px at 1 %",
            _size_at_1(lo),
        )
        for lo, hi in itertools.pairwise(SIZE_BINS_PX[1:])
    ),
    ("false alarms at 1 %, by class", _false_alarms_at_1),
    ("tracks, any-spike: UAV recordings found; false tracks per minute", _tracks("any_spike")),
    ("tracks, with identification", _tracks("identified")),
    ("tracks, set beforehand for 1 %", _tracks("identified_at_0.01")),
)
"""The table's rows: a name and how to read its cell from one file."""


def rows(files: Sequence[dict[str, Any]]) -> list[tuple[str, list[str]]]:
    """The table's rows: a name and one cell per file."""
    return [(name, [cell(f) for f in files]) for name, cell in ROWS]


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="+", metavar="LABEL=FILE")
    args = parser.parse_args(argv)
    labels, files = [], []
    for arg in args.files:
        label, sep, path = arg.partition("=")
        if not sep or not label or not path:
            parser.error(f"{arg!r}: expected LABEL=FILE")
        with open(path) as fh:
            figures = json.load(fh)
        if "identification" not in figures:
            parser.error(f"{path}: no identification figures (a model without identification?)")
        labels.append(label)
        files.append(figures)
    print("| | " + " | ".join(labels) + " |")
    print("|---|" + "---|" * len(labels))
    for name, cells in rows(files):
        print(f"| {name} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
