"""Windowing throughput against tonic, on the same events in the same run.

Compares, in events per second (best of ``--repeat`` runs, by wall clock; ``--clock cpu`` uses
the process's CPU time instead, summed over threads, which is steadier on a shared machine):

- uavsnn ``make_windows`` (sparse windows: each pixel's first spike per window), and
  ``make_windows`` followed by ``Windows.frames()`` (dense time-embedded frames);
- tonic's ``ToFrame`` (event-count frames per polarity, ``time_window=L``, ``overlap=L·o``),
  the dense transform closest to ours;
- tonic's ``ToTimesurface`` (a global time surface every ``dt`` = our window step, so both give
  one output per window).

The stream is synthetic by default (80 % of events on a small object crossing a 240×180 sensor,
20 % uniform background, constant rate); ``--recording FILE`` uses a real one instead. Prints a
table and the ratios uavsnn / tonic; ``--json`` prints them as JSON.

Run: ``python benches/python/bench_windows.py`` (tonic must be installed: ``pip install tonic``).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from uavsnn import io
from uavsnn.events import EVENT_DTYPE, Recording
from uavsnn.windows import make_windows, window_step


def synthetic(width: int, height: int, n: int, duration_us: int, seed: int) -> Recording:
    """``n`` events over ``duration_us``: a drone-sized blob crossing the sensor, plus noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=np.int64) * duration_us // n
    phase = t / duration_us
    on_object = rng.random(n) < 0.8
    radius = max(width / 40, 3.0)
    cx = phase * (width - 1)
    cy = height / 2 + np.sin(phase * 12) * height / 4
    x = np.where(on_object, cx + rng.uniform(-radius, radius, n), rng.uniform(0, width, n))
    y = np.where(on_object, cy + rng.uniform(-radius, radius, n), rng.uniform(0, height, n))
    ev = np.zeros(n, EVENT_DTYPE)
    ev["t"] = t
    ev["x"] = np.clip(x, 0, width - 1)
    ev["y"] = np.clip(y, 0, height - 1)
    ev["p"] = rng.random(n) < 0.5
    return Recording(ev, (width, height), {"source": "synthetic"})


CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def best_time(fn: Callable[[], Any], repeat: int, clock: Callable[[], float]) -> float:
    """The fastest of ``repeat`` calls, in seconds (the least disturbed by other load)."""
    best = float("inf")
    for _ in range(repeat):
        start = clock()
        fn()
        best = min(best, clock() - start)
    return best


def run(
    rec: Recording, length: int, overlap: float, repeat: int, clock: str = "wall"
) -> dict[str, Any]:
    """Time every method on one configuration."""
    from tonic.transforms import ToFrame, ToTimesurface

    width, height = rec.sensor_size
    n = len(rec)
    step = window_step(length, overlap)
    events = rec.events.copy()  # tonic may write into its input (single-polarity sensors)
    to_frame = ToFrame(
        sensor_size=(width, height, 2),
        time_window=length,
        overlap=length - step,
        include_incomplete=True,
    )
    to_surface = ToTimesurface(sensor_size=(width, height, 2), dt=step, tau=length / 2)
    windows = make_windows(rec, length, overlap)
    tick = CLOCKS[clock]
    timings = {
        "uavsnn windows": best_time(lambda: make_windows(rec, length, overlap), repeat, tick),
        "uavsnn windows + frames": best_time(
            lambda: make_windows(rec, length, overlap).frames(), repeat, tick
        ),
        "tonic ToFrame": best_time(lambda: to_frame(events), repeat, tick),
        "tonic ToTimesurface": best_time(lambda: to_surface(events), repeat, tick),
    }
    rates = {name: n / seconds for name, seconds in timings.items()}
    return {
        "events": n,
        "sensor": [width, height],
        "length_us": length,
        "overlap": overlap,
        "windows": len(windows),
        "clock": clock,
        "events_per_s": rates,
        "ratio_vs_ToFrame": {
            name: rates[name] / rates["tonic ToFrame"]
            for name in rates
            if name.startswith("uavsnn")
        },
        "ratio_vs_ToTimesurface": {
            name: rates[name] / rates["tonic ToTimesurface"]
            for name in rates
            if name.startswith("uavsnn")
        },
    }


def main() -> None:
    """Parse arguments, run every configuration, print the results."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--events", type=int, default=500_000, help="synthetic events")
    parser.add_argument("--duration-ms", type=int, default=500, help="synthetic duration")
    parser.add_argument("--recording", help="use this recording instead of a synthetic one")
    parser.add_argument("--sensor-size", type=int, nargs=2, metavar=("W", "H"))
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="wall")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()

    if args.recording:
        size = tuple(args.sensor_size) if args.sensor_size else None
        rec = io.read(args.recording, sensor_size=size)
    else:
        rec = synthetic(240, 180, args.events, args.duration_ms * 1000, args.seed)
    configs = [(10_000, 0.0), (10_000, 0.5), (50_000, 0.5), (10_000, 0.9)]
    results = [run(rec, length, overlap, args.repeat, args.clock) for length, overlap in configs]
    if args.json:
        print(json.dumps(results, indent=2))
        return
    width, height = rec.sensor_size
    source = rec.metadata.get("source", rec.metadata.get("path"))
    print(f"{len(rec):,} events on {width}x{height} ({source}); {args.clock} clock")
    for r in results:
        print(
            f"\nL = {r['length_us'] // 1000} ms, overlap {r['overlap']:.0%}: {r['windows']} windows"
        )
        for name, rate in r["events_per_s"].items():
            print(f"  {name:<26} {rate / 1e6:10.2f} M events/s")
        for name in r["ratio_vs_ToFrame"]:
            print(
                f"  {name:<26} {r['ratio_vs_ToFrame'][name]:8.1f}x ToFrame, "
                f"{r['ratio_vs_ToTimesurface'][name]:8.1f}x ToTimesurface"
            )


if __name__ == "__main__":
    main()
