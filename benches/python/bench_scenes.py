"""How fast scenes render, against the time they show.

For each domain, renders scenes drawn by ``sample_spec`` (seeds 0..n-1, kind ``uav``) and
reports CPU time per frame and the real-time factor: seconds of scene rendered per CPU second
(above 1: faster than the camera it imitates). The reference is the scene's own duration, so
the ratio needs no other machine. Optionally times ``build_demo``.

    python benches/python/bench_scenes.py [--scenes 6] [--demo] [--json]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time

import numpy as np

from uavsnn.dataset import build_demo
from uavsnn.scenes import render, sample_spec

CASES = {
    "dvs 240x180 @500 fps": ("dvs", None),
    "sim 480x360 @30/60 fps": ("sim", (480, 360)),
    "sim 1920x1080 @30/60 fps": ("sim", (1920, 1080)),
}


def bench(domain: str, size: tuple[int, int] | None, scenes: int) -> dict[str, float]:
    """CPU time per frame and real-time factor over ``scenes`` sampled UAV scenes."""
    cpu, frames, shown = 0.0, 0, 0.0
    for seed in range(scenes):
        spec = sample_spec(
            domain,
            "uav",
            np.random.default_rng(seed),
            size=size,
            duration_s=1.0 if domain == "sim" else 0.5,
        )
        start = time.process_time()
        render(spec, seed=seed)
        cpu += time.process_time() - start
        frames += spec.n_frames
        shown += spec.n_frames / spec.fps
    return {"ms_per_frame": 1e3 * cpu / frames, "realtime_factor": shown / cpu, "frames": frames}


def main() -> None:
    """Run the benchmark and print its figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=6)
    parser.add_argument("--demo", action="store_true", help="also time build_demo")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    out: dict[str, dict[str, float]] = {}
    for name, (domain, size) in CASES.items():
        out[name] = bench(domain, size, args.scenes)
    if args.demo:
        with tempfile.TemporaryDirectory() as tmp:
            start, wall = time.process_time(), time.perf_counter()
            build_demo(f"{tmp}/demo", 0)
            out["build_demo"] = {
                "cpu_s": time.process_time() - start,
                "wall_s": time.perf_counter() - wall,
            }
    if args.json:
        print(json.dumps(out, indent=2))
        return
    for name, r in out.items():
        print(f"{name:28s} " + "  ".join(f"{k} {v:.3g}" for k, v in r.items()))


if __name__ == "__main__":
    main()
