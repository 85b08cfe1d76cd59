"""The event-driven engine against the dense reference, on the same windows, in one run.

For each density (0.1 %, 1 %, 5 % of the pixels active per 50 ms window, 240x180 by default),
runs the same synthetic windows (``uavsnn.bench.synthetic_windows``: short moving edges plus
noise) through

- the engine, one window at a time (``Network.run_window``) and in a batch (``Network.infer``,
  one thread), and
- the dense frame-by-frame NumPy reference ``tests/reference/dense.py`` (``run_window``),

checks that they give the same spikes, and reports the CPU time per input event of each and
the speed ratio. CPU time (``time.thread_time``/``process_time``) is used so that other work on a
shared machine does not inflate the figures.

    python benches/python/bench_engine.py [--windows 3] [--size 240x180] [--dense PATH] [--json]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import time
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from uavsnn.bench import synthetic_windows
from uavsnn.network import LAYERS, Network

DENSITIES = (0.001, 0.01, 0.05)
LENGTH_US = 50_000
DEFAULT_DENSE = Path(__file__).resolve().parents[2] / "tests" / "reference" / "dense.py"


def load_dense(path: Path) -> ModuleType | None:
    """The dense reference module, imported from its file (it is a test helper, not a package)."""
    if not path.is_file():
        return None
    spec = importlib.util.spec_from_file_location("uavsnn_dense_reference", path)
    if spec is None or spec.loader is None:
        return None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    write_bytecode, sys.dont_write_bytecode = sys.dont_write_bytecode, True  # leave no cache
    try:
        spec.loader.exec_module(module)
    finally:
        sys.dont_write_bytecode = write_bytecode
    return module


def cpu_seconds(fn: Any, *args: Any, repeat: int = 1) -> tuple[float, Any]:
    """Best process CPU time of ``repeat`` calls (the engine releases the GIL but runs on the
    calling thread here), and the last result."""
    best, out = float("inf"), None
    for _ in range(repeat):
        start = time.process_time()
        out = fn(*args)
        best = min(best, time.process_time() - start)
    return best, out


def bench(
    density: float, width: int, height: int, windows: int, dense: ModuleType | None
) -> dict[str, Any]:
    net = Network({"width": width, "height": height}, seed=1)
    batch = synthetic_windows(width, height, density, windows, seed=int(density * 1e6))
    parts = [batch.spikes(i) for i in range(windows)]
    events = len(batch.t)

    def engine_each() -> list[Any]:
        return [net.run_window(t, x, y, i * LENGTH_US) for i, (t, x, y) in enumerate(parts)]

    engine_s, traces = cpu_seconds(engine_each, repeat=5)
    # The batch call runs on a one-thread pool so that CPU time is one core's time.
    batch_s, result = cpu_seconds(lambda: net.infer(batch, threads=1), repeat=5)
    row: dict[str, Any] = {
        "density_percent": density * 100,
        "sensor": f"{width}x{height}",
        "windows": windows,
        "events": events,
        "spikes_per_window": {
            layer: float(np.mean([len(tr[layer]) for tr in traces])) for layer in LAYERS
        },
        "engine_ns_per_event": engine_s / events * 1e9,
        "engine_batch_ns_per_event": batch_s / events * 1e9,
        "detected_windows": int(result.detected.sum()),
    }
    if dense is not None:
        config, weights = (
            net.config,
            {layer: net.weights(layer) for layer in ("conv1", "conv2", "conv3")},
        )

        def dense_each() -> list[dict[str, Any]]:
            return [
                dense.run_window(config, weights, t, x, y, i * LENGTH_US)
                for i, (t, x, y) in enumerate(parts)
            ]

        dense_s, reference = cpu_seconds(dense_each)
        same = all(
            np.array_equal(ref[layer], tr[layer])
            for ref, tr in zip(reference, traces, strict=True)
            for layer in LAYERS
        )
        row.update(
            dense_ns_per_event=dense_s / events * 1e9,
            speedup=dense_s / engine_s,
            same_spikes=same,
        )
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=int, default=3, help="windows per density")
    parser.add_argument("--size", default="240x180", help="sensor WIDTHxHEIGHT")
    parser.add_argument("--dense", type=Path, default=DEFAULT_DENSE, help="dense reference file")
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))
    dense = load_dense(args.dense)
    rows = [bench(d, width, height, args.windows, dense) for d in DENSITIES]
    if args.json:
        print(json.dumps({"dense_reference": str(args.dense) if dense else None, "rows": rows}))
        return
    if dense is None:
        print(f"dense reference missing at {args.dense}: timing the engine only")
    for r in rows:
        line = (
            f"{r['sensor']} {r['density_percent']:g}%: "
            f"{r['events'] // r['windows']} events/window, "
            f"engine {r['engine_ns_per_event']:.0f} ns/event "
            f"(batch {r['engine_batch_ns_per_event']:.0f})"
        )
        if "dense_ns_per_event" in r:
            line += (
                f", dense {r['dense_ns_per_event']:.0f} ns/event, "
                f"engine {r['speedup']:.0f}x faster, same spikes: {r['same_spikes']}"
            )
        print(line)
        spikes = ", ".join(f"{k} {v:.1f}" for k, v in r["spikes_per_window"].items())
        print(f"    spikes/window: {spikes}")


if __name__ == "__main__":
    main()
