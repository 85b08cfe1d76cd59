"""Resident memory of a long stream through ``uavsnn.Detector`` (issue 6: bounded memory).

Replays a synthetic moving-blob block (see ``bench_stream.py``: 4 s, a blob crossing from 0.5 s
on, over ``--noise-rate`` events/s of uniform noise) again and again, each copy shifted in time
after the previous one, until ``--events`` events (default 10^8) have gone through one
Detector, and prints the process's resident set size (``VmRSS`` from ``/proc/self/status``) at
regular intervals. Flat figures after the first windows mean bounded memory. The network has its
seeded initial weights (seed 0) unless ``--model`` names a trained one. Takes a minute or so on
two cores; not part of the test suite.

    python benches/python/rss_stream.py [--events 100000000] [--chunk 100000]
        [--noise-rate 40000] [--model MODEL] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_stream import moving_blob

from uavsnn.detector import Detector
from uavsnn.network import Network


def rss_mib() -> float:
    """This process's resident set size in MiB."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS in /proc/self/status")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--events", type=float, default=1e8)
    parser.add_argument("--chunk", type=int, default=100_000)
    parser.add_argument("--samples", type=int, default=20, help="RSS readings to print")
    parser.add_argument("--window-us", type=int, default=50_000)
    parser.add_argument("--overlap", type=float, default=0.5)
    parser.add_argument(
        "--noise-rate",
        type=float,
        default=40_000.0,
        help="background noise of the block, events/s (40,000: the blob is detected in every "
        "window it is in; from about 100,000 PENT silences an untrained network)",
    )
    parser.add_argument("--model", help="a trained model file (default: untrained, seed 0)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()

    block = moving_blob(seconds=4.0, seed=0, noise_rate=args.noise_rate).recording.events
    span = int(block["t"][-1]) - int(block["t"][0]) + 1
    net = Network.load(args.model) if args.model else Network(seed=0)
    det = Detector(net, window_us=args.window_us, overlap=args.overlap)
    total = int(args.events)
    every = max(total // args.samples, args.chunk)
    readings = [{"events": 0, "rss_mib": rss_mib(), "seconds": 0.0}]
    shifted = block.copy()
    start = time.perf_counter()
    done, copies, next_reading = 0, 0, every
    while done < total:
        shifted["t"] = block["t"] + np.uint64(copies * span)
        for i in range(0, len(shifted), args.chunk):
            chunk = shifted[i : i + min(args.chunk, total - done)]
            det.push(chunk)
            done += len(chunk)
            if done >= next_reading:
                readings.append(
                    {
                        "events": done,
                        "rss_mib": rss_mib(),
                        "seconds": time.perf_counter() - start,
                    }
                )
                next_reading += every
            if done >= total:
                break
        copies += 1
    det.flush()
    first = readings[1]["rss_mib"] if len(readings) > 1 else readings[0]["rss_mib"]
    summary = {
        "events": done,
        "model": args.model or "untrained (seed 0)",
        "block_events": len(block),
        "detections": det.detections_emitted,
        "windows_opened": det.windows_opened,
        "rss_first_mib": first,
        "rss_last_mib": readings[-1]["rss_mib"],
        "rss_max_mib": max(r["rss_mib"] for r in readings[1:]),
        "events_per_s": done / (time.perf_counter() - start),
        "readings": readings,
    }
    if args.json:
        json.dump(summary, sys.stdout, indent=2)
        print()
        return 0
    print(
        f"model: {summary['model']}; a {len(block):,}-event moving-blob block replayed in "
        f"chunks of {args.chunk:,}"
    )
    for r in readings:
        print(f"{r['events']:>13,} events  {r['seconds']:7.1f} s  RSS {r['rss_mib']:8.1f} MiB")
    print(
        f"RSS after the first interval {summary['rss_first_mib']:.1f} MiB, at the end "
        f"{summary['rss_last_mib']:.1f} MiB, max {summary['rss_max_mib']:.1f} MiB; "
        f"{summary['events_per_s']:,.0f} ev/s, {summary['windows_opened']:,} windows, "
        f"{summary['detections']:,} detections"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
