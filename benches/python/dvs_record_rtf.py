"""The "dvs" domain's real-time factor: scene seconds recorded per CPU second, on one core.

For sampled scenes (kinds ``uav`` and ``object``, seeds 0..n-1, 240x180 at 500 fps by
default), times on one thread (``RAYON_NUM_THREADS=1``, BLAS threads 1, CPU time from
``time.process_time``, so other jobs on a shared machine inflate it little):

- ``record``: ``uavsnn.scenes.record`` — frames rendered one at a time, fast parts (rotors,
  wings) re-rendered in patches between frames, everything streamed into the emulator;
- ``frames only``: ``render`` then ``DvsEmulator.process`` on whole frames, no sub-frame
  samples (the path before them), in the same run for a ratio.

The real-time factor is the scenes' own duration over the CPU time (above 1: faster than the
camera). Run it on a quiet machine for figures to quote. It also prints, per scene, the share of
pixels whose value changes from one frame to the next.

    python benches/python/dvs_record_rtf.py [--scenes 4] [--duration 0.5] [--size 240x180]
"""

from __future__ import annotations

import os

for _var in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from uavsnn.scenes import record, render, sample_spec  # noqa: E402
from uavsnn.sim import SCENE_PARAMS, DvsEmulator  # noqa: E402
from uavsnn.sim.checks import check_size  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=4)
    ap.add_argument("--duration", type=float, default=0.5)
    ap.add_argument("--size", default="240x180")
    args = ap.parse_args()
    size = check_size(args.size)
    shown = 0.0
    cpu = {"record": 0.0, "frames only": 0.0}
    events = {"record": 0, "frames only": 0}
    changed: list[float] = []
    for kind in ("uav", "object"):
        for seed in range(args.scenes):
            spec = sample_spec(
                "dvs", kind, np.random.default_rng(seed), size=size, duration_s=args.duration
            )
            shown += spec.n_frames / spec.fps
            start = time.process_time()
            out = record(spec, sensor=size, seed=seed)
            cpu["record"] += time.process_time() - start
            events["record"] += len(out.recording.events)
            start = time.process_time()
            frames, ts, _ = render(spec, seed=seed)
            ev = DvsEmulator(size, params=SCENE_PARAMS, seed=seed).process(frames, ts)
            cpu["frames only"] += time.process_time() - start
            events["frames only"] += len(ev)
            # What the emulator's shortcuts for unchanged pixels have to work with.
            changed.append(float(np.mean(frames[1:] != frames[:-1])))
            del frames
    print(f"{2 * args.scenes} scenes, {shown:.1f} s of scene at {size[0]}x{size[1]}, one thread")
    for name, c in cpu.items():
        print(
            f"{name:12s} CPU {c:6.2f} s  real-time factor {shown / c:5.2f}  events {events[name]}"
        )
    print(f"record / frames only CPU: {cpu['record'] / cpu['frames only']:.2f}x")
    print("pixels changing from frame to frame, per scene:", [round(c, 3) for c in changed])


if __name__ == "__main__":
    main()
