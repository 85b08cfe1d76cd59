"""``uavsnn simulate``: turn a video into an event recording (``.npz``), optionally with a PNG
strip of event frames to look at.

Examples::

    uavsnn simulate clip.mp4 -o clip.npz --mode sim --size 240x180 --preview clip.png
    uavsnn simulate render.avi -o render.npz --mode dvs --seed 3 --json
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn.events import Recording
from uavsnn.sim import video_to_recording, write_preview
from uavsnn.sim.checks import check_size

__all__ = ["register", "run", "write_recording"]


def register(subparsers: Any) -> None:
    """Add the ``simulate`` sub-command."""
    parser = subparsers.add_parser(
        "simulate",
        help="turn a video into events (PIX2NVS 'sim' or DVS emulation 'dvs')",
        description=(
            "Turn a video into an event recording. 'sim' is PIX2NVS as the paper used it "
            "(simulated at full resolution, events pooled onto the sensor); 'dvs' emulates a "
            "DVS with noise on frames resized to the sensor."
        ),
    )
    parser.add_argument("video", type=Path, help="input video (any format OpenCV reads)")
    parser.add_argument("-o", "--output", type=Path, required=True, help="output .npz")
    parser.add_argument("--mode", choices=("sim", "dvs"), default="sim")
    parser.add_argument("--size", default="240x180", help="sensor WIDTHxHEIGHT (240x180)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the dvs noise (0)")
    parser.add_argument(
        "--downsample",
        choices=("events", "frames"),
        default=None,
        help="sim only: pool events after simulating at full resolution (events, default) "
        "or resize frames first (frames)",
    )
    parser.add_argument("--max-frames", type=int, default=None, help="stop after N frames")
    parser.add_argument("--fps", type=float, default=None, help="override the video's rate")
    parser.add_argument("--preview", type=Path, default=None, help="write a PNG strip here")
    parser.add_argument("--json", action="store_true", help="print a JSON summary")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.set_defaults(handler=run)


def write_recording(recording: Recording, path: Path) -> None:
    """Write ``recording`` as ``.npz`` (arrays ``events``, ``sensor_size``, and ``metadata`` as
    JSON text) atomically; uses :func:`uavsnn.io.write_npz` when the package has it."""
    try:
        from uavsnn.io import write_npz  # type: ignore[import-not-found,attr-defined]
    except ImportError:
        write_npz = None
    if write_npz is not None:
        write_npz(recording, path)
        return
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".npz", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(
                fh,
                events=recording.events,
                sensor_size=np.asarray(recording.sensor_size, dtype=np.int64),
                metadata=np.asarray(json.dumps(recording.metadata)),
            )
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def run(args: argparse.Namespace) -> int:
    """Handler of ``uavsnn simulate``."""
    size = check_size(args.size)
    if args.output.suffix.lower() != ".npz":
        print(
            f"uavsnn simulate: error: output must end in .npz, got {args.output}", file=sys.stderr
        )
        return 2
    recording = video_to_recording(
        args.video,
        args.mode,
        size,
        args.seed,
        downsample=args.downsample,
        max_frames=args.max_frames,
        fps=args.fps,
        progress=not (args.quiet or args.json),
    )
    write_recording(recording, args.output)
    if args.preview is not None:
        write_preview(recording, args.preview)
    ev = recording.events
    duration_s = recording.metadata["frames"] / recording.metadata["fps"]
    summary = {
        "output": str(args.output),
        "preview": None if args.preview is None else str(args.preview),
        "mode": args.mode,
        "sensor_size": list(recording.sensor_size),
        "frames": recording.metadata["frames"],
        "events": len(ev),
        "on_fraction": float(ev["p"].mean()) if len(ev) else 0.0,
        "events_per_second": len(ev) / duration_s if duration_s > 0 else 0.0,
        "seed": args.seed,
    }
    if args.json:
        print(json.dumps(summary))
    else:
        print(
            f"{summary['events']} events from {summary['frames']} frames "
            f"({summary['events_per_second']:.0f} ev/s, {summary['on_fraction']:.0%} ON) "
            f"-> {args.output}"
        )
    return 0
