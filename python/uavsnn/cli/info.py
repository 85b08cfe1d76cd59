"""``uavsnn info FILE``: what a recording holds."""

from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np

from uavsnn import io
from uavsnn.errors import ParameterError
from uavsnn.events import Recording

__all__ = ["PEAK_BIN_US", "register", "summary"]

#: Width of the bins over which the peak event rate is measured.
PEAK_BIN_US = 1_000


def summary(recording: Recording) -> dict[str, Any]:
    """Sensor size, event count, first/last time, duration, and mean and peak event rates.

    The mean rate is events per second from the intervals between the events: ``n − 1`` of
    them over ``last t − first t`` (``None`` for fewer than two distinct times; ``n`` over that
    span would count the last event's interval, which lies beyond it, and read above the peak
    for events spread evenly over about 1 ms). The peak rate is the most events in one 1 ms bin
    (bins aligned on the first event), times 1000, and ``None`` when the events span less than
    one bin, whose count would read as a rate lower than the mean.
    """
    t = recording.events["t"]
    n = len(t)
    duration = recording.duration_us
    peak = None
    if n and duration >= PEAK_BIN_US:
        bins = (t - t[0]) // PEAK_BIN_US
        edges = np.flatnonzero(np.diff(bins)) + 1
        counts = np.diff(np.concatenate(([0], edges, [n])))
        peak = int(counts.max()) * (1_000_000 // PEAK_BIN_US)
    return {
        "path": recording.metadata.get("path"),
        "format": recording.metadata.get("format"),
        "sensor_size": list(recording.sensor_size),
        "sensor_size_source": recording.metadata.get("sensor_size_source"),
        "camera": recording.metadata.get("camera"),
        "events": n,
        "first_t_us": int(t[0]) if n else None,
        "last_t_us": int(t[-1]) if n else None,
        "duration_us": duration,
        "mean_rate_ev_per_s": (n - 1) * 1_000_000 / duration if duration > 0 else None,
        "peak_rate_ev_per_s": peak,
        "peak_bin_us": PEAK_BIN_US,
    }


def _sensor_size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT, got {text!r}") from exc
    return width, height


_SOURCES = {
    "file": "from the file",
    "argument": "as given",
    "camera": "the {camera} camera named in the header, which has no geometry; "
    "give --sensor-size if wrong",
    "fallback": "faery's fallback: the file has no geometry, give --sensor-size",
    "inferred": "the events' bounding box: give --sensor-size",
}


def _format(value: float | None, unit: str) -> str:
    return "n/a" if value is None else f"{value:,.0f} {unit}"


def run(args: argparse.Namespace) -> int:
    """Print the summary of ``args.file``."""
    if args.sensor_size is not None and min(args.sensor_size) <= 0:
        raise ParameterError(f"--sensor-size must be positive, got {args.sensor_size}")
    info = summary(io.read(args.file, sensor_size=args.sensor_size))
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    width, height = info["sensor_size"]
    duration = info["duration_us"]
    print(f"file:        {info['path']} ({info['format']})")
    source = _SOURCES.get(info["sensor_size_source"], info["sensor_size_source"])
    source = source.replace("{camera}", str(info["camera"]))
    print(f"sensor:      {width}x{height} ({source})")
    print(f"events:      {info['events']:,}")
    if info["events"]:
        print(f"time:        {info['first_t_us']} .. {info['last_t_us']} µs")
    print(f"duration:    {duration / 1e6:.6f} s")
    print(f"mean rate:   {_format(info['mean_rate_ev_per_s'], 'ev/s')}")
    peak = info["peak_rate_ev_per_s"]
    bin_text = "busiest 1 ms bin" if peak is not None else "the events span less than 1 ms"
    print(f"peak rate:   {_format(peak, 'ev/s')} ({bin_text})")
    return 0


def register(subparsers: Any) -> None:
    """Add the ``info`` sub-command."""
    parser = subparsers.add_parser(
        "info",
        help="sensor size, event count, duration and event rates of a recording",
        description="Read a recording (AEDAT4, RAW, DAT, ES, CSV, NPZ, NPY) and summarise it.",
    )
    parser.add_argument("file", help="the recording")
    parser.add_argument("--json", action="store_true", help="print JSON for programs")
    parser.add_argument(
        "--sensor-size",
        type=_sensor_size,
        metavar="WxH",
        help="sensor size for files without geometry (e.g. 640x480 for Prophesee Gen3 RAW)",
    )
    parser.set_defaults(handler=run)
