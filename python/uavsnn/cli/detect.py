"""``uavsnn detect``: run a trained model over a live event stream and print detections.

SOURCE is a recording file (any format :func:`uavsnn.io.read` reads; as fast as possible, or at
the recording's own pace with ``--realtime``), ``-`` for standard input (``--stdin-format
packed``: canonical 13-byte records; ``csv``: ``t,x,y,p`` lines), or ``udp://HOST:PORT``
receiving faery's or aestream's UDP packets (``--udp-format``; see :mod:`uavsnn.sources` for the
exact layouts). Detections go to standard output as they happen, one line each (JSON lines with
``--json``); a rate summary goes to standard error every ``--summary-every`` seconds and at the
end. Malformed packets, and chunks the detector rejects (an event outside the sensor, time going
backwards), are counted as drops and skipped.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from typing import Any, TextIO

import numpy as np

from uavsnn.distributed import add_ray_option
from uavsnn.errors import EventError, ParameterError, StreamError

__all__ = ["register"]

_DESCRIPTION = """\
Run a trained model over a live event stream and print detections as they happen.

SOURCE is one of:
  FILE              a recording (AEDAT4, RAW EVT2/EVT3, DAT, ES, CSV, .npz, .npy), replayed as
                    fast as possible, or at its own pace with --realtime; --downsample fits a
                    larger sensor to the model's input
  -                 standard input: packed 13-byte records (t u64, x u16, y u16, p u8, little
                    endian: the bytes of uavsnn.EVENT_DTYPE), or t,x,y,p CSV lines with
                    --stdin-format csv
  udp://HOST:PORT   UDP packets in faery's t64_x16_y16_on8 (default) or t32_x16_y15_on1
                    format, or aestream's spif words (--udp-format spif)

MODEL (--model) is a trained model file: 'uavsnn train DATASET -o MODEL' writes one, and
'uavsnn demo --out DIR' writes DIR/model.npz (trained on its small built-in set).

Detections go to standard output, one line each (JSON lines with --json); a rate summary goes
to standard error. Malformed packets, and chunks the detector rejects (events outside the
sensor, time going backwards), are counted as drops and skipped.
"""


def register(subparsers: Any) -> None:
    """Add the ``detect`` sub-command."""
    p = subparsers.add_parser(
        "detect",
        help="detect UAVs in a recording, standard input or a UDP event stream",
        description=_DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("source", metavar="SOURCE", help="a recording file, '-', or udp://HOST:PORT")
    p.add_argument(
        "more_sources",
        nargs="*",
        metavar="SOURCE",
        help="more files or udp://HOST:PORT streams, each with its own detector (needs --ray)",
    )
    p.add_argument(
        "--model",
        "-m",
        required=True,
        metavar="MODEL",
        help="trained model file (.npz): written by 'uavsnn train DATASET -o MODEL', or "
        "DIR/model.npz by 'uavsnn demo --out DIR'",
    )
    p.add_argument("--json", action="store_true", help="print detections as JSON lines")
    p.add_argument(
        "--realtime", action="store_true", help="replay a file at its own pace (files only)"
    )
    p.add_argument("--window-ms", type=float, default=50.0, help="window length in ms (default 50)")
    p.add_argument(
        "--overlap", type=float, default=0.5, help="window overlap in [0, 1) (default 0.5)"
    )
    p.add_argument(
        "--downsample",
        action="store_true",
        help="files only: crop and scale the recording to the model's input size",
    )
    p.add_argument(
        "--sensor-size",
        metavar="WxH",
        help="sensor size for '-' and UDP (default: the model's input size)",
    )
    p.add_argument(
        "--stdin-format",
        choices=("packed", "csv"),
        default="packed",
        help="layout of standard input (default packed 13-byte records)",
    )
    p.add_argument(
        "--udp-format",
        choices=("t64_x16_y16_on8", "t32_x16_y15_on1", "spif"),
        default="t64_x16_y16_on8",
        help="UDP packet format: faery's two formats or aestream's spif words",
    )
    p.add_argument(
        "--max-packets", type=int, help="UDP: stop after this many packets (for scripts, tests)"
    )
    p.add_argument(
        "--idle-timeout",
        type=float,
        help="UDP: stop after this many seconds without a packet",
    )
    p.add_argument(
        "--summary-every",
        type=float,
        default=1.0,
        metavar="S",
        help="seconds between rate summaries on stderr (0: only at the end)",
    )
    add_ray_option(p, "one detector per stream, each in a Ray actor")
    p.set_defaults(handler=run)


def _sensor_size(text: str | None) -> tuple[int, int] | None:
    if text is None:
        return None
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError as exc:
        raise ParameterError(f"--sensor-size must look like 240x180, got {text!r}") from exc
    return width, height


def _format(d: np.void, as_json: bool) -> str:
    if as_json:
        return json.dumps(
            {
                "t": int(d["t"]),
                "window": int(d["window"]),
                "map": int(d["map"]),
                "row": int(d["row"]),
                "col": int(d["col"]),
                "x": round(float(d["x"]), 2),
                "y": round(float(d["y"]), 2),
                "box": [int(d["x0"]), int(d["y0"]), int(d["x1"]), int(d["y1"])],
            }
        )
    return (
        f"t={int(d['t'])} window={int(d['window'])} map={int(d['map'])} "
        f"x={float(d['x']):.1f} y={float(d['y']):.1f} "
        f"box={int(d['x0'])},{int(d['y0'])},{int(d['x1'])},{int(d['y1'])}"
    )


class _Summary:
    """The live rate line on stderr."""

    def __init__(self, every: float, err: TextIO) -> None:
        self.every = every
        self.err = err
        self.start = time.monotonic()
        self.last = self.start

    def maybe(self, detector: Any, source: Any, rejected: int) -> None:
        now = time.monotonic()
        if self.every > 0 and now - self.last >= self.every:
            self.last = now
            self.write(detector, source, rejected, final=False)

    def write(self, detector: Any, source: Any, rejected: int, *, final: bool) -> None:
        wall = max(time.monotonic() - self.start, 1e-9)
        s = source.stats
        print(
            f"uavsnn detect: {'done' if final else 'live'} {wall:.1f}s "
            f"events={detector.events_seen} ({detector.events_seen / wall:,.0f} ev/s, "
            f"engine {detector.rate:,.0f} ev/s) windows={detector.windows_opened} "
            f"detections={detector.detections_emitted} packets={s.packets} "
            f"dropped={s.dropped + rejected}",
            file=self.err,
            flush=True,
        )


def run(args: argparse.Namespace) -> int:
    """Run detection until the source ends (or Ctrl-C); returns the exit code."""
    from uavsnn.detector import Detector
    from uavsnn.network import Network
    from uavsnn.sources import UdpSource, open_source

    if args.window_ms <= 0:
        raise ParameterError(f"--window-ms must be > 0, got {args.window_ms}")
    if args.more_sources or args.ray is not None:
        return _run_many(args)
    network = Network.load(args.model)
    model_size = (int(network.config["width"]), int(network.config["height"]))
    # '-' and UDP carry no sensor size: default to the model's; a file has its own.
    live = args.source == "-" or args.source.startswith("udp://")
    sensor_size = _sensor_size(args.sensor_size) or (model_size if live else None)
    source = open_source(
        args.source,
        sensor_size=sensor_size,
        realtime=args.realtime,
        stdin_format=args.stdin_format,
        udp_format=args.udp_format,
        max_packets=args.max_packets,
        idle_timeout=args.idle_timeout,
        downsample_to=model_size if args.downsample else None,
    )
    out, err = sys.stdout, sys.stderr
    with source:
        detector = Detector(
            network,
            window_us=round(args.window_ms * 1000),
            overlap=args.overlap,
            sensor_size=source.sensor_size,
        )
        if isinstance(source, UdpSource):
            host, port = source.address
            print(f"uavsnn detect: listening on udp://{host}:{port}", file=err, flush=True)
        summary = _Summary(args.summary_every, err)
        rejected = 0
        try:
            for chunk in source:
                try:
                    found = detector.push(chunk)
                except (EventError, StreamError) as exc:
                    rejected += 1
                    if rejected <= 5:
                        print(f"uavsnn detect: dropped a chunk: {exc}", file=err, flush=True)
                    continue
                for d in found:
                    print(_format(d, args.json), file=out, flush=True)
                summary.maybe(detector, source, rejected)
            for d in detector.flush():
                print(_format(d, args.json), file=out, flush=True)
        except KeyboardInterrupt:
            for d in detector.flush():
                print(_format(d, args.json), file=out, flush=True)
        except BrokenPipeError:
            # The reader went away (``| head``): stop quietly, as command-line tools do.
            os.dup2(os.open(os.devnull, os.O_WRONLY), out.fileno())
        summary.write(detector, source, rejected, final=True)
    return 0


def _run_many(args: argparse.Namespace) -> int:
    """Several streams at once, one Detector per stream in a Ray actor (docs/distributed.md):
    detections as they come, each line led by its stream's name; a stream that fails is
    reported and the others go on (exit 1 when any failed)."""
    from uavsnn.distributed import detect_streams, runner_for
    from uavsnn.network import Network

    sources = [args.source, *args.more_sources]
    if "-" in sources:
        raise ParameterError("standard input ('-') cannot be one of several streams")
    if len(set(sources)) != len(sources):
        raise ParameterError("a source is named twice")
    if args.ray is None:
        raise ParameterError("several sources need --ray (one detector per stream, on Ray)")
    network = Network.load(args.model)
    runner = runner_for(args.ray)
    out, err = sys.stdout, sys.stderr

    def ready(addresses: dict[str, tuple[str, int] | None], _actors: Any) -> None:
        for name, address in addresses.items():
            if address is not None:
                print(f"uavsnn detect: {name}: listening on udp://{address[0]}:{address[1]}",
                      file=err, flush=True)  # fmt: skip

    def found(name: str, detections: np.ndarray) -> None:
        for d in detections:
            if args.json:
                print(json.dumps({"stream": name, **json.loads(_format(d, True))}), file=out)
            else:
                print(f"[{name}] {_format(d, False)}", file=out)
        out.flush()

    results = detect_streams(
        runner, sources, network, window_us=round(args.window_ms * 1000),
        overlap=args.overlap, on_ready=ready, on_detections=found,
        sensor_size=_sensor_size(args.sensor_size), realtime=args.realtime,
        udp_format=args.udp_format, max_packets=args.max_packets,
        idle_timeout=args.idle_timeout, downsample=args.downsample,
    )  # fmt: skip
    for r in results.values():
        state = "done" if r.ok else f"failed ({r.error})"
        print(
            f"uavsnn detect: {r.name}: {state} events={r.events} windows={r.windows} "
            f"detections={len(r.detections)} packets={r.packets} "
            f"dropped={r.dropped} rejected_events={r.rejected_events}",
            file=err, flush=True,
        )  # fmt: skip
    return 0 if all(r.ok for r in results.values()) else 1
