"""Streaming benchmark of ``uavsnn.Detector`` (issue 6).

Measures, with a network trained here on the demo set (or ``--model``):

1. processing latency per chunk, from ``push`` to its return, p50 and p99, for chunks of 1, 100
   and 10,000 events (on a synthetic moving-blob recording: a small UAV-like blob crossing the
   sensor over uniform background noise);
2. sustained events/s through ``Detector``, against the batch path (``make_windows`` +
   ``Network.infer`` with the "preceding" PENT estimate, one thread) on the same recording,
   measured in the same run: the ratio is the figure to quote;
3. event-time latency on simulated recordings: UAV scenes rendered and turned into events by
   the dvs domain's emulator (``uavsnn.dataset.synthetic_recording``, the demo set's scene
   source, seeds of their own), each streamed through ``Detector`` in chunks; per recording,
   the event time from the UAV's first event in view (the first event inside the UAV's
   labelled box) to the first detection after it, to the first detection whose box holds the
   centre of the UAV's box, and to the return of the ``push`` that carried the first detection;
   median and p90 over the recordings detected, and the share detected; and, as the reference
   for false alarms, the same streamed over scenes without a UAV;
4. the same event-time latency on synthetic moving blobs (from the blob's first event to the
   first detection whose box holds the blob), as a second line.

Without ``--model`` the script builds the demo set (``uavsnn.dataset.build_demo``; in a
temporary folder, or in ``--data DIR`` where a finished one is reused) and trains conv2 and
conv3 on its train split by STDP as ``uavsnn demo`` does (``RECIPE_SETTINGS``, 2000 windows per
layer): about a minute on two cores. ``--untrained`` skips that and uses the seeded initial
weights, which is enough to measure cost but makes the event-time latencies meaningless.

Run from the repository root after ``maturin develop --release``::

    python benches/python/bench_stream.py [--model MODEL | --untrained | [--data DIR]
        [--save-model PATH]] [--scenes 8] [--controls 4] [--scene-seconds 1] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn import EVENT_DTYPE, Recording
from uavsnn.dataset import (
    DatasetError,
    LabelledRecording,
    SceneSource,
    build_demo,
    load,
    read_manifest,
    synthetic_recording,
)
from uavsnn.detector import Detector
from uavsnn.experiments import RECIPE_SETTINGS, recipe_config
from uavsnn.network import Network
from uavsnn.training import train
from uavsnn.windows import make_windows

SIZE = (240, 180)
#: The demo set's scene source: the dvs domain, 240x180 rendered at 400 fps (docs/dataset.md).
DEMO_FPS = 400.0
#: The first seed of the event-time latency scenes. The demo set's recordings are seeded by
#: 32-bit hashes of (dataset seed, domain, split, index); the script checks that none of them
#: is among the seeds it uses when it has the demo set's manifest.
SCENE_SEED = 1000
#: The first seed of the scenes without a UAV (the false-alarm reference).
CONTROL_SEED = 2000


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


UAV_KINDS = ("phantom", "tello")


def uav_scenes(
    n: int, first_seed: int, seconds: float, kind: str = "uav", fps: float = DEMO_FPS
) -> list[LabelledRecording]:
    """``n`` scenes of ``kind`` (``"uav"``: a Phantom or a Tello, sometimes with a
    distractor) of the dvs domain, seeds ``first_seed``, ``first_seed + 1``...: rendered and
    turned into events by the DVS emulator, with the object's box in every frame."""
    source = SceneSource("dvs", SIZE, fps, seconds)
    return [synthetic_recording(source, kind, first_seed + i) for i in range(n)]


def frame_index(lr: LabelledRecording, t: np.ndarray) -> np.ndarray:
    """The frame that stands for each time of ``t``: frame ``k`` stands for
    ``[t_k - Δ/2, t_k + Δ/2)`` (docs/dataset.md §3)."""
    ts = lr.timestamps_us.astype(np.float64)
    mid = (ts[:-1] + ts[1:]) / 2
    return np.searchsorted(mid, np.asarray(t, dtype=np.float64), side="right")


def first_uav_event(lr: LabelledRecording) -> int | None:
    """Time (µs) of the first event inside the UAV's labelled box, in the frame that stands
    for the event's time (pixel ``(x, y)`` covers ``[x, x+1) × [y, y+1)``); ``None`` if the
    UAV is never in view."""
    ev = lr.recording.events
    k = frame_index(lr, ev["t"])
    lab = lr.labels[k]
    x, y = ev["x"].astype(np.float32), ev["y"].astype(np.float32)
    with np.errstate(invalid="ignore"):
        inside = (
            lab["uav"]
            & lr.labelled[k]
            & (x + 1 > lab["x0"])
            & (x < lab["x1"])
            & (y + 1 > lab["y0"])
            & (y < lab["y1"])
        )
    hits = np.flatnonzero(inside)
    return int(ev["t"][hits[0]]) if len(hits) else None


def uav_centre(lr: LabelledRecording, t: int) -> tuple[float, float] | None:
    """Centre of the UAV's labelled box at time ``t``; ``None`` when no UAV is in view."""
    lab = lr.labels[int(frame_index(lr, np.array([t]))[0])]
    if not lab["uav"]:
        return None
    return float(lab["x0"] + lab["x1"]) / 2, float(lab["y0"] + lab["y1"]) / 2


def scene_latency(
    net: Network, lr: LabelledRecording, *, window_us: int, overlap: float, chunk: int = 100
) -> dict[str, Any]:
    """Stream ``lr`` through a Detector in chunks of ``chunk`` events.

    Returns, with ``first`` the UAV's first event (:func:`first_uav_event`; for a scene without
    a UAV, the recording's first event), the event time in µs from ``first`` to the first
    detection after it (``latency_us``), to the first detection whose box holds the centre of
    the UAV's box (``holds_uav_latency_us``), and to the last event of the push that returned
    the first detection (``released_latency_us``: what a live caller waits, in event time);
    ``None`` where there is no such detection. Also the first detection's box and the distance
    from its position (its receptive field's centre) to the UAV's centre, and the share of
    windows with a detection."""
    events = lr.recording.events
    has_uav = bool(lr.labels["uav"].any())
    first = first_uav_event(lr) if has_uav else (int(events["t"][0]) if len(events) else None)
    main = next((o for o in lr.info["objects"] if o["kind"] in UAV_KINDS), None)
    if main is None and lr.info["objects"]:
        main = lr.info["objects"][0]
    out: dict[str, Any] = {
        "seed": lr.info["seed"],
        "object": main["kind"] if main else "none",
        "range_m": main["range_m"] if main else None,
        "background": lr.info["background"],
        "lighting": lr.info["lighting"],
        "events": len(events),
        "first_event_us": first,
        "latency_us": None,
        "holds_uav_latency_us": None,
        "released_latency_us": None,
        "first_box": None,
        "first_offset_px": None,
        "detections": 0,
        "detections_before": 0,
        "windows": 0,
        "windows_detected": 0,
    }
    det = Detector(net, window_us=window_us, overlap=overlap)
    windows: set[int] = set()

    def take(found: np.ndarray, released: int) -> None:
        for d in found:
            out["detections"] += 1
            windows.add(int(d["window"]))
            t = int(d["t"])
            if first is None or t < first:
                out["detections_before"] += 1
                continue
            centre = uav_centre(lr, t) if has_uav else None
            holds = centre is not None and (
                d["x0"] <= centre[0] < d["x1"] and d["y0"] <= centre[1] < d["y1"]
            )
            if out["latency_us"] is None:
                out["latency_us"] = t - first
                out["released_latency_us"] = released - first
                out["first_box"] = [int(d[k]) for k in ("x0", "y0", "x1", "y1")]
                if centre is not None:
                    out["first_offset_px"] = round(
                        float(np.hypot(d["x"] - centre[0], d["y"] - centre[1])), 1
                    )
            if holds and out["holds_uav_latency_us"] is None:
                out["holds_uav_latency_us"] = t - first

    for i in range(0, len(events), chunk):
        part = events[i : i + chunk]
        take(det.push(part), int(part["t"][-1]))
    take(det.flush(), lr.end_us)  # flush() releases at the end of the recording
    out["windows"] = det.windows_opened
    out["windows_detected"] = len(windows)
    return out


def summarise(values: Sequence[int | None]) -> dict[str, Any]:
    """Median and p90 (µs) over the recordings with a value, and how many have one."""
    found = np.array([v for v in values if v is not None], dtype=np.float64)
    return {
        "median_us": float(np.median(found)) if len(found) else None,
        "p90_us": float(np.percentile(found, 90)) if len(found) else None,
        "detected": len(found),
        "recordings": len(values),
    }


def window_share(per: Sequence[dict[str, Any]]) -> float | None:
    """Share of all windows, over the recordings, that hold a detection."""
    total = sum(r["windows"] for r in per)
    return sum(r["windows_detected"] for r in per) / total if total else None


def demo_model(data: Path | None, data_seed: int, windows_per_layer: int) -> tuple[Network, dict]:
    """Train conv2 and conv3 as ``uavsnn demo`` does on the demo set's train split, building the
    set in ``data`` (reused when it holds the demo set of ``data_seed``) or in a temporary
    folder. Returns the network and what was done, with the demo set's recording seeds."""
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="bench_stream_") as tmp:
        root = data if data is not None else Path(tmp) / "data"
        try:
            reused = read_manifest(root)["seed"] == data_seed
        except DatasetError:
            reused = False
        if not reused:
            build_demo(root, data_seed, overwrite=True)
        built = time.perf_counter()
        train_set = load(root, "train")
        seeds = {int(r["seed"]) for r in train_set.manifest["recordings"] if "seed" in r}
        net = Network(recipe_config(), seed=data_seed)
        train(net, train_set.windows, windows_per_layer=windows_per_layer, seed=data_seed)
    info = {
        "model": f"trained here: demo set seed {data_seed} ({len(train_set)} train windows), "
        f"{' '.join(RECIPE_SETTINGS)}, {windows_per_layer} windows per layer",
        "dataset_s": round(built - started, 1),
        "dataset_reused": bool(reused),
        "train_s": round(time.perf_counter() - built, 1),
        "demo_recording_seeds": seeds,
    }
    return net, info


def parse_args(argv: Sequence[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    model = parser.add_mutually_exclusive_group()
    model.add_argument("--model", help="a trained model file (default: train one, see --data)")
    model.add_argument(
        "--untrained",
        action="store_true",
        help="seeded initial weights (seed 0): cost only, no dataset, no training",
    )
    parser.add_argument(
        "--data",
        type=Path,
        help="demo dataset folder, reused if built with --data-seed, else built there "
        "(default: a temporary folder)",
    )
    parser.add_argument("--data-seed", type=int, default=0, help="demo set and training seed")
    parser.add_argument("--save-model", type=Path, help="write the model trained here to this file")
    parser.add_argument("--train-windows", type=int, default=2000, help="windows per layer")
    parser.add_argument("--seconds", type=float, default=4.0, help="moving-blob recording length")
    parser.add_argument("--window-us", type=int, default=50_000)
    parser.add_argument("--overlap", type=float, default=0.5)
    parser.add_argument(
        "--recordings", type=int, default=5, help="moving-blob recordings for event-time latency"
    )
    parser.add_argument("--scenes", type=int, default=8, help="simulated UAV recordings")
    parser.add_argument(
        "--scene-seed", type=int, default=SCENE_SEED, help="seed of the first UAV scene"
    )
    parser.add_argument(
        "--scene-seconds", type=float, default=1.0, help="length of each UAV scene (s)"
    )
    parser.add_argument(
        "--scene-chunk", type=int, default=100, help="events per push when streaming the scenes"
    )
    parser.add_argument(
        "--controls",
        type=int,
        default=4,
        help="simulated recordings without a UAV (kind 'object'), the false-alarm reference",
    )
    parser.add_argument(
        "--control-seed", type=int, default=CONTROL_SEED, help="seed of the first control scene"
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    if args.save_model and (args.model or args.untrained):
        parser.error("--save-model writes the model trained here: not with --model or --untrained")
    return args


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Every measurement of the script, as a JSON-ready dict."""
    started = time.perf_counter()
    model_info: dict[str, Any]
    if args.model:
        net, model_info = Network.load(args.model), {"model": args.model}
    elif args.untrained:
        net, model_info = Network(seed=0), {"model": "untrained (seed 0)"}
    else:
        net, model_info = demo_model(args.data, args.data_seed, args.train_windows)
        if args.save_model:
            net.save(args.save_model)
    demo_seeds = model_info.pop("demo_recording_seeds", set())
    scene_seeds = {*range(args.scene_seed, args.scene_seed + args.scenes)}
    scene_seeds |= {*range(args.control_seed, args.control_seed + args.controls)}
    clash = sorted(demo_seeds.intersection(scene_seeds))
    if clash:
        raise SystemExit(f"scene seeds {clash} are seeds of demo-set recordings: pick --scene-seed")

    syn = moving_blob(seconds=args.seconds, seed=0)
    events = syn.recording.events
    results: dict[str, Any] = {
        "recording": {
            "events": len(events),
            "seconds": args.seconds,
            "window_us": args.window_us,
            "overlap": args.overlap,
            **model_info,
        },
        "chunk_latency": [chunk_latency(net, syn, c, args) for c in (1, 100, 10_000)],
        "throughput": throughput(net, syn.recording, args),
    }

    render_start = time.perf_counter()
    scenes = uav_scenes(args.scenes, args.scene_seed, args.scene_seconds)
    controls = uav_scenes(args.controls, args.control_seed, args.scene_seconds, kind="object")
    rendered = time.perf_counter() - render_start
    stream = {"window_us": args.window_us, "overlap": args.overlap, "chunk": args.scene_chunk}
    per = [scene_latency(net, lr, **stream) for lr in scenes]
    ctl = [scene_latency(net, lr, **stream) for lr in controls]
    results["scene_latency"] = {
        "source": f"dvs, {SIZE[0]}x{SIZE[1]} at {DEMO_FPS:g} fps, {args.scene_seconds:g} s",
        "seeds": [args.scene_seed, args.scene_seed + args.scenes - 1],
        "chunk": args.scene_chunk,
        "render_s": round(rendered, 1),
        "per_recording": per,
        "first_detection": summarise([r["latency_us"] for r in per]),
        "first_detection_holding_uav": summarise([r["holds_uav_latency_us"] for r in per]),
        "released": summarise([r["released_latency_us"] for r in per]),
        "windows_detected": window_share(per),
        "controls": {
            "kind": "object",
            "seeds": [args.control_seed, args.control_seed + args.controls - 1],
            "per_recording": ctl,
            "first_detection": summarise([r["latency_us"] for r in ctl]),
            "windows_detected": window_share(ctl),
        },
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
    results["seconds"] = round(time.perf_counter() - started, 1)
    return results


def _ms(us: float | None) -> str:
    return "-" if us is None else f"{us / 1e3:.2f} ms"


def _px(px: float | None) -> str:
    return "-" if px is None else f"{px:.0f} px"


def _pct(share: float | None) -> str:
    return "-" if share is None else f"{100 * share:.0f} %"


def _summary(s: dict[str, Any]) -> str:
    return (
        f"median {_ms(s['median_us'])}, p90 {_ms(s['p90_us'])}, detected "
        f"{s['detected']}/{s['recordings']}"
    )


def report(results: dict[str, Any]) -> list[str]:
    """The printed report, one string per line."""
    r = results["recording"]
    lines = [f"model: {r['model']}"]
    if "train_s" in r:
        lines[0] += (
            f" (dataset {'reused' if r['dataset_reused'] else 'built'} in {r['dataset_s']} s, "
            f"trained in {r['train_s']} s)"
        )
    lines.append(
        f"synthetic moving blob: {r['events']:,} events over {r['seconds']} s, "
        f"L={r['window_us']} µs, o={r['overlap']}"
    )
    lines.append("push latency per chunk:")
    for c in results["chunk_latency"]:
        lines.append(
            f"  {c['chunk']:>6} events: p50 {c['p50_us']:9.1f} µs  p99 {c['p99_us']:9.1f} µs"
            f"  mean {c['mean_us']:9.1f} µs ({c['ns_per_event_mean']:.0f} ns/event, "
            f"{c['pushes']} pushes)"
        )
    tp = results["throughput"]
    lines.append(
        f"sustained: stream {tp['stream_events_per_s']:,.0f} ev/s, batch "
        f"{tp['batch_events_per_s']:,.0f} ev/s (1 thread): stream/batch speed "
        f"{tp['stream_over_batch']:.2f}x"
    )
    sc = results["scene_latency"]
    lines.append(
        f"event-time latency on simulated UAV recordings ({sc['source']}, seeds "
        f"{sc['seeds'][0]}..{sc['seeds'][1]}, chunks of {sc['chunk']} events), from the UAV's "
        "first event in its labelled box:"
    )
    for rec in sc["per_recording"]:
        lines.append(
            f"  seed {rec['seed']}: {rec['object']} at {rec['range_m']} m, {rec['background']}, "
            f"light {rec['lighting']}, {rec['events']:,} events; first UAV event at "
            f"{_ms(rec['first_event_us'])}; first detection +{_ms(rec['latency_us'])} "
            f"(its position {_px(rec['first_offset_px'])} from the UAV), first holding the UAV "
            f"+{_ms(rec['holds_uav_latency_us'])}; windows with a detection "
            f"{rec['windows_detected']}/{rec['windows']}"
        )
    for key, what in (
        ("first_detection", "first detection"),
        ("first_detection_holding_uav", "first detection whose box holds the UAV's centre"),
        ("released", "first detection returned by push (last event of that chunk)"),
    ):
        lines.append(f"  {what}: {_summary(sc[key])}")
    ctl = sc["controls"]
    lines.append(
        f"  reference, scenes without a UAV (kind '{ctl['kind']}', seeds {ctl['seeds'][0]}.."
        f"{ctl['seeds'][1]}): first detection after the first event: "
        f"{_summary(ctl['first_detection'])}; windows with a detection "
        f"{_pct(ctl['windows_detected'])} (UAV scenes {_pct(sc['windows_detected'])})"
    )
    lat = results["event_time_latency_ms"]
    lines.append(
        f"event-time latency, first blob event -> first detection whose box holds the blob: "
        f"median {lat['median']} ms, detected {lat['detected']}, per recording "
        f"{lat['per_recording']}"
    )
    lines.append(f"total {results['seconds']} s")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    results = run(args)
    if args.json:
        json.dump(results, sys.stdout, indent=2)
        print()
        return 0
    print("\n".join(report(results)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
