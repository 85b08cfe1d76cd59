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
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from uavsnn.scenes import Background, Lighting, ObjectSpec, PathSpec, SceneSpec, record
from uavsnn.sim.checks import dominant_frequency, pixel_rate_spectrum, plot_spectra

FOCAL = 1200.0


def scene(obj: ObjectSpec, duration: float) -> SceneSpec:
    return SceneSpec(
        domain="dvs",
        width=240,
        height=180,
        fps=500.0,
        duration_s=duration,
        focal_px=FOCAL,
        background=Background("sky", cloud_cover=0.0),
        lighting=Lighting(level=1.0, noise=0.0),
        objects=(obj,),
        tilt_deg=30.0,
    )


def at(range_m: float) -> PathSpec:
    """Hovering on the optical axis (camera coordinates; the camera looks 30 degrees up),
    ``range_m`` away."""
    return PathSpec("hover", (0.0, 0.0, range_m))


def box_width(rec_labels: np.ndarray) -> float:
    return float(np.median(rec_labels["x1"] - rec_labels["x0"]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--png", type=Path, default=None)
    ap.add_argument("--duration", type=float, default=0.6)
    args = ap.parse_args()
    drone = ObjectSpec("phantom", 0.29, at(50.0), rate_hz=120.0, heading_deg=30.0)
    d = record(scene(drone, args.duration), sensor=(240, 180), seed=1)
    width = box_width(d.labels)
    # The bird's range for the same box width: boxes scale as 1 / range.
    probe = ObjectSpec("bird", 0.6, at(50.0), rate_hz=6.0, heading_deg=30.0, color=(0.1, 0.1, 0.1))
    b50 = record(scene(probe, 0.02), sensor=(240, 180), seed=1)
    bird_range = 50.0 * box_width(b50.labels) / width
    bird = ObjectSpec(
        "bird", 0.6, at(bird_range), rate_hz=6.0, heading_deg=30.0, color=(0.1, 0.1, 0.1)
    )
    b = record(scene(bird, args.duration), sensor=(240, 180), seed=1)
    print(
        f"Drone: Phantom at 50 m, box {width:.1f} px wide, rotors 120 rev/s (blade pass 240 Hz). "
        f"Bird: 0.6 m span at {bird_range:.1f} m, box {box_width(b.labels):.1f} px, wing beat "
        "6 Hz.\n"
    )
    print("| | events | strongest per-pixel line Hz (>= 20 Hz) | power at 240 Hz / median |")
    print("|---|---:|---:|---:|")
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
        print(f"| {name} | {len(ev)} | {peak:.1f} | {float(p[near].max()) / med:.1f} |")
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
