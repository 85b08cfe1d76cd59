"""Streaming benchmark of ``uavsnn.Detector`` (issue 6).

Measures, on synthetic moving-blob recordings (a small UAV-like blob crossing the sensor, with
uniform background noise; no rendered scenes are used):

1. processing latency per chunk, from ``push`` to its return, p50 and p99, for chunks of 1, 100
   and 10,000 events;
2. sustained events/s through ``Detector``, against the batch path (``make_windows`` +
   ``Network.infer`` with the "preceding" PENT estimate, one thread) on the same recording,
   measured in the same run: the ratio is the figure to quote;
3. event-time latency: from the blob's first event to its first detection (a detection whose
   box holds the blob at the detection's time), per recording.

Run from the repository root after ``maturin develop --release``::

    python benches/python/bench_stream.py [--model MODEL] [--seconds 4] [--json]

Without ``--model`` the network has its seeded initial weights (untrained), which is enough to
measure cost; detections, and so event-time latency, are only meaningful with a trained model.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass

import numpy as np

from uavsnn import EVENT_DTYPE, Recording
from uavsnn.detector import Detector
from uavsnn.network import Network
from uavsnn.windows import make_windows

SIZE = (240, 180)


@dataclass
class Synthetic:
    """A synthetic recording and where its blob is."""

    recording: Recording
    #: Time of the blob's first event (µs).
    enter_us: int
    #: When the blob's centre is at ``start`` (µs).
    origin_us: int
    #: Blob centre at ``origin_us`` (pixels), velocity (pixels/s) and radius (pixels).
    start: tuple[float, float]
    velocity: tuple[float, float]
    radius: float

    def centre(self, t_us: int) -> tuple[float, float]:
        """The blob's centre at time ``t_us``."""
        s = (t_us - self.origin_us) / 1e6
        return self.start[0] + self.velocity[0] * s, self.start[1] + self.velocity[1] * s


def moving_blob(
    *,
    seconds: float = 2.0,
    enter_s: float = 0.5,
    blob_rate: float = 150_000.0,
    noise_rate: float = 40_000.0,
    radius: float = 12.0,
    speed: float = 60.0,
    seed: int = 0,
    t_offset: int = 1_000_000,
) -> Synthetic:
    """A blob of ``radius`` px (a close drone: about 24 px across on 240x180) crossing the
    sensor at ``speed`` px/s from ``enter_s`` on, firing ``blob_rate`` events/s in its outer
    ring, over ``noise_rate`` events/s of uniform noise."""
    rng = np.random.default_rng(seed)
    w, h = SIZE
    duration = int(seconds * 1e6)
    n_noise = rng.poisson(noise_rate * seconds)
    t_noise = rng.integers(0, duration, n_noise)
    x_noise = rng.integers(0, w, n_noise)
    y_noise = rng.integers(0, h, n_noise)
    enter = int(enter_s * 1e6)
    n_blob = rng.poisson(blob_rate * (seconds - enter_s))
    t_blob = rng.integers(enter, duration, n_blob)
    x_start, y_start = 20.0, h * rng.uniform(0.3, 0.7)
    angle = rng.uniform(-0.3, 0.3)
    vx, vy = speed * np.cos(angle), speed * np.sin(angle)
    s = (t_blob - enter) / 1e6
    theta = rng.uniform(0, 2 * np.pi, n_blob)
    rr = radius * np.sqrt(rng.uniform(0.5, 1.0, n_blob))
    x_blob = np.clip(np.round(x_start + vx * s + rr * np.cos(theta)), 0, w - 1)
    y_blob = np.clip(np.round(y_start + vy * s + rr * np.sin(theta)), 0, h - 1)
    t = np.concatenate([t_noise, t_blob]) + t_offset
    order = np.argsort(t, kind="stable")
    events = np.zeros(len(t), dtype=EVENT_DTYPE)
    events["t"] = t[order]
    events["x"] = np.concatenate([x_noise, x_blob])[order]
    events["y"] = np.concatenate([y_noise, y_blob])[order]
    events["p"] = rng.integers(0, 2, len(t)).astype(bool)
    first_blob = int(t_blob.min()) + t_offset if n_blob else -1
    return Synthetic(
        Recording(events, SIZE), first_blob, enter + t_offset, (x_start, y_start), (vx, vy), radius
    )


def chunk_latency(net: Network, syn: Synthetic, size: int, args: argparse.Namespace) -> dict:
    """p50/p99 of push() wall time for chunks of ``size`` events, measured while the blob is in
    view (the detector is first warmed, unmeasured, up to 0.5 s after the blob entered)."""
    events = syn.recording.events
    det = Detector(net, window_us=args.window_us, overlap=args.overlap)
    warm = int(np.searchsorted(events["t"], syn.enter_us + 500_000))
    det.push(events[:warm])
    # The same stretch of events for every chunk size, so that per-event costs compare.
    n = min(len(events) - warm, 200_000)
    times = []
    for i in range(warm, warm + n - size + 1, size):
        chunk = events[i : i + size]
        start = time.perf_counter_ns()
        det.push(chunk)
        times.append(time.perf_counter_ns() - start)
    us = np.array(times) / 1e3
    return {
        "chunk": size,
        "pushes": len(us),
        "p50_us": float(np.percentile(us, 50)),
        "p99_us": float(np.percentile(us, 99)),
        "mean_us": float(us.mean()),
        # Costs are bursty (a crossing cascades through the layers), so the mean, not the
        # median, gives the cost per event.
        "ns_per_event_mean": float(us.mean() * 1e3 / size),
    }


def throughput(net: Network, rec: Recording, args: argparse.Namespace) -> dict:
    """Events/s through Detector (chunks of 10,000) against the batch path, same events."""
    det = Detector(net, window_us=args.window_us, overlap=args.overlap)
    start = time.perf_counter()
    for i in range(0, len(rec.events), 10_000):
        det.push(rec.events[i : i + 10_000])
    det.flush()
    stream_s = time.perf_counter() - start

    start = time.perf_counter()
    windows = make_windows(rec, args.window_us, args.overlap)
    net_batch = batch_network(net)
    net_batch.infer(windows, threads=1)
    batch_s = time.perf_counter() - start
    n = len(rec.events)
    return {
        "events": n,
        "stream_events_per_s": n / stream_s,
        "batch_events_per_s": n / batch_s,
        "stream_over_batch": batch_s / stream_s,
    }


def batch_network(net: Network) -> Network:
    """The same network with PENT's "preceding" estimate (what the stream uses)."""
    config = dict(net.config)
    config["pent"] = {**config["pent"], "estimate": "preceding"}
    out = Network(config)
    for layer in ("conv1", "conv2", "conv3"):
        out.set_weights(layer, net.weights(layer))
    return out


def event_time_latency(net: Network, syn: Synthetic, args: argparse.Namespace) -> float | None:
    """Milliseconds of event time from the blob's first event to the first detection whose box
    holds the blob (its centre at the detection's time, within the blob's radius)."""
    det = Detector(net, window_us=args.window_us, overlap=args.overlap)
    events = syn.recording.events
    for i in range(0, len(events), 100):
        for d in det.push(events[i : i + 100]):
            if d["t"] < syn.enter_us:
                continue
            cx, cy = syn.centre(int(d["t"]))
            r = syn.radius
            if d["x0"] - r <= cx < d["x1"] + r and d["y0"] - r <= cy < d["y1"] + r:
                return (int(d["t"]) - syn.enter_us) / 1e3
    return None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", help="a trained model file (default: untrained, seed 0)")
    parser.add_argument("--seconds", type=float, default=4.0, help="synthetic recording length")
    parser.add_argument("--window-us", type=int, default=50_000)
    parser.add_argument("--overlap", type=float, default=0.5)
    parser.add_argument("--recordings", type=int, default=5, help="for event-time latency")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()

    net = Network.load(args.model) if args.model else Network(seed=0)
    syn = moving_blob(seconds=args.seconds, seed=0)
    events = syn.recording.events
    results: dict = {
        "recording": {
            "events": len(events),
            "seconds": args.seconds,
            "window_us": args.window_us,
            "overlap": args.overlap,
            "model": args.model or "untrained (seed 0)",
        },
        "chunk_latency": [chunk_latency(net, syn, c, args) for c in (1, 100, 10_000)],
        "throughput": throughput(net, syn.recording, args),
    }
    latencies = [
        event_time_latency(net, moving_blob(seconds=args.seconds, seed=s), args)
        for s in range(1, args.recordings + 1)
    ]
    found = [v for v in latencies if v is not None]
    results["event_time_latency_ms"] = {
        "per_recording": latencies,
        "median": float(np.median(found)) if found else None,
        "detected": f"{len(found)}/{len(latencies)}",
    }
    if args.json:
        json.dump(results, sys.stdout, indent=2)
        print()
        return 0
    r = results["recording"]
    print(
        f"synthetic moving blob: {r['events']:,} events over {r['seconds']} s, "
        f"L={r['window_us']} µs, o={r['overlap']}, model: {r['model']}"
    )
    print("push latency per chunk:")
    for c in results["chunk_latency"]:
        print(
            f"  {c['chunk']:>6} events: p50 {c['p50_us']:9.1f} µs  p99 {c['p99_us']:9.1f} µs"
            f"  mean {c['mean_us']:9.1f} µs ({c['ns_per_event_mean']:.0f} ns/event, "
            f"{c['pushes']} pushes)"
        )
    tp = results["throughput"]
    print(
        f"sustained: stream {tp['stream_events_per_s']:,.0f} ev/s, batch "
        f"{tp['batch_events_per_s']:,.0f} ev/s (1 thread): stream/batch speed "
        f"{tp['stream_over_batch']:.2f}x"
    )
    lat = results["event_time_latency_ms"]
    print(
        f"event-time latency, first blob event -> first detection whose box holds the blob: "
        f"median {lat['median']} ms, detected {lat['detected']}, per recording "
        f"{lat['per_recording']}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
