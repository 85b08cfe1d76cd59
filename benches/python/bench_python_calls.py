"""What a call from Python costs beside the work it asks of the engine, each figure against its
reference measured in the same run (so that a shared or throttled machine skews both alike):

1. ``Network.run_window`` per call, against the engine's own cost for the same windows
   (``Network.infer`` of all of them at once on one thread with every layer's spikes recorded,
   divided by the number of windows: the per-call costs amortised away). The ratio is the
   Python call's total over the engine's; 1 would be a free call.
2. ``Network.infer`` on batches of 20 windows at 1 % density, ``threads=2`` against
   ``threads=1``: the speed-up of a second thread on small batches.
3. ``uavsnn.filters.downsample`` against tonic's ``Downsample`` (``sensor_size``,
   ``target_size``) on the same events: the speed ratio (> 1: uavsnn faster). The two do not
   compute the same thing (uavsnn crops to the target's aspect and keeps the events in order;
   tonic scales both axes by their own factor), but both read and write every event.
4. ``Detector.push`` of one-event chunks, against the engine's own push of the same packed
   events (the detector's ``_inner``, a fresh one each): what the Python layer adds to each
   push of a stream fed in small chunks.

Each timing is the best of ``--repeats`` rounds, the rounds of a pair interleaved. Work is
counted (events, spikes, windows) and printed beside each time, and each result is checked
against its reference (spikes and detections equal, the same events kept), so that a ratio
never compares different work. Usage, from the repository root with the package built
(``maturin develop --release``):

    python benches/python/bench_python_calls.py [--recording FILE] [--repeats N] [--json]

``--recording`` defaults to ``../shared/data/dvs/prophesee_gen4_driving_evt3.raw`` when it
exists, else a synthetic 1280x720 recording of 2·10⁶ events.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn import EVENT_DTYPE, Recording
from uavsnn.filters import downsample
from uavsnn.network import Network
from uavsnn.windows import make_windows

DEFAULT_FILE = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "dvs"
DEFAULT_FILE = DEFAULT_FILE / "prophesee_gen4_driving_evt3.raw"


def best(fn: Callable[[], Any], repeats: int) -> float:
    """Best wall time of ``repeats`` calls, in seconds."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def paired(a: Callable[[], Any], b: Callable[[], Any], repeats: int) -> tuple[float, float]:
    """Best times of ``a`` and ``b``, their rounds interleaved."""
    ta, tb = [], []
    for _ in range(repeats):
        ta.append(best(a, 1))
        tb.append(best(b, 1))
    return min(ta), min(tb)


def noise_recording(n: int, size: tuple[int, int], density: float, seed: int) -> Recording:
    """Uniform events over ``size``; ``density`` of the pixels per 50 ms window."""
    rng = np.random.default_rng(seed)
    ev = np.zeros(n, dtype=EVENT_DTYPE)
    per_us = density * size[0] * size[1] / 50_000
    ev["t"] = np.cumsum(rng.exponential(1 / per_us, n)).astype(np.uint64)
    ev["x"] = rng.integers(0, size[0], n)
    ev["y"] = rng.integers(0, size[1], n)
    ev["p"] = rng.random(n) < 0.5
    return Recording(ev, size)


def run_window_cost(net: Network, repeats: int) -> dict[str, Any]:
    size = (int(net.config["width"]), int(net.config["height"]))
    out: dict[str, Any] = {}
    for density in (0.0, 0.01, 0.05):
        if density == 0:
            windows = make_windows(noise_recording(1, size, 0.01, 0), 50_000, 0.0)
            windows = windows.select(np.zeros(200, dtype=np.int64))
        else:
            n = int(density * size[0] * size[1] * 60)
            windows = make_windows(noise_recording(n, size, density, 1), 50_000, 0.0)
        # The per-window call: t, x, y of each window's spikes, its t0 and its N_in.
        calls = []
        for i in range(len(windows)):
            t, x, y = (np.ascontiguousarray(a) for a in windows.spikes(i))
            calls.append((t, x, y, int(windows.t0[i]), len(t)))
        if density == 0:
            calls = [(c[0][:0], c[1][:0], c[2][:0], c[3], 0) for c in calls]

        def python_calls(calls: list = calls) -> list:
            return [net.run_window(t, x, y, t0, n_in) for t, x, y, t0, n_in in calls]

        def engine(windows: Any = windows) -> Any:
            return net.infer(windows, threads=1, spikes=True)

        traces = python_calls()
        batch = engine()
        if density > 0:  # same work: the same detections, window by window
            got = sum(len(tr.detections) for tr in traces)
            assert got == len(batch.detections), (got, len(batch.detections))
        t_calls, t_engine = paired(python_calls, engine, repeats)
        n = len(calls)
        spikes = sum(
            sum(len(getattr(tr, f)) for f in ("conv1", "pool1", "conv2", "pool2", "conv3"))
            for tr in traces
        )
        out[f"density_{density}"] = {
            "windows": n,
            "input_spikes_per_window": float(np.mean([len(c[0]) for c in calls])),
            "spikes_out_per_window": spikes / n,
            "run_window_us_per_call": 1e6 * t_calls / n,
            "engine_us_per_window": 1e6 * t_engine / n,
            "ratio": t_calls / t_engine,
        }
    return out


def push_cost(net: Network, repeats: int, pushes: int = 5000) -> dict[str, Any]:
    from uavsnn.detector import Detector

    events = np.zeros(pushes, dtype=EVENT_DTYPE)
    events["t"] = np.arange(1, pushes + 1)
    chunks = [events[k : k + 1] for k in range(pushes)]
    packed = [c.tobytes() for c in chunks]

    def python_pushes() -> int:
        det = Detector(net, window_us=50_000, overlap=0.0, start_us=0)
        return sum(len(det.push(c)) for c in chunks)

    def engine_pushes() -> int:
        det = Detector(net, window_us=50_000, overlap=0.0, start_us=0)
        return sum(len(det._inner.push(raw)) for raw in packed)

    assert python_pushes() == 0 == engine_pushes()  # the same work: no detection either way
    t_python, t_engine = paired(python_pushes, engine_pushes, repeats)
    return {
        "pushes": pushes,
        "push_us_per_call": 1e6 * t_python / pushes,
        "engine_push_us_per_call": 1e6 * t_engine / pushes,
        "python_us_per_push": 1e6 * (t_python - t_engine) / pushes,
    }


def infer_threads(net: Network, repeats: int) -> dict[str, Any]:
    size = (int(net.config["width"]), int(net.config["height"]))
    n = int(0.01 * size[0] * size[1] * 20)
    windows = make_windows(noise_recording(n, size, 0.01, 2), 50_000, 0.0)
    batch = windows.select(np.arange(min(20, len(windows))))
    one = net.infer(batch, threads=1)
    two = net.infer(batch, threads=2)
    np.testing.assert_array_equal(one.detections, two.detections)

    def run(threads: int) -> Callable[[], Any]:
        return lambda: [net.infer(batch, threads=threads) for _ in range(20)]

    t1, t2 = paired(run(1), run(2), repeats)
    return {
        "windows_per_call": len(batch),
        "input_spikes_per_window": float(np.mean(np.diff(batch.offsets))),
        "threads_1_us_per_call": 1e6 * t1 / 20,
        "threads_2_us_per_call": 1e6 * t2 / 20,
        "speedup_of_2_threads": t1 / t2,
    }


def downsample_vs_tonic(rec: Recording, repeats: int) -> dict[str, Any]:
    from tonic.transforms import Downsample

    width, height = rec.sensor_size
    tonic_down = Downsample(sensor_size=(width, height, 2), target_size=(240, 180))
    ours = downsample(rec, (240, 180))
    theirs = tonic_down(rec.events)
    # The same events in, each read and written once by both.
    assert len(theirs) == len(rec.events)
    t_ours, t_tonic = paired(
        lambda: downsample(rec, (240, 180)), lambda: tonic_down(rec.events), repeats
    )
    return {
        "events_in": len(rec.events),
        "events_kept_by_uavsnn": len(ours.events),
        "sensor": [width, height],
        "uavsnn_ms": 1e3 * t_ours,
        "tonic_ms": 1e3 * t_tonic,
        "uavsnn_speed_over_tonic": t_tonic / t_ours,
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--recording", type=Path, default=None)
    p.add_argument("--repeats", type=int, default=7)
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    from uavsnn.io import read

    path = args.recording or (DEFAULT_FILE if DEFAULT_FILE.exists() else None)
    if path is not None:
        rec = read(path)
        source = str(path.name)
    else:
        rec = noise_recording(2_000_000, (1280, 720), 0.05, 3)
        source = "synthetic 1280x720, 2e6 events"
    net = Network(seed=0)
    result = {
        "run_window": run_window_cost(net, args.repeats),
        "infer_20_windows": infer_threads(net, args.repeats),
        "downsample": {"recording": source, **downsample_vs_tonic(rec, args.repeats)},
        "detector_push": push_cost(net, args.repeats),
    }
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    for density, r in result["run_window"].items():
        print(
            f"run_window, {density}: {r['run_window_us_per_call']:.1f} us/call against the "
            f"engine's {r['engine_us_per_window']:.1f} us/window (x{r['ratio']:.2f}; "
            f"{r['input_spikes_per_window']:.0f} input spikes, {r['spikes_out_per_window']:.0f} "
            f"spikes out per window, {r['windows']} windows)"
        )
    r = result["infer_20_windows"]
    print(
        f"infer, {r['windows_per_call']} windows of {r['input_spikes_per_window']:.0f} spikes: "
        f"threads=1 {r['threads_1_us_per_call']:.0f} us/call, threads=2 "
        f"{r['threads_2_us_per_call']:.0f} us/call (speed-up x{r['speedup_of_2_threads']:.2f})"
    )
    r = result["downsample"]
    print(
        f"downsample to 240x180, {r['recording']} ({r['events_in']:,} events, "
        f"{r['events_kept_by_uavsnn']:,} kept): uavsnn {r['uavsnn_ms']:.1f} ms, tonic "
        f"{r['tonic_ms']:.1f} ms (uavsnn x{r['uavsnn_speed_over_tonic']:.2f} tonic's speed)"
    )
    r = result["detector_push"]
    print(
        f"Detector.push of one event: {r['push_us_per_call']:.2f} us/call against the engine's "
        f"{r['engine_push_us_per_call']:.2f} us ({r['python_us_per_push']:.2f} us of Python a "
        f"push; {r['pushes']} pushes)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
