"""Which drones detection + identification misses at a fixed false-alarm rate, and which
UAV-free recordings set that rate: by the scene's light and the drone's speed.

For the test split of a dataset (``--split``), the model's any-spike rule and its combined
score (the UAV score where the network fires, as ``uavsnn evaluate`` scores a window) are
computed; the thresholds where 1 % and 5 % of the UAV-free windows alarm are read off this
split's ROC, as ``uavsnn evaluate``'s "detection at 1 % false alarms" is. Prints:

1. the UAV windows by the scene's light level (from the manifest) and the labelled box's speed
   (its centre's displacement to the recording's next window, ``drone_bird_spectra.box_speed``):
   how many the any-spike rule detects, how many pass each threshold, and in how many a
   detected object's rotor signature is detected (``rotor_detected``); then by light alone;
2. the UAV-free recordings whose windows alarm at each threshold, with their class and light,
   and their objects as the build drew them (``uavsnn.clips.Whole.spec``: size, range, and the
   wing beat or rotor rate).

    python benches/python/missed_drones.py runs/dvs1280t/model.npz runs/dvs1280t
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from drone_bird_spectra import box_speed, labelled_split

from uavsnn import Network, identify
from uavsnn.clips import clip_set
from uavsnn.evaluation import FALSE_ALARM_RATES, threshold_at_false_alarm
from uavsnn.features import FEATURES
from uavsnn.scenes import SceneSpec

RATES = FALSE_ALARM_RATES
LIGHT_BINS = ((0.0, 0.1), (0.1, 0.3), (0.3, 1.01))
SPEED_BINS = ((0.0, 20.0), (20.0, 100.0), (100.0, np.inf))


def window_rotor(detected: np.ndarray, window: np.ndarray, windows: int) -> np.ndarray:
    """Per window, whether one of its objects' rotor signature is detected (``detected``: per
    object, ``window``: each object's window)."""
    out = np.zeros(windows, bool)
    np.logical_or.at(out, np.asarray(window, np.int64), np.asarray(detected) > 0.5)
    return out


def bin_rows(
    light: np.ndarray, speed: np.ndarray, columns: dict[str, np.ndarray]
) -> list[dict[str, Any]]:
    """The UAV windows counted by light and speed bin (an unknown speed in its own bin): per
    bin its window count and the sum of each boolean column."""
    rows = []
    for lo, hi in LIGHT_BINS:
        lit = (light >= lo) & (light < hi)
        bins = [(f"{s0:g}–{s1:g}", (speed >= s0) & (speed < s1)) for s0, s1 in SPEED_BINS]
        for name, sel in [*bins, ("unknown", ~np.isfinite(speed))]:
            here = lit & sel
            if here.any():
                rows.append(
                    {
                        "light": f"{lo:g}–{min(hi, 1.0):g}",
                        "speed": name,
                        "windows": int(here.sum()),
                        **{k: int(v[here].sum()) for k, v in columns.items()},
                    }
                )
    return rows


def describe(spec: SceneSpec) -> str:
    """A scene's objects: kind, size (m), range at the start (m) and rate (the wing beat, a
    rotor's revolutions or a leaf's tumble, per second)."""
    return ", ".join(
        f"{o.kind} {o.size_m:.3g} m at {o.path.start[2]:.3g} m, {o.rate_hz:.0f}/s"
        for o in spec.objects
    )


def scene_objects(root: Path, split: str, manifest: dict[str, Any]) -> dict[int, str]:
    """Each rendered recording of the split (by id): its objects as its build drew them
    (:meth:`uavsnn.clips.Whole.spec`, no rendering)."""
    clips = {c.name: c for c in clip_set(root, split).clips}
    out = {}
    for r in manifest["recordings"]:
        whole = clips.get(str(r["name"]))
        spec = None if whole is None else whole.spec()
        if spec is not None:
            out[int(r["id"])] = describe(spec)
    return out


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model", type=Path)
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--split", default="test")
    args = parser.parse_args(argv)
    net = Network.load(args.model)
    ident = net.identification
    if ident is None:
        raise SystemExit(f"{args.model}: no identification")
    d, light_of, _ = labelled_split(args.dataset, args.split)
    inference = net.infer(d.windows)
    feats = identify.window_features(net, d, inference)
    fired = np.asarray(inference.detected, bool)
    combined = ident.combined_scores(feats, fired)
    label = np.asarray(d.label, bool)
    rotor = window_rotor(feats.x[:, FEATURES.index("rotor_detected")], feats.window, len(label))
    t0s = np.asarray(d.windows.t0, dtype=np.int64)
    boxes = np.asarray(d.box, dtype=np.float64)
    uav = np.flatnonzero(label)
    light = np.array([light_of[int(d.recording[i])] for i in uav])
    speed = np.array([box_speed(d, t0s, boxes, int(i)) for i in uav])
    at = {r: combined >= threshold_at_false_alarm(combined, label, r) for r in RATES}
    columns = {
        "any-spike": fired[uav],
        **{f"at {100 * r:g} %": at[r][uav] for r in RATES},
        "rotor detected": (rotor & fired)[uav],
    }
    print(f"{args.model} on {args.dataset} ({args.split}): {len(uav)} UAV windows\n")
    print("| light | box speed (px/s) | windows | " + " | ".join(columns) + " |")
    print("|---|---|---|" + "---|" * len(columns))
    for row in bin_rows(light, speed, columns):
        cells = [str(row[k]) for k in ("light", "speed", "windows", *columns)]
        print("| " + " | ".join(cells) + " |")
    total = [str(len(uav))] + [str(int(v.sum())) for v in columns.values()]
    print("| all | all | " + " | ".join(total) + " |")
    print("\nBy light alone:\n")
    print("| light | windows | " + " | ".join(columns) + " |")
    print("|---|---|" + "---|" * len(columns))
    for lo, hi in LIGHT_BINS:
        lit = (light >= lo) & (light < hi)
        cells = [str(int(lit.sum()))] + [str(int(v[lit].sum())) for v in columns.values()]
        print(f"| {lo:g}–{min(hi, 1.0):g} | " + " | ".join(cells) + " |")
    print(
        "\nUAV-free recordings alarming (class, light: windows alarming of the recording's; "
        "the scene's objects as drawn):\n"
    )
    free = ~label
    scenes = scene_objects(args.dataset, args.split, d.manifest)
    for r in RATES:
        recs = sorted({int(x) for x in d.recording[free & at[r]]})
        items = []
        for rec in recs:
            mine = free & (d.recording == rec)
            cls = str(d.cls[mine][0])
            items.append(
                f"{rec} ({cls}, {light_of[rec]:.2f}: {int(at[r][mine].sum())} of "
                f"{int(mine.sum())}; {scenes.get(rec, '?')})"
            )
        print(f"- at {100 * r:g} %: " + ("; ".join(items) or "none"))


if __name__ == "__main__":
    main()
