"""A rotor alone against the analytic blade pass, over the grid of rates and sizes.

For each rotation rate (rev/s) and rotor diameter (pixels), a two-blade rotor is rendered
face-on against a plain sky and emulated (``uavsnn.sim.checks.rotor_events``, the sensor of
the "dvs" scenes, ``uavsnn.sim.SCENE_PARAMS``), once with fast parts sampled between the
500 fps frames (``samples_per_pass`` per blade passage, jittered) and once from the frames
alone (the renderer before sub-frame samples). The peak of the mean per-pixel, per-polarity
event-rate spectrum (``pixel_rate_spectrum``) is compared with the blade pass, 2 x the rate:
``ok`` when within 2 %.

    python benches/python/rotor_grid.py [--duration 0.3] [--samples-per-pass 24]

Prints a Markdown table (docs/simulation.md keeps its output).
"""

from __future__ import annotations

import argparse

from uavsnn.scenes.renderer import SAMPLES_PER_PASS
from uavsnn.sim.checks import dominant_frequency, pixel_rate_spectrum, rotor_events

RATES = (50.0, 100.0, 150.0, 300.0, 450.0, 600.0)
SIZES = (2.0, 3.0, 4.0, 6.0, 10.0, 20.0, 40.0, 60.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=0.3)
    ap.add_argument("--samples-per-pass", type=int, default=SAMPLES_PER_PASS)
    ap.add_argument("--fps", type=float, default=500.0)
    args = ap.parse_args()
    print(
        f"Peak of the per-pixel event-rate spectrum (Hz) against the blade pass; frames at "
        f"{args.fps:g} fps, {args.duration:g} s per cell; sub-frame = "
        f"{args.samples_per_pass} samples per passage, frames only = none.\n"
    )
    print(
        "| rev/s | blade pass Hz | size px | events | sub-frame peak Hz | | frames only peak Hz | |"
    )
    print("|---:|---:|---:|---:|---:|---|---:|---|")
    passed = failed_old = total = 0
    for rate in RATES:
        bp = 2 * rate
        for size in SIZES:
            cells = []
            n_events = 0
            for spp in (args.samples_per_pass, 0):
                ev, _ = rotor_events(
                    rate, size, fps=args.fps, samples_per_pass=spp, duration_s=args.duration
                )
                if spp:
                    n_events = len(ev)
                peak = dominant_frequency(*pixel_rate_spectrum(ev))
                ok = abs(peak - bp) <= 0.02 * bp
                cells.append(f"{peak:.1f} | {'ok' if ok else 'miss'}")
                if spp:
                    passed += ok
                else:
                    failed_old += not ok
            total += 1
            print(
                f"| {rate:g} | {bp:g} | {size:g} | {n_events} | {cells[0]} | {cells[1]} |",
                flush=True,
            )
    print(
        f"\nsub-frame samples: {passed}/{total} cells within 2 %; frames only: "
        f"{failed_old}/{total} cells miss."
    )


if __name__ == "__main__":
    main()
