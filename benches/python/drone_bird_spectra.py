"""A drone at 50 m and a bird of the same size in pixels: their event-rate spectra in the box.

Two "dvs" scenes (240x180, a telephoto lens so that a Phantom at 50 m spans about 12 pixels,
sky, camera tilted 30 degrees up, objects 30 degrees above the horizon, 0.6 s): a hovering
Phantom whose rotors turn at 120 rev/s (blade pass 240 Hz), and a gliding-speed bird (wing beat
6 Hz, 0.6 m span) placed at the range where its box is as wide as the drone's. Each is recorded
with ``uavsnn.scenes.record`` (fast parts sampled between frames) and the mean per-pixel,
per-polarity event-rate spectrum in its box (``uavsnn.sim.checks.pixel_rate_spectrum``) is
compared: physics says the drone's pixels beat at the blade pass and its harmonics, the bird's
only at the wing beat's few hertz and their low harmonics.

    python benches/python/drone_bird_spectra.py [--png docs/drone_bird_spectra.png]

``--samples-per-pass N`` records both with N sub-frame samples per blade passage or wing beat
instead of the scenes' ``SAMPLES_PER_PASS``; the table's last column gives the strongest line
that is no harmonic of the blade pass (a fold of the sampling shows there).

``--factors`` measures instead why a rotor that this spectrum shows can still go unseen in a
dataset window: the same hovering Phantom, changed one factor at a time (the light, a crossing
speed, the range, a Tello instead), each recorded for 0.2 s, and the box of the drone over the
100 ms before 0.15 s read by both rotor estimators (``uavsnn.signature``): the edge estimator
on the 50 ms window (what identification read before), the rate spectrum on the same 50 ms,
and both on the window and the 50 ms before it (the raw events a dataset keeps, what a
streaming detector has seen when it decides)::

    python benches/python/drone_bird_spectra.py --factors

``--dataset DIR`` reads the same on the UAV windows of a dataset's test split (``--split``): per
window, the labelled box's events over ``[t0 − L, t0 + L)``, the scene's light level (from the
manifest) and the box's speed (its centre's displacement to the next window of the recording),
and both estimators on those events (the edge estimator also on the window alone, as
identification reads it); then how many windows fall in each light and speed class and what
the estimators find there::

    python benches/python/drone_bird_spectra.py --dataset runs/b

``--motion`` records the Phantom (50 m, 120 rev/s) and a bird of the same box width crossing at
0 to 15 m/s (``--vertical R``: also R times as fast vertically; ``--dvs-threshold T``: the
sensor's contrast threshold instead of 0.2; seeds 1–5) and reads the window [100, 150) ms in
the union of the labelled boxes with both estimators, plain and motion-compensated
(``uavsnn.signature.compensated_rotor``). ``--motion --dataset DIR`` reads every labelled
window of a dataset's split the same way, by class, light and speed::

    python benches/python/drone_bird_spectra.py --motion [--vertical 0.5] [--dvs-threshold 0.1]
    python benches/python/drone_bird_spectra.py --motion --dataset DIR [--limit N]
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn.scenes import Background, Lighting, ObjectSpec, PathSpec, SceneSpec, record
from uavsnn.scenes.renderer import SAMPLES_PER_PASS
from uavsnn.signature import compensated_rotor, motion_line, rotor_signature, rotor_spectrum
from uavsnn.sim.checks import dominant_frequency, pixel_rate_spectrum, plot_spectra

FOCAL = 1200.0


def off_harmonics(f: np.ndarray, p: np.ndarray, base_hz: float, med: float) -> str:
    """The strongest line in 20-1000 Hz more than 8 Hz from every multiple of ``base_hz``, as
    ``"Hz: power / median"``."""
    away = np.abs(f - base_hz * np.round(f / base_hz)) > 8.0
    band = (f >= 20.0) & (f <= 1000.0) & away
    if not band.any():
        return "-"
    i = np.flatnonzero(band)[np.argmax(p[band])]
    return f"{f[i]:.0f}: {float(p[i]) / med:.1f}"


def scene(obj: ObjectSpec, duration: float, light: float = 1.0) -> SceneSpec:
    return SceneSpec(
        domain="dvs",
        width=240,
        height=180,
        fps=500.0,
        duration_s=duration,
        focal_px=FOCAL,
        background=Background("sky", cloud_cover=0.0),
        lighting=Lighting(level=light, noise=0.0),
        objects=(obj,),
        tilt_deg=30.0,
    )


def at(range_m: float) -> PathSpec:
    """Hovering on the optical axis (camera coordinates; the camera looks 30 degrees up),
    ``range_m`` away."""
    return PathSpec("hover", (0.0, 0.0, range_m))


def box_width(rec_labels: np.ndarray) -> float:
    return float(np.median(rec_labels["x1"] - rec_labels["x0"]))


#: (name, kind, size m, range m, rev/s, crossing speed m/s, light): one factor changed at a time.
FACTORS = (
    ("base: Phantom, 50 m, hovering, daylight", "phantom", 0.29, 50.0, 120.0, 0.0, 1.0),
    ("light 0.3 (overcast, lit hall)", "phantom", 0.29, 50.0, 120.0, 0.0, 0.3),
    ("light 0.1 (dim)", "phantom", 0.29, 50.0, 120.0, 0.0, 0.1),
    ("light 0.03 (dark)", "phantom", 0.29, 50.0, 120.0, 0.0, 0.03),
    ("crossing at 3 m/s", "phantom", 0.29, 50.0, 120.0, 3.0, 1.0),
    ("crossing at 12 m/s", "phantom", 0.29, 50.0, 120.0, 12.0, 1.0),
    ("range 100 m", "phantom", 0.29, 100.0, 120.0, 0.0, 1.0),
    ("range 25 m", "phantom", 0.29, 25.0, 120.0, 0.0, 1.0),
    ("Tello, 220 rev/s, 20 m", "tello", 0.098, 20.0, 220.0, 0.0, 1.0),
)


def factors() -> None:
    """One factor at a time (see the module's documentation)."""
    t0, length = 100_000, 50_000
    print(
        "| case | box (px) | events in box, 100 ms | blade pass (Hz) | edges, 50 ms "
        "| edges, 100 ms | spectrum, 50 ms | spectrum, 100 ms |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, kind, size, range_m, rev, speed, light in FACTORS:
        path = PathSpec("linear", (-speed * 0.1, 0.0, range_m), velocity=(speed, 0.0, 0.0))
        obj = ObjectSpec(kind, size, path, rate_hz=rev, heading_deg=30.0)
        r = record(scene(obj, 0.2, light), sensor=(240, 180), seed=1)
        lab, ts = r.labels, np.asarray(r.timestamps_us)
        span = (ts >= t0 - length) & (ts < t0 + length)
        x0 = int(np.floor(np.nanmin(lab["x0"][span])))
        y0 = int(np.floor(np.nanmin(lab["y0"][span])))
        x1 = int(np.ceil(np.nanmax(lab["x1"][span])))
        y1 = int(np.ceil(np.nanmax(lab["y1"][span])))
        ev = r.recording.events
        inside = ev[(ev["x"] >= x0) & (ev["x"] < x1) & (ev["y"] >= y0) & (ev["y"] < y1)]
        t = inside["t"].astype(np.int64)
        history = inside[(t >= t0 - length) & (t < t0 + length)]
        window = inside[(t >= t0) & (t < t0 + length)]
        box = (x0, y0, x1 - x0, y1 - y0)
        edge = rotor_signature(window, box)
        edge_long = rotor_signature(history, box)
        short = rotor_spectrum(window, box)
        long = rotor_spectrum(history, box)

        def spec(e: object) -> str:
            return (
                f"{e.frequency_hz:.0f} Hz, {e.prominence:.1f}, {e.pixels} px"  # type: ignore[attr-defined]
                + (" **yes**" if e.detected else "")  # type: ignore[attr-defined]
            )

        def edges(e: object) -> str:
            return (
                f"{e.frequency_hz:.0f} Hz, {e.strength:.2f}, {e.pixels} px"  # type: ignore[attr-defined]
                + (" **yes**" if e.detected else "")  # type: ignore[attr-defined]
            )

        print(
            f"| {name} | {x1 - x0}×{y1 - y0} | {len(history)} | {2 * rev:g} "
            f"| {edges(edge)} | {edges(edge_long)} | {spec(short)} | {spec(long)} |"
        )


#: Crossing speeds (m/s) of the motion table, and the seeds each case is recorded with.
MOTION_SPEEDS = (0.0, 1.0, 2.0, 3.0, 6.0, 8.0, 10.0, 15.0)
MOTION_SEEDS = (1, 2, 3, 4, 5)


def window_events(r: object, t0: int, length: int) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    """The events of ``[t0, t0 + length)`` inside the union of the labelled boxes of the
    frames in that span (a dataset window's box), and that box."""
    lab, ts = r.labels, np.asarray(r.timestamps_us)  # type: ignore[attr-defined]
    span = (ts >= t0) & (ts < t0 + length)
    x0 = int(np.floor(np.nanmin(lab["x0"][span])))
    y0 = int(np.floor(np.nanmin(lab["y0"][span])))
    x1 = int(np.ceil(np.nanmax(lab["x1"][span])))
    y1 = int(np.ceil(np.nanmax(lab["y1"][span])))
    ev = r.recording.events  # type: ignore[attr-defined]
    t = ev["t"].astype(np.int64)
    sel = (t >= t0) & (t < t0 + length)
    sel &= (ev["x"] >= x0) & (ev["x"] < x1) & (ev["y"] >= y0) & (ev["y"] < y1)
    return ev[sel], (x0, y0, x1 - x0, y1 - y0)


def bird_range(drone_range: float) -> float:
    """The range at which the bird's box is as wide as the Phantom's at ``drone_range``."""
    drone = ObjectSpec("phantom", 0.29, at(drone_range), rate_hz=120.0, heading_deg=30.0)
    probe = ObjectSpec("bird", 0.6, at(50.0), rate_hz=6.0, heading_deg=30.0, color=(0.1, 0.1, 0.1))
    w_drone = box_width(record(scene(drone, 0.02), sensor=(240, 180), seed=1).labels)
    w_bird = box_width(record(scene(probe, 0.02), sensor=(240, 180), seed=1).labels)
    return 50.0 * w_bird / w_drone


def motion(light: float, vertical: float, rev: float, threshold: float | None) -> None:
    """Drone and bird crossing at each speed: both estimators, plain and motion-compensated."""
    import dataclasses

    from uavsnn.sim import SCENE_PARAMS

    params = SCENE_PARAMS
    if threshold is not None:
        params = dataclasses.replace(params, threshold_on=threshold, threshold_off=threshold)
    t0, length = 100_000, 50_000
    b_range = bird_range(50.0)
    print(
        f"light {light:g}; Phantom at 50 m (rotors {rev:g} rev/s, blade pass {2 * rev:g} Hz), "
        "a bird "
        f"(0.6 m, wing beat 6 Hz) at {b_range:.1f} m; crossing horizontally"
        + (f" and {vertical:g} times as fast vertically" if vertical else "")
        + f"; window [{t0 // 1000}, {(t0 + length) // 1000}) ms, seeds {MOTION_SEEDS}; "
        f"contrast threshold {params.threshold_on:g}\n"
    )
    print(
        "Each estimator's cell: **detections within 5 % of the blade pass** / detections / "
        "runs (the frequencies detected). Events from the rotor: the box's events less those "
        "of the same recording with the rotors still (mean). Last column: runs with a "
        "compensated detection not on a harmonic of the motion (motion_line).\n"
    )
    print(
        "| object | m/s | px/s (label) | px/s (estimated, median) | box (px) | events "
        "| events from the rotor | edges | spectrum | edges, compensated "
        "| spectrum, compensated | compensated, not a motion line |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for kind, range_m in (("phantom", 50.0), ("bird", b_range)):
        for speed in MOTION_SPEEDS:
            runs = []
            for seed in MOTION_SEEDS:
                v = (speed, vertical * speed, 0.0)
                path = PathSpec("linear", (-v[0] * 0.125, -v[1] * 0.125, range_m), velocity=v)
                if kind == "phantom":
                    obj = ObjectSpec(kind, 0.29, path, rate_hz=rev, heading_deg=30.0)
                else:
                    obj = ObjectSpec(
                        kind, 0.6, path, rate_hz=6.0, heading_deg=30.0, color=(0.1, 0.1, 0.1)
                    )
                r = record(scene(obj, 0.2, light), sensor=(240, 180), seed=seed, params=params)
                ev, box = window_events(r, t0, length)
                still = 0
                if kind == "phantom":
                    obj0 = dataclasses.replace(obj, rate_hz=0.0)
                    spec0 = scene(obj0, 0.2, light)
                    r0 = record(spec0, sensor=(240, 180), seed=seed, params=params)
                    still = len(window_events(r0, t0, length)[0])
                lab, ts = r.labels, np.asarray(r.timestamps_us)
                span = np.flatnonzero((ts >= t0) & (ts < t0 + length))
                cx = (lab["x0"] + lab["x1"]) / 2
                cy = (lab["y0"] + lab["y1"]) / 2
                dt = (ts[span[-1]] - ts[span[0]]) * 1e-6
                true = np.hypot(cx[span[-1]] - cx[span[0]], cy[span[-1]] - cy[span[0]]) / dt
                comp = compensated_rotor(ev, box)
                runs.append(
                    (
                        true,
                        comp.motion.speed,
                        box,
                        len(ev),
                        rotor_signature(ev, box),
                        len(ev) - still if kind == "phantom" else float("nan"),
                        rotor_spectrum(ev, box),
                        comp.edges,
                        comp.spectrum,
                        any(
                            e.detected and not motion_line(e.frequency_hz, comp.motion)
                            for e in (comp.edges, comp.spectrum)
                        ),
                    )
                )

            def cell(ests: list, blade: float) -> str:
                found = [e for e in ests if e.detected]
                near = sum(abs(e.frequency_hz - blade) <= 0.05 * blade for e in found)
                if not found:
                    return f"0/{len(ests)}"
                f = ",".join(f"{e.frequency_hz:.0f}" for e in found)
                return f"**{near}**/{len(found)}/{len(ests)} ({f})"

            w = int(np.median([r[2][2] for r in runs]))
            h = int(np.median([r[2][3] for r in runs]))
            print(
                f"| {kind} | {speed:g} | {np.median([r[0] for r in runs]):.0f} "
                f"| {np.median([r[1] for r in runs]):.0f} | {w}×{h} "
                f"| {int(np.median([r[3] for r in runs]))} "
                + (f"| {np.mean([r[5] for r in runs]):.0f} | " if kind == "phantom" else "| – | ")
                + " | ".join(cell([r[k] for r in runs], 2 * rev) for k in (4, 6, 7, 8))
                + f" | {sum(r[9] for r in runs)}/{len(runs)} |"
            )


def labelled_split(root: Path, split: str) -> tuple[Any, dict[int, float], int]:
    """A dataset's split (with raw events), each recording's light level (from the
    manifest) and the raw events' length L before a window."""
    from uavsnn.dataset.format import load

    d = load(root, split)
    if d.raw is None:
        raise SystemExit(f"{root} has no raw events (format 2 needed)")
    light = {int(r["id"]): float(r["lighting"]) for r in d.manifest["recordings"]}
    return d, light, int(d.raw.before_us)


def box_speed(d: Any, t0s: np.ndarray, boxes: np.ndarray, i: int) -> float:
    """Window ``i``'s box speed (px/s): its centre's displacement to the next window of the
    recording; nan without a next window (or a box there)."""
    later = np.flatnonzero((d.recording == d.recording[i]) & (t0s > t0s[i]))
    if len(later):
        j = later[np.argmin(t0s[later])]
        if np.isfinite(boxes[j]).all():
            b = boxes[i]
            shift = np.hypot(*((boxes[j, :2] + boxes[j, 2:]) - (b[:2] + b[2:])) / 2)
            return float(shift / ((t0s[j] - t0s[i]) * 1e-6))
    return float("nan")


def box_events(
    d: Any, i: int, b: np.ndarray, start: int, stop: int
) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    """Window ``i``'s raw events of ``[start, stop)`` in its labelled box ``b`` (x0, y0, x1,
    y1, widened to whole pixels, at least one), and that box as (x, y, width, height)."""
    x0, y0 = int(np.floor(b[0])), int(np.floor(b[1]))
    x1, y1 = max(int(np.ceil(b[2])), x0 + 1), max(int(np.ceil(b[3])), y0 + 1)
    raw = d.raw.window(int(i))
    t = raw["t"].astype(np.int64)
    ev = raw[(t >= start) & (t < stop)]
    ev = ev[(ev["x"] >= x0) & (ev["x"] < x1) & (ev["y"] >= y0) & (ev["y"] < y1)]
    return ev, (x0, y0, x1 - x0, y1 - y0)


def dataset(root: Path, split: str) -> None:
    """The UAV windows of a dataset (see the module's documentation)."""
    d, light, length = labelled_split(root, split)
    t0s = np.asarray(d.windows.t0, dtype=np.int64)
    boxes = np.asarray(d.box, dtype=np.float64)
    rows = []
    for i in np.flatnonzero(np.asarray(d.label, dtype=bool)):
        b = boxes[i]
        if not np.isfinite(b).all():
            continue
        speed = box_speed(d, t0s, boxes, int(i))
        ev, box = box_events(d, int(i), b, t0s[i] - length, t0s[i] + length)
        window = ev[ev["t"].astype(np.int64) >= t0s[i]]
        rows.append(
            (
                light[int(d.recording[i])],
                speed,
                len(ev) / (box[2] * box[3]),
                rotor_signature(window, box).detected,
                rotor_spectrum(ev, box),
                rotor_signature(ev, box).detected,
            )
        )
    print(f"{root} {split}: {len(rows)} UAV windows with a labelled box, L = {length} µs")
    print(
        "| light | box speed (px/s) | windows | events per box pixel, 100 ms (median) "
        "| edges detected, 50 ms | edges detected, 100 ms | spectrum detected "
        "| spectrum prominence >= 4 |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for lo, hi in ((0.0, 0.1), (0.1, 0.3), (0.3, 1.01)):
        for slo, shi in ((0.0, 20.0), (20.0, 100.0), (100.0, np.inf)):
            sel = [r for r in rows if lo <= r[0] < hi and np.isfinite(r[1]) and slo <= r[1] < shi]
            if not sel:
                continue
            print(
                f"| {lo:g}–{min(hi, 1.0):g} | {slo:g}–{shi:g} | {len(sel)} "
                f"| {np.median([r[2] for r in sel]):.2f} | {sum(r[3] for r in sel)} "
                f"| {sum(r[5] for r in sel)} "
                f"| {sum(r[4].detected for r in sel)} "
                f"| {sum(r[4].prominence >= 4 for r in sel)} |"
            )
    unknown = sum(not np.isfinite(r[1]) for r in rows)
    print(f"(and {unknown} windows without a next window to measure the speed on)")


#: The dvs domain's frame rate: compensated fast objects show a line at it (rendering, not
#: physics), so the dataset table counts lines within 5 % of it (and of half of it) apart.
RENDER_FPS = 500.0


def dataset_motion(root: Path, split: str, limit: int | None) -> None:
    """Every labelled window of a dataset's split: both estimators, plain and compensated."""
    import time

    d, light, length = labelled_split(root, split)
    t0s = np.asarray(d.windows.t0, dtype=np.int64)
    boxes = np.asarray(d.box, dtype=np.float64)
    todo = [i for i in range(len(t0s)) if np.isfinite(boxes[i]).all()]
    if limit is not None:
        todo = todo[:limit]
    rows = []
    start = time.process_time()
    estimate_s = 0.0
    for i in todo:
        speed = box_speed(d, t0s, boxes, i)
        ev, box = box_events(d, i, boxes[i], t0s[i], t0s[i] + length)
        tick = time.process_time()
        comp = compensated_rotor(ev, box)
        estimate_s += time.process_time() - tick
        lines = []
        for e in (comp.edges, comp.spectrum):
            f = e.frequency_hz
            frame = any(abs(f - m * RENDER_FPS) <= 0.05 * m * RENDER_FPS for m in (0.5, 1.0))
            lines.append((e.detected, motion_line(f, comp.motion), frame, f))
        rows.append(
            {
                "cls": str(d.cls[i]),
                "uav": bool(d.label[i]),
                "light": light[int(d.recording[i])],
                "speed": speed,
                "est": comp.motion.speed,
                "events": len(ev),
                "plain": rotor_signature(ev, box).detected or rotor_spectrum(ev, box).detected,
                "comp": comp.detected,
                "clean": any(det and not ml and not fr for det, ml, fr, _ in lines),
                "no_motion_line": any(det and not ml for det, ml, _, _ in lines),
                "freqs": [f for det, ml, fr, f in lines if det and not ml and not fr],
                "rec": int(d.recording[i]),
            }
        )
    took = time.process_time() - start
    print(
        f"{root.name} {split}: {len(rows)} windows with a labelled box, L = {length} µs; "
        f"CPU {took:.0f} s in all, {estimate_s:.0f} s in compensated_rotor"
    )
    print(
        "\n**plain**: either estimator on the window's events in the box; **compensated**: "
        "either on the events moved to the object's frame; **− motion lines**: a compensated "
        "line at a harmonic of |vx| or |vy| (motion_line) left out; **− frame lines**: also "
        f"one within 5 % of {RENDER_FPS:g} or {RENDER_FPS / 2:g} Hz left out.\n"
    )
    print(
        "| class | windows (recordings) | plain | compensated | − motion lines "
        "| − frame lines | plain or the last |"
    )
    print("|---|---|---|---|---|---|---|")
    for cls in sorted({r["cls"] for r in rows}, key=lambda c: (c != "drone", c)):
        sel = [r for r in rows if r["cls"] == cls]

        def count(key: str, sel: list = sel) -> str:
            hits = [r for r in sel if r[key]]
            return f"{len(hits)} ({len({r['rec'] for r in hits})})"

        for r in sel:
            r["either"] = r["plain"] or r["clean"]
        print(
            f"| {cls} | {len(sel)} ({len({r['rec'] for r in sel})}) | {count('plain')} "
            f"| {count('comp')} | {count('no_motion_line')} | {count('clean')} "
            f"| {count('either')} |"
        )
    print("\nUAV windows by light and labelled box speed (px/s):\n")
    print(
        "| light | speed | windows | estimated speed (median) | plain | compensated "
        "| − motion lines | − frame lines | plain or the last |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    uav = [r for r in rows if r["uav"]]
    for lo, hi in ((0.0, 0.1), (0.1, 0.3), (0.3, 1.01)):
        for slo, shi in ((0.0, 20.0), (20.0, 100.0), (100.0, np.inf), (np.nan, np.nan)):
            if np.isnan(slo):
                sel = [r for r in uav if lo <= r["light"] < hi and not np.isfinite(r["speed"])]
                label = "unknown"
            else:
                sel = [
                    r
                    for r in uav
                    if lo <= r["light"] < hi and np.isfinite(r["speed"]) and slo <= r["speed"] < shi
                ]
                label = f"{slo:g}–{shi:g}"
            if not sel:
                continue
            print(
                f"| {lo:g}–{min(hi, 1.0):g} | {label} | {len(sel)} "
                f"| {np.median([r['est'] for r in sel]):.0f} | {sum(r['plain'] for r in sel)} "
                f"| {sum(r['comp'] for r in sel)} | {sum(r['no_motion_line'] for r in sel)} "
                f"| {sum(r['clean'] for r in sel)} | {sum(r['either'] for r in sel)} |"
            )
    found = sorted(f for r in uav for f in r["freqs"])
    if found:
        print(f"\nUAV lines left (Hz): {', '.join(f'{f:.0f}' for f in found)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--png", type=Path, default=None)
    ap.add_argument("--duration", type=float, default=0.6)
    ap.add_argument("--factors", action="store_true", help="the factor table instead")
    ap.add_argument("--dataset", type=Path, default=None, help="a dataset's UAV windows instead")
    ap.add_argument("--split", default="test")
    ap.add_argument("--motion", action="store_true", help="the motion table instead")
    ap.add_argument("--light", type=float, default=1.0, help="--motion's light level")
    ap.add_argument("--vertical", type=float, default=0.0, help="--motion's vy / vx")
    ap.add_argument("--rev", type=float, default=120.0, help="--motion's rotor rev/s")
    ap.add_argument(
        "--dvs-threshold", type=float, default=None, help="--motion: the contrast threshold"
    )
    ap.add_argument("--limit", type=int, default=None, help="--dataset --motion: first N windows")
    ap.add_argument(
        "--samples-per-pass",
        type=int,
        default=SAMPLES_PER_PASS,
        help="sub-frame samples per blade passage or wing beat (the spectra)",
    )
    args = ap.parse_args()
    spp = args.samples_per_pass
    if args.dataset is not None and args.motion:
        dataset_motion(args.dataset, args.split, args.limit)
        return
    if args.motion:
        motion(args.light, args.vertical, args.rev, args.dvs_threshold)
        return
    if args.dataset is not None:
        dataset(args.dataset, args.split)
        return
    if args.factors:
        factors()
        return
    drone = ObjectSpec("phantom", 0.29, at(50.0), rate_hz=120.0, heading_deg=30.0)
    d = record(scene(drone, args.duration), sensor=(240, 180), seed=1, samples_per_pass=spp)
    width = box_width(d.labels)
    # The bird's range for the same box width: boxes scale as 1 / range.
    probe = ObjectSpec("bird", 0.6, at(50.0), rate_hz=6.0, heading_deg=30.0, color=(0.1, 0.1, 0.1))
    b50 = record(scene(probe, 0.02), sensor=(240, 180), seed=1)
    bird_range = 50.0 * box_width(b50.labels) / width
    bird = ObjectSpec(
        "bird", 0.6, at(bird_range), rate_hz=6.0, heading_deg=30.0, color=(0.1, 0.1, 0.1)
    )
    b = record(scene(bird, args.duration), sensor=(240, 180), seed=1, samples_per_pass=spp)
    print(
        f"Drone: Phantom at 50 m, box {width:.1f} px wide, rotors 120 rev/s (blade pass 240 Hz). "
        f"Bird: 0.6 m span at {bird_range:.1f} m, box {box_width(b.labels):.1f} px, wing beat "
        f"6 Hz. {spp} sub-frame samples per passage or beat.\n"
    )
    print(
        "| | events | strongest per-pixel line Hz (>= 20 Hz) | power at 240 Hz / median "
        "| strongest line off 240 Hz's harmonics (Hz: power / median) |"
    )
    print("|---|---:|---:|---:|---:|")
    curves = []
    for name, r in (("drone (Phantom, 50 m)", d), (f"bird ({bird_range:.0f} m)", b)):
        lab = r.labels
        box = (
            float(np.nanmin(lab["x0"])),
            float(np.nanmin(lab["y0"])),
            float(np.nanmax(lab["x1"])),
            float(np.nanmax(lab["y1"])),
        )
        ev = r.recording.events
        f, p = pixel_rate_spectrum(ev, box=box, start_us=20_000, end_us=int(r.timestamps_us[-1]))
        peak = dominant_frequency(f, p, low_hz=20.0)
        near = (f > 235) & (f < 245)
        med = float(np.median(p[(f >= 20) & (f <= 2000)])) or float("nan")
        print(
            f"| {name} | {len(ev)} | {peak:.1f} | {float(p[near].max()) / med:.1f} "
            f"| {off_harmonics(f, p, 240.0, med)} |"
        )
        curves.append((name, f, p))
    if args.png is not None:
        plot_spectra(
            curves,
            str(args.png),
            title="mean per-pixel event-rate spectrum in the box (240 Hz blade pass marked)",
            max_hz=1000.0,
            marks=(240.0,),
        )
        print(f"\nwrote {args.png}")


if __name__ == "__main__":
    main()
