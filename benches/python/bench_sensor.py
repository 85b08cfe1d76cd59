"""The dvs domain at each sensor size: rendering + DVS emulation against the time shown.

For each sensor (240×180, 346×260, 640×480, 1280×720), renders the same sampled UAV scenes
(seeds 0..n-1: the same scenes in angles on every sensor) at 500 fps and emulates them with
:class:`uavsnn.sim.DvsEmulator`, then reports CPU time per frame (render, emulation) and the
real-time factor: seconds of scene per CPU second of one core (the scene's own duration is the
reference, so the ratio needs no other machine), with the events made per second of scene.

CPU time is the process's, over all its threads, so the factor is per core. The figures are
only meaningful on a quiet machine: the script prints the load average before and after, and
the number of cores, beside them.

    python benches/python/bench_sensor.py [--scenes 3] [--seconds 0.5] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from typing import Any

import numpy as np

from uavsnn.dataset import SENSOR_SIZES
from uavsnn.scenes import render, sample_spec
from uavsnn.sim import DvsEmulator


def machine() -> dict[str, Any]:
    """The machine's state: cores and the 1, 5 and 15 minute load averages."""
    return {"cores": os.cpu_count(), "load_average": [round(v, 2) for v in os.getloadavg()]}


def bench(sensor: tuple[int, int], scenes: int, seconds: float, fps: float) -> dict[str, float]:
    """Render and emulate ``scenes`` UAV scenes of ``seconds`` on ``sensor``."""
    render_cpu, emulate_cpu, frames, shown, events = 0.0, 0.0, 0, 0.0, 0
    for seed in range(scenes):
        spec = sample_spec(
            "dvs", "uav", np.random.default_rng(seed), size=sensor, fps=fps, duration_s=seconds
        )
        start = time.process_time()
        images, ts, _ = render(spec, seed=seed)
        mid = time.process_time()
        made = DvsEmulator(sensor, seed=seed).process(images, ts)
        end = time.process_time()
        del images
        render_cpu += mid - start
        emulate_cpu += end - mid
        frames += spec.n_frames
        shown += spec.n_frames / spec.fps
        events += len(made)
    cpu = render_cpu + emulate_cpu
    return {
        "render_ms_per_frame": 1e3 * render_cpu / frames,
        "emulate_ms_per_frame": 1e3 * emulate_cpu / frames,
        "realtime_factor": shown / cpu,
        "events_per_s": events / shown,
        "frames": frames,
    }


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print its figures."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--scenes", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=0.5, help="scene length (0.5)")
    parser.add_argument("--fps", type=float, default=500.0, help="render rate (500)")
    parser.add_argument(
        "--sensor", action="append", default=None, help="WxH (repeatable; default: all four)"
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    sensors = (
        [tuple(int(v) for v in s.lower().split("x")) for s in args.sensor]
        if args.sensor
        else list(SENSOR_SIZES)
    )
    out: dict[str, Any] = {"machine_before": machine()}
    for w, h in sensors:
        out[f"{w}x{h}"] = bench((w, h), args.scenes, args.seconds, args.fps)
    out["machine_after"] = machine()
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    for name, r in out.items():
        print(
            f"{name:15s} "
            + "  ".join(
                f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in r.items()
            )
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
