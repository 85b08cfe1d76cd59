"""The event-driven engine against the dense reference, on the same windows, in one run.

For each density (0.1 %, 1 %, 5 % of the pixels active per 50 ms window, 240x180 by default),
runs the same synthetic windows (short moving edges plus noise) through

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
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from uavsnn.network import LAYERS, Network

DENSITIES = (0.001, 0.01, 0.05)
LENGTH_US = 50_000
DEFAULT_DENSE = Path(__file__).resolve().parents[2] / "tests" / "reference" / "dense.py"


@dataclass(frozen=True)
class Batch:
    """The columns of ``uavsnn.windows.Windows`` that the engine reads."""

    sensor_size: tuple[int, int]
    length_us: int
    t0: np.ndarray
    offsets: np.ndarray
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    n_preceding: np.ndarray


def scene(
    rng: np.random.Generator, width: int, height: int, density: float, t0: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A window with ``density`` of the pixels active: 80 % on short edges sweeping sideways,
    20 % uniform noise; first spike per pixel, sorted by time (the Rust bench's scenes)."""
    target = max(1, round(width * height * density))
    seen = np.zeros((height, width), dtype=bool)
    spikes: list[tuple[int, int, int]] = []

    def add(t: int, x: int, y: int) -> None:
        if 0 <= x < width and 0 <= y < height and not seen[y, x]:
            seen[y, x] = True
            spikes.append((t, x, y))

    while len(spikes) < target * 4 // 5:
        x0, y0 = rng.uniform(0, width), rng.uniform(0, height)
        angle = rng.uniform(0, np.pi)
        length, sweep = int(rng.integers(5, 21)), int(rng.integers(1, 5))
        start, pace = int(rng.integers(0, LENGTH_US // 2)), int(rng.integers(50, 500))
        for s in range(sweep):
            for i in range(length):
                x = x0 + i * np.cos(angle) - s * np.sin(angle)
                y = y0 + i * np.sin(angle) + s * np.cos(angle)
                add(min(t0 + start + s * pace + i * 7, t0 + LENGTH_US - 1), int(x), int(y))
    while len(spikes) < target:
        add(
            t0 + int(rng.integers(0, LENGTH_US)),
            int(rng.integers(width)),
            int(rng.integers(height)),
        )
    spikes.sort(key=lambda s: s[0])
    t, x, y = (np.array(c) for c in zip(*spikes, strict=True))
    return t.astype(np.uint64), x.astype(np.uint16), y.astype(np.uint16)


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
    rng = np.random.default_rng(int(density * 1e6))
    net = Network({"width": width, "height": height}, seed=1)
    parts = [scene(rng, width, height, density, i * LENGTH_US) for i in range(windows)]
    events = sum(len(p[0]) for p in parts)

    def engine_each() -> list[Any]:
        return [net.run_window(t, x, y, i * LENGTH_US) for i, (t, x, y) in enumerate(parts)]

    lengths = [len(p[0]) for p in parts]
    batch = Batch(
        sensor_size=(width, height),
        length_us=LENGTH_US,
        t0=np.arange(windows, dtype=np.uint64) * LENGTH_US,
        offsets=np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
        t=np.concatenate([p[0] for p in parts]),
        x=np.concatenate([p[1] for p in parts]),
        y=np.concatenate([p[2] for p in parts]),
        n_preceding=np.zeros(windows, dtype=np.int64),
    )
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
