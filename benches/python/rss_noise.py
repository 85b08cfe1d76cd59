"""Peak memory of one noise level of the Table 3 sweep (``uavsnn.experiments.noise_level``),
its noisy windows made and run part by part against all at once.

Makes ``--windows`` test windows of a ``--sensor`` (uniform events on ``--density`` of the
pixels per window, half the windows labelled UAV with a box of ``--box`` pixels at the sensor's
centre), then runs one noise level (``--fraction`` of the pixels) through a network with its
seeded initial weights (seed 0) and its static-threshold twin, as ``uavsnn evaluate --noise``
does, in a fresh process for each of two budgets: ``--part-spikes`` (default
``NOISE_PART_SPIKES``) and one above every spike of the level (one part: how the level ran
before it was made in parts). Prints each run's parts, the growth of its peak resident set
(``VmHWM`` from ``/proc/self/status``) over its resident set before the level, its time, and
whether the two runs' points are equal. Takes a minute or so on two cores at the defaults;
not part of the test suite.

    python benches/python/rss_noise.py [--sensor 1280x720] [--windows 200]
        [--fraction 0.05] [--density 0.02] [--part-spikes N] [--json]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from uavsnn.dataset import LabelledWindows
from uavsnn.dataset.build import parse_sensor
from uavsnn.events import EVENT_DTYPE, Recording
from uavsnn.experiments import NOISE_PART_SPIKES, _noise_parts, noise_level, static_twin
from uavsnn.network import Network, default_config
from uavsnn.windows import make_windows, noise_per_window

WINDOW_US = 50_000


def status_mib(field: str) -> float:
    """A ``/proc/self/status`` memory field of this process, in MiB."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) / 1024
    raise RuntimeError(f"no {field} in /proc/self/status")


def test_windows(
    sensor: tuple[int, int], n: int, density: float, box: int, seed: int
) -> LabelledWindows:
    """``n`` windows of uniform events, half of them labelled UAV with a centred box."""
    width, height = sensor
    per_window = int(density * width * height)
    rng = np.random.default_rng(seed)
    count = per_window * n
    events = np.zeros(count, dtype=EVENT_DTYPE)
    events["t"] = np.sort(rng.integers(0, n * WINDOW_US, count))
    events["x"] = rng.integers(0, width, count)
    events["y"] = rng.integers(0, height, count)
    events["p"] = rng.integers(0, 2, count)
    windows = make_windows(Recording(events, sensor), WINDOW_US, 0.0, end_us=n * WINDOW_US)
    label = np.arange(len(windows)) % 2 == 0
    x0, y0 = (width - box) / 2, (height - box) / 2
    boxes = np.full((len(windows), 4), np.nan, dtype=np.float32)
    boxes[label] = (x0, y0, x0 + box, y0 + box)
    return LabelledWindows(
        windows,
        label,
        np.where(label, "drone", "none").astype("<U12"),
        np.zeros(len(windows), dtype=np.int64),
        boxes,
    )


def run(args: argparse.Namespace, budget: int) -> dict[str, object]:
    """One noise level at ``budget`` spikes a part, in this process."""
    sensor = parse_sensor(args.sensor)
    data = test_windows(sensor, args.windows, args.density, args.box, args.seed)
    net = Network({**default_config(), "width": sensor[0], "height": sensor[1]}, seed=0)
    static, _ = static_twin(net, data.windows)
    noise = noise_per_window(args.fraction, sensor)
    spikes = np.diff(data.windows.offsets)
    before = status_mib("VmRSS")
    start = time.perf_counter()
    points = noise_level(
        {"pent": net, "static": static}, data, args.fraction, seed=args.seed, part_spikes=budget
    )
    seconds = time.perf_counter() - start
    return {
        "part_spikes": budget,
        "parts": len(_noise_parts(spikes, noise, budget)),
        "input_spikes": int(spikes.sum()) + noise * len(data),
        "rss_before_mib": before,
        "peak_growth_mib": status_mib("VmHWM") - before,
        "seconds": seconds,
        "points": [p.to_dict() for p in points],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sensor", default="1280x720")
    parser.add_argument("--windows", type=int, default=200)
    parser.add_argument("--fraction", type=float, default=0.05)
    parser.add_argument("--density", type=float, default=0.02)
    parser.add_argument("--box", type=int, default=64)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--part-spikes", type=int, default=NOISE_PART_SPIKES)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--one", type=int, help=argparse.SUPPRESS)  # a child: run this budget
    args = parser.parse_args()
    if args.one is not None:
        print(json.dumps(run(args, args.one)))
        return 0

    sensor = parse_sensor(args.sensor)
    everything = args.windows * int(
        args.density * sensor[0] * sensor[1] + args.fraction * sensor[0] * sensor[1] + 2
    )
    results = []
    for budget in (args.part_spikes, max(everything, args.part_spikes) + 1):
        child = [sys.executable, __file__, *sys.argv[1:], "--one", str(budget)]
        out = subprocess.run(child, check=True, capture_output=True, text=True).stdout
        results.append(json.loads(out.strip().splitlines()[-1]))
    parts, whole = results
    same = parts["points"] == whole["points"]
    if args.json:
        print(json.dumps({"parts": parts, "whole": whole, "same_points": same}, indent=2))
        return 0
    print(
        f"{args.windows} windows of {args.sensor}, noise on {args.fraction:.1%} of the pixels "
        f"({parts['input_spikes']:,} input spikes with the signal), two networks"
    )
    for name, r in (("in parts", parts), ("at once", whole)):
        print(
            f"  {name:9s} {r['parts']:3d} part(s) of <= {r['part_spikes']:,} spikes: peak "
            f"+{r['peak_growth_mib']:.0f} MiB over {r['rss_before_mib']:.0f} MiB, "
            f"{r['seconds']:.1f} s"
        )
    ratio = parts["peak_growth_mib"] / whole["peak_growth_mib"]
    print(
        f"  peak growth, in parts / at once: {ratio:.2f}; time: "
        f"{parts['seconds'] / whole['seconds']:.2f}; the same points: {same}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
