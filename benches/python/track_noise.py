"""False tracks from noise detections: how often the tracker confirms a track built of noise.

Windows of a 240×180 sensor (50 ms windows, overlap 0.5) each hold Poisson(``rate``) detections
at uniform positions (6×6 boxes), nothing else, for ``--windows`` windows and ``--seeds`` seeds
from ``--first-seed`` (default 0..4; the tests use seed 2000 and up). For each rate and gate it
prints the tracks started, the tracks confirmed, and confirmed tracks per 1000 windows (per
1000 windows of 25 ms steps: per 25 s of stream). The other parameters are the tracker's
defaults (:class:`uavsnn.tracks.Tracker`).

Run from the repository root::

    python benches/python/track_noise.py [--windows 2000] [--seeds 5] [--first-seed 0]
"""

from __future__ import annotations

import argparse

import numpy as np

from uavsnn.detector import WindowObject, WindowReport
from uavsnn.tracks import Tracker, track_windows

STEP = 25_000


def reports(seed: int, windows: int, rate: float) -> list[WindowReport]:
    rng = np.random.default_rng(seed)
    empty = np.empty(0)
    out = []
    for k, n in enumerate(rng.poisson(rate, windows).tolist()):
        objects = []
        for _ in range(n):
            x, y = round(rng.uniform(10, 230)), round(rng.uniform(10, 170))
            objects.append(WindowObject(box=(x - 3, y - 3, x + 3, y + 3), spikes=1))
        out.append(
            WindowReport(
                window=k,
                t0=k * STEP,
                t1=k * STEP + 2 * STEP,
                detected=bool(objects),
                detections=empty,
                objects=tuple(objects),
            )
        )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=int, default=2000)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--first-seed", type=int, default=0)
    args = parser.parse_args()
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    print("| noise per window | gate (px) | tracks started | confirmed | per 1000 windows |")
    print("|---|---|---|---|---|")
    for rate in (0.1, 0.25, 0.5, 1.0, 2.0):
        for gate in (12.0, 24.0):
            started = confirmed = 0
            for seed in seeds:
                tracks = track_windows(reports(seed, args.windows, rate), Tracker(gate_px=gate))
                started += len(tracks.tracks)
                confirmed += sum(t.confirmed for t in tracks.tracks)
            per = 1000 * confirmed / (args.windows * len(seeds))
            print(f"| {rate} | {gate:g} | {started} | {confirmed} | {per:.2f} |")


if __name__ == "__main__":
    main()
