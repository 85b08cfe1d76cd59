"""What a dataset's raw events cost on disk, per 1000 windows, at each sensor size.

For each sensor, builds a dvs test set (``--n-test`` windows, half UAV, 50 ms windows with
50 % overlap, default scenes at 500 fps of ``--seconds``) in a temporary folder and reports the
bytes of the split file's arrays per 1000 windows: the raw events (``raw_t``, ``raw_x``,
``raw_y``, ``raw_p``, ``raw_start``, ``raw_stop``) beside the first spikes (``t``, ``x``,
``y``, ``offsets``) and the whole file. Windows of one recording share their raw events, so
the figure holds for any ``n_test`` drawn the same way (pools of 1.25 times the windows).

    python benches/python/raw_cost.py [--n-test 100] [--seconds 0.5] [--sensor 640x480] [--json]
"""

from __future__ import annotations

import argparse
import json
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn.dataset import SENSOR_SIZES, build, parse_sensor
from uavsnn.dataset.synthetic import default_source

RAW = ("raw_t", "raw_x", "raw_y", "raw_p", "raw_start", "raw_stop")
SPIKES = ("t", "x", "y", "offsets")


def cost(sensor: tuple[int, int], n_test: int, seconds: float, seed: int) -> dict[str, Any]:
    """Build one test set on ``sensor`` and measure its split file."""
    source = replace(default_source("dvs", sensor), duration_s=seconds)
    with tempfile.TemporaryDirectory() as tmp:
        paths = build(
            Path(tmp) / "set",
            "dvs",
            n_test=n_test,
            n_train=0,
            seed=seed,
            dvs=source,
            sensor=sensor,
        )
        with np.load(paths.test) as z:
            raw = sum(z[k].nbytes for k in RAW)
            spikes = sum(z[k].nbytes for k in SPIKES)
            events = len(z["raw_t"])
        file_bytes = paths.test.stat().st_size
    per = 1000 / n_test
    return {
        "raw_MB_per_1000_windows": raw * per / 1e6,
        "spikes_MB_per_1000_windows": spikes * per / 1e6,
        "file_MB_per_1000_windows": file_bytes * per / 1e6,
        "raw_events_per_window": events / n_test,
    }


def main(argv: list[str] | None = None) -> int:
    """Measure and print."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--n-test", type=int, default=100)
    parser.add_argument("--seconds", type=float, default=0.5, help="scene length (0.5)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--sensor", action="append", help="WxH (repeatable; default: all four)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    sensors = [parse_sensor(s) for s in args.sensor] if args.sensor else list(SENSOR_SIZES)
    out = {f"{w}x{h}": cost((w, h), args.n_test, args.seconds, args.seed) for w, h in sensors}
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    for name, r in out.items():
        print(f"{name:10s} " + "  ".join(f"{k} {v:.3g}" for k, v in r.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
