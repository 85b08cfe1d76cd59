"""False tracks from noise detections: how often the tracker confirms a track built of noise.

Windows of a 240×180 sensor (50 ms windows, overlap 0.5) each hold Poisson(``rate``) detections
at uniform positions (6×6 boxes), nothing else, for ``--windows`` windows and ``--seeds`` seeds
from ``--first-seed`` (default 0..4; the tests use seed 2000 and up). For each rate and gate it
prints the tracks started, the tracks confirmed, and confirmed tracks per 1000 windows (per
1000 windows of 25 ms steps: per 25 s of stream). The other parameters are the tracker's
defaults (:class:`uavsnn.tracks.Tracker`).

With ``--model M --dataset D``, it measures instead what a trained network gives the tracker
on the windows of a dataset's split (``--split``, default ``train``: sweep on a tuning set, never
choose by the test split): the objects per UAV-free window, by class, and for each gate and
confirmation rule the any-spike rule's track-level figures (:mod:`uavsnn.track_eval`: UAV
recordings found, time to first alarm, false tracks per minute of UAV-free recording).
``--keep F`` follows only a share ``F`` of the split's windows (drawn with ``--keep-seed``), to
see how the windows a dataset leaves out move those figures.

Run from the repository root::

    python benches/python/track_noise.py [--windows 2000] [--seeds 5] [--first-seed 0]
    python benches/python/track_noise.py --model M --dataset D [--split train] [--keep 0.8]
"""

from __future__ import annotations

import argparse

import numpy as np

from uavsnn.grouping import WindowObject, WindowReport
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


def dataset_sweep(
    model: str,
    dataset: str,
    split: str,
    keep: float = 1.0,
    keep_seed: int = 0,
    gates: tuple[float, ...] = (12.0, 24.0, 36.0),
) -> None:
    """Objects per UAV-free window, and the any-spike rule's track figures per tracker. With
    ``keep`` < 1, only that share of the windows (drawn with ``keep_seed``) is followed: the
    others count as misses, as the windows a dataset leaves out do."""
    from uavsnn import Network
    from uavsnn.dataset import load
    from uavsnn.identify import window_features
    from uavsnn.track_eval import track_figures

    net = Network.load(model)
    data = load(dataset, split)
    if keep < 1.0:
        rng = np.random.default_rng(keep_seed)
        data = data.select(np.flatnonzero(rng.random(len(data)) < keep))
    inference = net.infer(data.windows)
    feats = window_features(net, data, inference)
    per_window = np.bincount(feats.window, minlength=len(data))
    free = ~np.asarray(data.label, dtype=bool)
    coverage = track_figures(data, feats)["window_coverage"]
    print(
        f"{dataset} {split}: {len(data)} windows ({100 * coverage:.1f} % of the steps their "
        f"recordings span), {int(free.sum())} UAV-free"
    )
    print("| UAV-free windows of class | windows | objects per window | windows with one |")
    print("|---|---|---|---|")
    for name in [*np.unique(data.cls[free]).tolist(), "all"]:
        sel = free if name == "all" else free & (data.cls == name)
        n = per_window[sel]
        print(f"| {name} | {len(n)} | {n.mean():.2f} | {100 * np.mean(n > 0):.1f} % |")
    print()
    print(
        "| gate (px) | confirm | UAV recordings found | time to first alarm, median / 90th pct "
        "(ms) | false tracks | per minute (95 % upper bound) |"
    )
    print("|---|---|---|---|---|---|")
    for gate in gates:
        for hits, of in ((2, 5), (3, 5), (4, 5)):
            tracker = Tracker(gate_px=gate, confirm_hits=hits, confirm_windows=of)
            f = track_figures(data, window_features(net, data, inference, tracker=tracker))
            rule = f["rules"]["any_spike"]
            t = rule["time_to_alarm_ms"]
            delay = "–" if t["median"] is None else f"{t['median']:.0f} / {t['p90']:.0f}"
            per = rule["false_tracks_per_minute"]
            upper = rule["false_tracks_per_minute_upper95"]
            rate = "–" if per is None else f"{per:.1f} ({upper:.1f})"
            print(
                f"| {gate:g} | {hits} of {of} | {rule['found']} of {f['uav_recordings']} "
                f"| {delay} | {rule['false_tracks']} | {rate} |"
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=int, default=2000)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--model", help="a model file: measure on a dataset instead")
    parser.add_argument("--dataset", help="the dataset folder (with --model)")
    parser.add_argument("--split", default="train", help="its split (train)")
    parser.add_argument(
        "--keep", type=float, default=1.0, help="follow only this share of the windows (1)"
    )
    parser.add_argument("--keep-seed", type=int, default=0, help="the seed of that draw (0)")
    parser.add_argument(
        "--gates",
        default="12,24,36",
        help="the tracker's gates (px) swept with --model, comma-separated (12,24,36)",
    )
    args = parser.parse_args()
    try:
        gates = tuple(float(g) for g in args.gates.split(","))
    except ValueError:
        parser.error(f"--gates takes numbers separated by commas, got {args.gates!r}")
    if not all(g > 0 for g in gates):
        parser.error("--gates must all be > 0")
    if not 0.0 < args.keep <= 1.0:
        parser.error("--keep must be in (0, 1]")
    if (args.model is None) != (args.dataset is None):
        parser.error("--model and --dataset go together")
    if args.model is not None:
        dataset_sweep(args.model, args.dataset, args.split, args.keep, args.keep_seed, gates)
        return
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
