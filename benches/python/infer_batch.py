"""``Network.infer`` on one batch of synthetic windows, as a Python caller runs it: the CPU and
wall time of the call, the best and median of ``--repeats`` calls, per window and per input
spike. It compares two builds of the package (run it under each, alternated), as the engine's
Criterion benchmarks compare two commits: what the binding adds around the engine (the copy of
the inputs, the parts Ctrl-C is checked between) shows here and not there.

    python benches/python/infer_batch.py [--windows 4000] [--density 0.01] [--size 240x180]
        [--threads 1] [--repeats 7] [--json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from typing import Any

from uavsnn.bench import synthetic_windows
from uavsnn.dataset.build import parse_sensor
from uavsnn.network import Network


def measure(
    windows: int, density: float, size: tuple[int, int], threads: int, repeats: int
) -> dict[str, Any]:
    net = Network({"width": size[0], "height": size[1]})
    batch = synthetic_windows(size[0], size[1], density, windows, seed=0)
    spikes = int(batch.t.size)
    cpu, wall = [], []
    for _ in range(repeats):
        c, w = time.process_time(), time.perf_counter()
        net.infer(batch, threads=threads)
        cpu.append(time.process_time() - c)
        wall.append(time.perf_counter() - w)
    out: dict[str, Any] = {"windows": windows, "input_spikes": spikes, "threads": threads}
    for name, times in (("cpu", cpu), ("wall", wall)):
        out[f"{name}_s_best"] = min(times)
        out[f"{name}_s_median"] = statistics.median(times)
        out[f"{name}_ns_per_spike_best"] = 1e9 * min(times) / max(spikes, 1)
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--windows", type=int, default=4000)
    p.add_argument("--density", type=float, default=0.01, help="active pixels per window")
    p.add_argument("--size", default="240x180", help="sensor WIDTHxHEIGHT")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--repeats", type=int, default=7)
    p.add_argument("--json", action="store_true")
    a = p.parse_args(argv)
    r = measure(a.windows, a.density, parse_sensor(a.size), a.threads, a.repeats)
    if a.json:
        print(json.dumps(r))
    else:
        print(
            f"{r['windows']} windows, {r['input_spikes']} input spikes, {r['threads']} thread(s): "
            f"CPU best {r['cpu_s_best']:.4f} s (median {r['cpu_s_median']:.4f}), wall best "
            f"{r['wall_s_best']:.4f} s (median {r['wall_s_median']:.4f}); "
            f"{r['cpu_ns_per_spike_best']:.1f} ns CPU per input spike"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
