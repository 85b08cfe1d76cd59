"""Windowing throughput against tonic, on the same events in the same run.

Compares, in events per second (best of ``--repeat`` runs, by wall clock; ``--clock cpu`` uses
the process's CPU time instead, summed over threads, which is steadier on a shared machine):

- uavsnn ``make_windows`` (sparse CSR windows: each pixel's first spike per window), and
  ``make_windows`` followed by ``Windows.frames()`` (dense time-embedded frames, float32
  ``(n, H, W)``): the like-for-like row against tonic's dense outputs;
- tonic's ``ToFrame`` (event-count frames per polarity, int16 ``(n, 2, H, W)``, the same bytes
  per window as ours), the dense transform closest to ours;
- tonic's ``ToTimesurface`` (a global time surface every ``dt`` = our window step, float64
  ``(n, 2, H, W)``, so both give one output per window).

Like for like, on purpose:

- Same events, same windows. ``ToFrame`` is given ``start_time`` and ``end_time`` so that its
  slices are exactly our windows ``[start + i·step, start + i·step + L)``, ``i < n`` (left to
  itself, ``include_incomplete`` stops at the first window reaching the last event, and drops
  the last ``L/step − 1`` of ours). ``ToTimesurface`` is tonic's ``to_timesurface_numpy`` (what
  the transform calls) with ``include_incomplete=True``: the transform's default drops the last
  step's events and surface. Both counts are printed next to ours.
- Same threads. tonic's NumPy path is single-threaded, so ours runs on ``--threads`` (default 1)
  rayon threads: per-core throughput. More threads help our wall clock, not CPU time.
- What the work is. ``ToFrame``, like ours, handles every event once per window that holds it
  (``L/step`` times). ``ToTimesurface`` does not: it writes each event once into a running
  per-pixel memory and pays per surface (an ``exp`` over ``2·W·H`` float64), whatever ``L``.
  So against it our ratio falls where windows overlap and steps are long (50 ms at 50 %:
  two windows per event, few surfaces); that is the transform, not a flaw of the run.

The stream is synthetic by default (80 % of events on a small object crossing a 240×180 sensor,
20 % uniform background, constant rate); ``--recording FILE`` uses a real one instead. Prints a
table and the ratios uavsnn / tonic; ``--json`` prints them as JSON.

Run: ``python benches/python/bench_windows.py --clock cpu`` (tonic must be installed:
``pip install tonic``).
"""

from __future__ import annotations

import argparse
import json
import os
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
    from tonic.functional import to_timesurface_numpy
    from tonic.transforms import ToFrame

    width, height = rec.sensor_size
    n = len(rec)
    step = window_step(length, overlap)
    events = rec.events.copy()  # tonic may write into its input (single-polarity sensors)
    windows = make_windows(rec, length, overlap)
    start = int(windows.t0[0])
    # Exactly our windows: n slices starting at start + i·step (see the module docstring).
    to_frame = ToFrame(
        sensor_size=(width, height, 2),
        time_window=length,
        overlap=length - step,
        include_incomplete=True,
        start_time=start,
        end_time=start + length + (len(windows) - 1) * step,
    )

    def to_surface(ev: np.ndarray) -> np.ndarray:
        # ToTimesurface(sensor_size, dt=step, tau=L/2), keeping the last step (see above).
        return to_timesurface_numpy(
            ev, (width, height, 2), dt=step, tau=length / 2, include_incomplete=True
        )

    outputs = {
        "uavsnn": len(windows),
        "tonic ToFrame": len(to_frame(events)),
        "tonic ToTimesurface": len(to_surface(events)),
    }
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
        "outputs": outputs,
        "clock": clock,
        "threads": int(os.environ.get("RAYON_NUM_THREADS", "0")),
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
    parser.add_argument(
        "--threads", type=int, default=1, help="rayon threads for uavsnn (0: one per core)"
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    # Read once, when rayon's pool first starts (nothing has run on it yet).
    if args.threads > 0:
        os.environ["RAYON_NUM_THREADS"] = str(args.threads)

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
    threads = args.threads or "all"
    print(
        f"{len(rec):,} events on {width}x{height} ({source}); {args.clock} clock, "
        f"uavsnn on {threads} thread(s)"
    )
    for r in results:
        print(
            f"\nL = {r['length_us'] // 1000} ms, overlap {r['overlap']:.0%}: {r['windows']} windows"
            f" (tonic: {r['outputs']['tonic ToFrame']} frames, "
            f"{r['outputs']['tonic ToTimesurface']} surfaces)"
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
