"""``uavsnn bench``: how fast the engine runs on this machine (see :mod:`uavsnn.bench`)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from uavsnn import _jsonout
from uavsnn.bench import DEFAULT_EVENTS, DENSITIES, bench_density
from uavsnn.cli import counted
from uavsnn.errors import ParameterError
from uavsnn.network import Network
from uavsnn.progress import bar as new_bar
from uavsnn.sim.checks import check_size

#: The longest ``--chunk-ms``: an hour of event time (a bench's windows span less).
MAX_CHUNK_MS = 3_600_000.0

__all__ = ["register"]


def _densities(text: str) -> list[float]:
    try:
        values = [float(v) / 100 for v in text.split(",")]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected percentages like 0.1,1,5, got {text!r}") from (
            exc
        )
    if not all(0 < v <= 1 for v in values):
        raise argparse.ArgumentTypeError(f"percentages must be in (0, 100], got {text!r}")
    return values


def _count(text: str) -> int:
    """A count of at least 1, written whole or as a whole number like ``3e5``."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value.is_integer() and value >= 1):
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1 (e.g. 3e5), got {text!r}")
    return int(text) if text.strip().lstrip("+").isdigit() else int(value)


def register(subparsers: Any) -> None:
    """Add ``uavsnn bench``."""
    p = subparsers.add_parser(
        "bench",
        help="measure the engine's speed on this machine",
        description="Run a network on synthetic bench windows (the Criterion benches' scenes) "
        "at several shares of active pixels and report, against references measured in the "
        "same run: ns per input event and the real-time factor on one thread, the scaling to "
        "all threads, and a Detector stream against the batch path.",
    )
    p.add_argument("--model", type=Path, help="model file (default: an untrained network)")
    p.add_argument(
        "--size", default=None, metavar="WxH",
        help="sensor size of the untrained network (240x180; a model brings its own)",
    )  # fmt: skip
    p.add_argument(
        "--density", type=_densities, default=list(DENSITIES),
        metavar="P,P,..", help="percent of pixels active per window (0.1,1,5)",
    )  # fmt: skip
    p.add_argument(
        "--windows", type=_count, default=None,
        help="windows of 50 ms per density (default: enough for about --events input events; "
        "not with --events)",
    )  # fmt: skip
    p.add_argument(
        "--events", type=_count, default=None,
        help="input events per density (3e5; not with --windows, which sets the count itself)",
    )  # fmt: skip
    p.add_argument("--repeat", type=int, default=5, help="runs per figure; the best counts (5)")
    p.add_argument("--threads", type=int, default=None, help="workers of the batch (all cores)")
    p.add_argument(
        "--chunk-ms", type=float, default=1.0,
        help="event time the stream takes per push, in ms (1; from 0.001)",
    )  # fmt: skip
    p.add_argument("--seed", type=int, default=0, help="seed of the windows and network (0)")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    p.add_argument("--quiet", action="store_true", help="no progress on standard error")
    p.set_defaults(handler=_bench)


def _bench(args: argparse.Namespace) -> int:
    if args.windows is not None and args.events is not None:
        raise ParameterError(
            "--windows and --events both set how many windows each density runs: give one"
        )
    if args.model is not None:
        if args.size is not None:
            raise ParameterError("--size is the untrained network's: a --model brings its own")
        network = Network.load(args.model)
    else:
        width, height = check_size(args.size or "240x180", "--size")
        network = Network({"width": width, "height": height}, seed=args.seed)
    if not (math.isfinite(args.chunk_ms) and 0.001 <= args.chunk_ms <= MAX_CHUNK_MS):
        raise ParameterError(
            f"--chunk-ms must be a number of ms from 0.001 to {MAX_CHUNK_MS:g}, got {args.chunk_ms}"
        )
    progress = (
        None if args.quiet else new_bar(total=len(args.density), desc="bench", unit="density")
    )
    rows = []
    for density in args.density:
        rows.append(bench_density(
            network, density, windows=args.windows,
            events=DEFAULT_EVENTS if args.events is None else args.events, threads=args.threads,
            repeat=args.repeat, chunk_us=round(args.chunk_ms * 1000), seed=args.seed,
        ))  # fmt: skip
        if progress is not None:
            progress.update(1)
    if progress is not None:
        progress.close()
    if args.json:
        model = str(args.model) if args.model else None
        print(_jsonout.document({"model": model, "rows": [r.to_dict() for r in rows]}))
        return 0
    print(f"model: {args.model or f'untrained (seed {args.seed})'}")
    for r in rows:
        print(
            f"{r.sensor} {r.density_percent:g} %: {r.events // r.windows} events/window; "
            f"one thread {r.one_thread_ns_per_event:.0f} ns/event "
            f"({r.one_thread_events_per_s / 1e6:.2f} M events/s, "
            f"{r.real_time_factor:.0f}x real time); "
            f"{counted(r.threads, 'thread')} {r.scaling:.2f}x one; "
            f"stream ({r.stream_chunk_us / 1000:g} ms chunks) {r.stream_vs_batch:.2f}x batch"
        )
        spikes = ", ".join(f"{k} {v:.1f}" for k, v in r.spikes_per_window.items())
        print(f"    spikes/window: {spikes}; windows detected {r.detected_windows}/{r.windows}")
    return 0
