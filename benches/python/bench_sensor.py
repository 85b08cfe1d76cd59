"""The dvs domain at each sensor size: rendering + DVS emulation against the time shown.

For each sensor (240×180, 346×260, 640×480, 1280×720), renders the same sampled UAV scenes
(seeds 0..n-1: the same scenes in angles on every sensor) at 500 fps and emulates them as
:func:`uavsnn.scenes.record` does — frames one at a time with the fast parts' sub-frame patches,
through a :class:`uavsnn.sim.DvsEmulator` with :data:`uavsnn.sim.SCENE_PARAMS` — timing the
renderer and the emulator apart. It reports CPU time per frame (render, emulation) and the
real-time factor: seconds of scene per CPU second (the scene's own duration is the reference,
so the ratio needs no other machine), with the events made per second of scene.
``--frames-only`` measures the path before sub-frame samples instead (``render`` of whole
frames, then ``DvsEmulator.process`` with the default :class:`~uavsnn.sim.DvsParams`).

Everything runs on one thread (``RAYON_NUM_THREADS=1``, BLAS threads 1) and CPU time is the
process's (``time.process_time``), so the factor is per core and other jobs on a shared
machine inflate it little. The script prints the load average before and after, and the number
of cores, beside the figures.

    python benches/python/bench_sensor.py [--scenes 3] [--seconds 0.5] [--frames-only] [--json]
"""

from __future__ import annotations

import os

for _var in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from uavsnn.dataset import SENSOR_SIZES  # noqa: E402
from uavsnn.scenes import render, sample_spec  # noqa: E402
from uavsnn.scenes.renderer import frames  # noqa: E402
from uavsnn.sim import SCENE_PARAMS, DvsEmulator  # noqa: E402


def machine() -> dict[str, Any]:
    """The machine's state: cores and the 1, 5 and 15 minute load averages."""
    return {"cores": os.cpu_count(), "load_average": [round(v, 2) for v in os.getloadavg()]}


def _recorded(spec: Any, sensor: tuple[int, int], seed: int) -> tuple[float, float, int]:
    """``record``'s loop, timed: (render CPU, emulation CPU, events)."""
    emulator = DvsEmulator(sensor, params=SCENE_PARAMS, seed=seed)
    render_cpu, emulate_cpu, events = 0.0, 0.0, 0
    stream = frames(spec, seed=seed)
    while True:
        start = time.process_time()
        f = next(stream, None)
        mid = time.process_time()
        render_cpu += mid - start
        if f is None:
            return render_cpu, emulate_cpu, events
        events += len(emulator.process_frame(f.image, f.t_us, f.patches))
        emulate_cpu += time.process_time() - mid


def _frames_only(spec: Any, sensor: tuple[int, int], seed: int) -> tuple[float, float, int]:
    """Whole frames, then the default sensor: (render CPU, emulation CPU, events)."""
    start = time.process_time()
    images, ts, _ = render(spec, seed=seed)
    mid = time.process_time()
    made = DvsEmulator(sensor, seed=seed).process(images, ts)
    return mid - start, time.process_time() - mid, len(made)


def bench(
    sensor: tuple[int, int], scenes: int, seconds: float, fps: float, frames_only: bool = False
) -> dict[str, float]:
    """Render and emulate ``scenes`` UAV scenes of ``seconds`` on ``sensor``."""
    render_cpu, emulate_cpu, n_frames, shown, events = 0.0, 0.0, 0, 0.0, 0
    run = _frames_only if frames_only else _recorded
    for seed in range(scenes):
        spec = sample_spec(
            "dvs", "uav", np.random.default_rng(seed), size=sensor, fps=fps, duration_s=seconds
        )
        r, e, n = run(spec, sensor, seed)
        render_cpu += r
        emulate_cpu += e
        events += n
        n_frames += spec.n_frames
        shown += spec.n_frames / spec.fps
    cpu = render_cpu + emulate_cpu
    return {
        "render_ms_per_frame": 1e3 * render_cpu / n_frames,
        "emulate_ms_per_frame": 1e3 * emulate_cpu / n_frames,
        "realtime_factor": shown / cpu,
        "events_per_s": events / shown,
        "frames": n_frames,
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
    parser.add_argument(
        "--frames-only",
        action="store_true",
        help="whole frames and the default sensor, no sub-frame samples (the older path)",
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    sensors = (
        [tuple(int(v) for v in s.lower().split("x")) for s in args.sensor]
        if args.sensor
        else list(SENSOR_SIZES)
    )
    out: dict[str, Any] = {
        "path": "frames only" if args.frames_only else "record",
        "machine_before": machine(),
    }
    for w, h in sensors:
        out[f"{w}x{h}"] = bench((w, h), args.scenes, args.seconds, args.fps, args.frames_only)
    out["machine_after"] = machine()
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    for name, r in out.items():
        if not isinstance(r, dict):
            print(f"{name:15s} {r}")
            continue
        print(
            f"{name:15s} "
            + "  ".join(
                f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in r.items()
            )
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
