"""Is a rotor in the events, class by class? Both rotor estimators on each labelled box.

Draws scenes of one kind at a time (a UAV scene, or an object scene of one kind of object), at a
sensor size and field of view (and lens), renders and records each exactly as ``uavsnn dataset
build --domain dvs`` does (``uavsnn.dataset.synthetic.synthetic_recording``, 50 ms windows
overlapping by half, labelled as the build labels them), and reads every usable window of the
scene's own class with both rotor estimators (``uavsnn.signature``) on the labelled box (whole
pixels): the edge estimator on the window's events (what identification reads, on the
detection's box: ``rotor_log_hz``, ``rotor_detected``), and the rate spectrum on the window and
the window before it (100 ms, what a streaming detector has seen when it decides). No network
and no fitted model: whether the cue is in the events, before anything looks for it.

Per class: the windows, the labelled object's size and range, the events per box pixel, how many
windows each estimator detects a line in and where those lines lie (their quartiles, and the share
below 150 Hz: a helicopter's tail rotor passes 40–70 Hz, a Phantom's blades 200–300 Hz, a
Tello's 360–520 Hz; the spectrum leaves out the boxes too large for its memory cap); the
drone and helicopter windows by the scene's light and the labelled box's speed (its centre's
displacement to the next usable window), the two things that hide a rotor in the dvs domain
(docs/identification.md, "Why the dataset's drones show no rotor"); and the ROC area of the UAV
windows against each class's by the edge estimator's frequency feature as identification
computes it (``log1p`` of the peak, detected or not) and by its detection::

    python benches/python/rotor_by_class.py --sensor 1280x720 --fov 18,22 --scenes 8
    python benches/python/rotor_by_class.py --sensor 1280x720 --fov 18,22 --lens 1.4 --scenes 8

``--per-recording`` adds a row for each UAV recording (its object, path, light, and its
windows' median range, size, speed and events per box pixel, and its edge lines): the same
seeds at two views are the same draws, the view's own (its range, the camera's tilt) apart.

Seeds: scene ``i`` of the ``k``-th kind named is drawn and recorded from seed ``--seed + 1000 k +
i`` (default ``--seed 500``); a dataset's recordings take 32-bit seeds drawn from the dataset's
(``uavsnn.dataset.splits.keyed_seed``), so these are almost surely none of a split's.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
import time
from dataclasses import replace
from typing import Any

import numpy as np

from uavsnn.cli._camera import fov_option, lens_option
from uavsnn.dataset.build import parse_sensor
from uavsnn.dataset.splits import WindowCut
from uavsnn.dataset.synthetic import SceneSource, default_source, synthetic_recording
from uavsnn.errors import ParameterError
from uavsnn.evaluation import roc_area
from uavsnn.signature import rotor_signature, rotor_spectrum

#: Lines below this (Hz) are counted apart: a helicopter's tail rotor and its first harmonics.
LOW_HZ = 150.0

#: The kinds drawn by default, and the class their windows are labelled with.
KINDS = {"uav": "drone", "helicopter": "helicopter", "insect": "insect", "bird": "bird"}


def windows_of(source: SceneSource, cut: WindowCut, kind: str, seed: int) -> list[dict[str, Any]]:
    """Every usable window of one recording whose labelled object is of the kind's class: its
    size, range, light, events per box pixel and both estimators' reading."""
    object_kind = None if kind == "uav" else kind
    lr = synthetic_recording(source, "uav" if kind == "uav" else "object", seed, object_kind)
    windows = cut.cut(lr.recording, lr.end_us)
    labels = cut.label(windows.t0, lr.timestamps_us, lr.labels, lr.labelled)
    drawn = lr.info["objects"][0]  # the scene's own object (a UAV scene's distractor is second)
    ev = lr.recording.events
    t = ev["t"].astype(np.int64)
    rows = []
    for i in np.flatnonzero(labels.usable):
        b = labels.box[i]
        if str(labels.cls[i]) != KINDS[kind] or not np.isfinite(b).all():
            continue
        x0, y0 = int(np.floor(b[0])), int(np.floor(b[1]))
        x1, y1 = max(int(np.ceil(b[2])), x0 + 1), max(int(np.ceil(b[3])), y0 + 1)
        box = (x0, y0, x1 - x0, y1 - y0)
        t0 = int(windows.t0[i])
        in_box = (ev["x"] >= x0) & (ev["x"] < x1) & (ev["y"] >= y0) & (ev["y"] < y1)
        inside, ti = ev[in_box], t[in_box]
        window = inside[(ti >= t0) & (ti < t0 + cut.length_us)]
        history = inside[(ti >= t0 - cut.length_us) & (ti < t0 + cut.length_us)]
        edges = rotor_signature(window, box)
        try:
            spectrum = rotor_spectrum(history, box)
        except ParameterError:  # a box too large for the spectrum's memory cap
            spectrum = None
        rows.append(
            {
                "rec": seed,
                "object": drawn["kind"],
                "path": drawn["path"],
                "t0": t0,
                "centre": ((b[0] + b[2]) / 2, (b[1] + b[3]) / 2),
                "size": float(labels.size_px[i]),
                "range": float(labels.range_m[i]),
                "light": float(lr.info["lighting"]),
                "per_px": len(window) / (box[2] * box[3]),
                "edges": edges,
                "spectrum": spectrum,
                "log_hz": math.log1p(edges.frequency_hz),
            }
        )
    # the box's speed: its centre's displacement to the next usable window's
    for row, after in itertools.pairwise(rows):
        dt = (after["t0"] - row["t0"]) * 1e-6
        row["speed"] = math.dist(row["centre"], after["centre"]) / dt
    if rows:
        rows[-1]["speed"] = math.nan
    return rows


def by_light_and_speed(kind: str, rows: list[dict[str, Any]]) -> None:
    """``kind``'s windows by the scene's light and the box's speed: the lines found there."""
    print(f"\n{KINDS[kind]} windows by light and labelled box speed (px/s):\n")
    print("| light | speed | windows | edges: lines | spectrum, 100 ms: lines |")
    print("|---|---|---|---|---|")
    for lo, hi in ((0.0, 0.1), (0.1, 0.3), (0.3, 1.01)):
        for slo, shi in ((0.0, 20.0), (20.0, 100.0), (100.0, math.inf)):
            sel = [r for r in rows if lo <= r["light"] < hi and slo <= r["speed"] < shi]
            if sel:
                edges = sum(r["edges"].detected for r in sel)
                spectrum = sum(r["spectrum"] is not None and r["spectrum"].detected for r in sel)
                cells = (f"{lo:g}–{min(hi, 1.0):g}", f"{slo:g}–{shi:g}", len(sel), edges, spectrum)
                print("| " + " | ".join(str(c) for c in cells) + " |")
    print(f"(and {sum(not math.isfinite(r['speed']) for r in rows)} last windows without a speed)")


def per_recording(rows: list[dict[str, Any]]) -> None:
    """Each recording of ``rows``: its object, path and light, and the medians of its windows'
    range, size, box speed and events per box pixel, and the windows with an edge line."""
    print(
        "\n| seed | object | path | light | range m | size px | speed px/s "
        "| events per box px | edges: lines |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for rec in sorted({r["rec"] for r in rows}):
        sel = [r for r in rows if r["rec"] == rec]
        med = {k: np.nanmedian([r[k] for r in sel]) for k in ("range", "size", "speed", "per_px")}
        print(
            f"| {rec} | {sel[0]['object']} | {sel[0]['path']} | {sel[0]['light']:.2f} "
            f"| {med['range']:.1f} | {med['size']:.1f} | {med['speed']:.0f} | {med['per_px']:.2f} "
            f"| {sum(r['edges'].detected for r in sel)} of {len(sel)} |"
        )


def lines(rows: list[dict[str, Any]], key: str) -> str:
    """How many windows ``key``'s estimator detects a line in (of those it could read: the
    spectrum's memory cap leaves the largest boxes out), their quartiles and the share below
    :data:`LOW_HZ`."""
    read = [r for r in rows if r[key] is not None]
    f = np.array([r[key].frequency_hz for r in read if r[key].detected])
    if not len(f):
        return f"0 of {len(read)} | – | –"
    q = np.percentile(f, [25, 50, 75])
    return (
        f"{len(f)} of {len(read)} ({100 * len(f) / len(read):.0f} %) "
        f"| {q[0]:.0f} / {q[1]:.0f} / {q[2]:.0f} | {100 * np.mean(f < LOW_HZ):.0f} %"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sensor", default="1280x720", metavar="WxH")
    ap.add_argument("--fov", default=None, metavar="LO,HI")
    ap.add_argument("--lens", type=float, default=None, metavar="F_NUMBER")
    ap.add_argument("--focus-m", type=float, default=None, metavar="M")
    ap.add_argument("--scenes", type=int, default=8, help="recordings per kind (8)")
    ap.add_argument("--kinds", default=",".join(KINDS), help=f"of {','.join(KINDS)}")
    ap.add_argument("--seed", type=int, default=500)
    ap.add_argument(
        "--per-recording", action="store_true", help="also each UAV recording's own row"
    )
    args = ap.parse_args()
    kinds = args.kinds.split(",")
    if not set(kinds) <= set(KINDS) or "uav" not in kinds:
        raise SystemExit(f"--kinds: 'uav' and any of {', '.join(KINDS)}, got {args.kinds!r}")
    if not 1 <= args.scenes <= 200:
        raise SystemExit(f"--scenes must be 1 to 200, got {args.scenes}")
    source = replace(  # as `uavsnn dataset build --domain dvs --sensor --lens --fov` makes it
        default_source("dvs", parse_sensor(args.sensor)),
        lens=lens_option(args.lens, args.focus_m),
        fov_deg=fov_option(args.fov),
    )
    cut = WindowCut(50_000, 0.5, 0.5)
    by_kind: dict[str, list[dict[str, Any]]] = {}
    start = time.perf_counter()
    for k, kind in enumerate(kinds):
        rows: list[dict[str, Any]] = []
        for i in range(args.scenes):
            rows += windows_of(source, cut, kind, args.seed + 1000 * k + i)
            print(f"{kind} {i + 1}/{args.scenes}", file=sys.stderr, flush=True)
        by_kind[kind] = rows
    took = time.perf_counter() - start
    print(
        f"{args.sensor}, view {args.fov or 'the default'} degrees, "
        f"{'f/' + format(args.lens, 'g') if args.lens else 'pinhole'}"
        f"{f' focused at {args.focus_m:g} m' if args.focus_m else ''}; "
        f"{args.scenes} recordings per kind, seeds from {args.seed}; {took:.0f} s\n"
    )
    print(
        "| class | windows (recordings) | size px (median) | range m (median) "
        "| events per box px, 50 ms | edges: lines | their quartiles (Hz) | below 150 Hz "
        "| spectrum, 100 ms: lines | their quartiles (Hz) | below 150 Hz |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for kind, rows in by_kind.items():
        if not rows:
            print(f"| {KINDS[kind]} | 0 | | | | | | | | | |")
            continue
        recs = len({r["rec"] for r in rows})
        print(
            f"| {KINDS[kind]} | {len(rows)} ({recs}) | {np.median([r['size'] for r in rows]):.1f} "
            f"| {np.median([r['range'] for r in rows]):.0f} "
            f"| {np.median([r['per_px'] for r in rows]):.2f} "
            f"| {lines(rows, 'edges')} | {lines(rows, 'spectrum')} |"
        )
    for kind in ("uav", "helicopter"):
        if by_kind.get(kind):
            by_light_and_speed(kind, by_kind[kind])
    if args.per_recording and by_kind["uav"]:
        print("\ndrone recordings:")
        per_recording(by_kind["uav"])
    uav = by_kind["uav"]
    print(
        "\nROC area of the UAV windows against each class's, by the edge estimator "
        "(rotor_log_hz: log1p of its peak; rotor_detected):\n"
    )
    for kind, rows in by_kind.items():
        if kind == "uav" or not rows or not uav:
            continue
        label = np.r_[np.ones(len(uav), bool), np.zeros(len(rows), bool)]
        both = uav + rows
        hz = roc_area(np.array([r["log_hz"] for r in both]), label)
        det = roc_area(np.array([float(r["edges"].detected) for r in both]), label)
        print(f"- {KINDS[kind]}: rotor_log_hz {hz:.3f}, rotor_detected {det:.3f}")


if __name__ == "__main__":
    main()
