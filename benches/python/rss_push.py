"""Memory of one large push into ``uavsnn.Detector``: the peak resident memory a chunk of
``--events`` events takes beyond itself, pushed whole, against the same events pushed in
chunks of ``--chunk`` (the reference, measured in the same run).

Each way runs in a fresh process: the events (uniform over a 240×180 sensor, ``--seconds`` of
them, seed 0) are made first, then the peak resident set size is reset (Linux's
``/proc/self/clear_refs``) and read after the pushes and the flush (``VmHWM``); its growth
over the resident size before the pushes is printed in MiB and in bytes per event.
``--windows`` pushes through ``push_windows`` (the grouping by window and the copy kept for
the rotor signature included). The network has its seeded initial weights (seed 0). Not part
of the test suite.

    python benches/python/rss_push.py [--events 10000000] [--chunk 65536] [--windows] [--json]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from uavsnn import EVENT_DTYPE
from uavsnn.detector import Detector
from uavsnn.network import Network


def status_kib(field: str) -> int:
    """A field of ``/proc/self/status`` (``VmRSS``, ``VmHWM``) in KiB."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    raise RuntimeError(f"no {field} in /proc/self/status")


def one(events: int, chunk: int, seconds: float, windows: bool) -> dict[str, float]:
    """Push the events in chunks of ``chunk`` (``0``: whole) in this process."""
    rng = np.random.default_rng(0)
    ev = np.zeros(events, dtype=EVENT_DTYPE)
    ev["t"] = np.sort(rng.integers(0, int(seconds * 1e6), events))
    ev["x"] = rng.integers(0, 240, events)
    ev["y"] = rng.integers(0, 180, events)
    ev["p"] = rng.integers(0, 2, events)
    det = Detector(Network(seed=0))
    step = chunk or events
    # Reset the peak (Linux: clear_refs 5), so the events' own making does not hide it.
    Path("/proc/self/clear_refs").write_text("5")
    before = status_kib("VmRSS")
    start = time.perf_counter()
    found = 0
    for s in range(0, events, step):
        part = ev[s : s + step]
        found += len(det.push_windows(part)) if windows else len(det.push(part))
    found += len(det.flush_windows()) if windows else len(det.flush())
    growth = (status_kib("VmHWM") - before) * 1024
    return {
        "growth_mib": growth / 2**20,
        "bytes_per_event": growth / events,
        "seconds": time.perf_counter() - start,
        "found": found,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--events", type=float, default=1e7)
    parser.add_argument("--chunk", type=int, default=65_536, help="the reference's chunk")
    parser.add_argument("--seconds", type=float, default=20.0, help="event time spanned")
    parser.add_argument("--windows", action="store_true", help="push_windows, not push")
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--child", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    events = int(args.events)
    if not 1 <= events <= 10**9 or args.chunk < 1:
        parser.error("--events must be 1 to 10^9 and --chunk at least 1")
    if args.child is not None:
        print(json.dumps(one(events, args.child, args.seconds, args.windows)))
        return 0
    rows = {}
    for name, chunk in (("whole", 0), (f"chunks of {args.chunk}", args.chunk)):
        cmd = [sys.executable, __file__, "--events", str(events), "--child", str(chunk)]
        cmd += ["--seconds", str(args.seconds)] + (["--windows"] if args.windows else [])
        done = subprocess.run(cmd, capture_output=True, text=True, check=True)
        rows[name] = json.loads(done.stdout)
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    way = "push_windows" if args.windows else "push"
    print(f"{events} events through Detector.{way}, peak memory beyond the events:")
    for name, r in rows.items():
        print(
            f"  {name:>18}: {r['growth_mib']:7.1f} MiB ({r['bytes_per_event']:5.1f} B/event), "
            f"{r['seconds']:.2f} s, {r['found']} found"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
