"""The DVS emulator's noise rates as delivered, each process alone and together.

A static grey frame (luma 130) on a 240x180 sensor for 10 s, through ``uavsnn.sim.emulate_dvs``
with no threshold spread, refractory period, hot pixels or low-pass, and the default leak
(``leak_rate_hz`` 0.1 ON events per pixel per second) and shot noise (``shot_noise_rate_hz`` 1
per pixel per second in the dark, ``shot_noise_bright_factor`` 0.25 at white, linear in the
luma between: 0.618 at 130): the leak alone, the shot noise alone, then both. Each process
alone delivers the rate asked; together the leak, which counts from the pixel's memory that a
noise event resets, fires less often (docs/simulation.md, "Noise events reset the pixel").

    python benches/python/dvs_noise_rates.py [--seconds 10] [--luma 130]
"""

from __future__ import annotations

import argparse

import numpy as np

from uavsnn.sim import DvsParams, emulate_dvs

WIDTH, HEIGHT = 240, 180


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=int, default=10)
    ap.add_argument("--luma", type=float, default=130.0)
    args = ap.parse_args(argv)
    frames = np.full((args.seconds + 1, HEIGHT, WIDTH), args.luma, dtype=np.float32)
    times = np.arange(args.seconds + 1, dtype=np.int64) * 1_000_000
    quiet = {"threshold_sigma": 0.0, "refractory_us": 0.0, "hot_pixel_fraction": 0.0}
    quiet["cutoff_hz"] = 0.0
    default = DvsParams()
    pixels = WIDTH * HEIGHT
    leak = default.leak_rate_hz * pixels
    bright = args.luma / 255.0
    shot_hz = default.shot_noise_rate_hz * (1 - (1 - default.shot_noise_bright_factor) * bright)
    shot = shot_hz * pixels
    print(f"static luma {args.luma:g} on {WIDTH}x{HEIGHT} for {args.seconds} s")
    print("| noise | asked (events/s) | delivered (events/s) | ON share |")
    print("|---|---:|---:|---:|")
    for name, params, asked in (
        ("leak alone", DvsParams(**quiet, shot_noise_rate_hz=0.0), leak),
        ("shot noise alone", DvsParams(**quiet, leak_rate_hz=0.0), shot),
        ("both", DvsParams(**quiet), leak + shot),
    ):
        ev = emulate_dvs(frames, times, params=params, seed=0)
        rate = len(ev) / args.seconds
        on = float(ev["p"].mean()) if len(ev) else float("nan")
        print(f"| {name} | {asked:,.0f} | {rate:,.0f} | {on:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
