"""PIX2NVS's adaptive threshold on a labelled drone clip: why the "sim" path runs ``adaptive=0``.

A pixel whose log luma stays below PIX2NVS's threshold θ multiplies its θ by ``1 - adaptive``
at every frame (0.05 compiled into the released program), so after a few seconds of a still
sky θ is small enough for video-compression noise to cross it everywhere. This simulates one
labelled clip (``V_DRONE_001`` of the development data by default) whole through the "sim" path
to 240×180, as ``uavsnn dataset build --domain real`` does, under each setting of the table in
docs/simulation.md ("Why ``adaptive = 0``"), and counts:

- its events;
- the share of them inside the labelled drone's box, widened by ``--margin`` px on the sensor
  (the box of the frame each event's time falls in; frames without a box count as outside);
- the events per frame after ``--after`` seconds, once an adaptive threshold has had time to
  fall.

    python benches/python/pix2nvs_adaptive.py
    python benches/python/pix2nvs_adaptive.py --seconds 5 \\
        --clip ../shared/data/svanstrom-dev/V_DRONE_002.mp4

Counts depend on the video decoder (OpenCV's FFmpeg), not on the CPU.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from uavsnn.dataset.real import clip_labels, find_clips
from uavsnn.sim import Pix2NvsParams, probe_video, video_to_recording

SENSOR = (240, 180)
DEFAULT_CLIP = Path(__file__).resolve().parents[3] / "shared/data/svanstrom-dev/V_DRONE_001.mp4"

#: The table's settings: a name and the parameters (PIX2NVS's own defaults, ours, ours with the
#: adaptive threshold bounded, and PIX2NVS README's worked example).
SETTINGS = {
    "PIX2NVS defaults (adaptive=0.05)": Pix2NvsParams(adaptive=0.05),
    "adaptive=0 (our default)": Pix2NvsParams(),
    "adaptive=0.05, bounds [0.3, 0.7]": Pix2NvsParams(
        adaptive=0.05, threshold_min=0.3, threshold_max=0.7
    ),
    "README example (-r 3 -a 0 -b 4)": Pix2NvsParams(
        reference="event_increment", adaptive=0.0, block_size=4
    ),
}


def measure(
    clip: Path, params: Pix2NvsParams, margin: float, after_s: float, seconds: float | None
) -> dict:
    """The events of ``clip`` (its first ``seconds``, or whole) through the "sim" path with
    ``params``, and what they hold."""
    (labelled,) = [c for c in find_clips(clip.parent) if c.video == clip]
    info = probe_video(clip)
    most = None if seconds is None else max(1, round(seconds * info.fps))
    rec = video_to_recording(clip, "sim", size=SENSOR, params=params, max_frames=most)
    fps = float(rec.metadata["fps"])
    frames = int(rec.metadata["frames"])
    labels, _ = clip_labels(labelled, frames, (info.width, info.height), SENSOR)
    ev = rec.events
    # The frame each event's time falls in (frame i at round(i * 1e6 / fps) µs).
    k = np.clip(np.round(ev["t"].astype(np.float64) * fps / 1e6).astype(np.int64), 0, frames - 1)
    box = labels[k]
    x, y = ev["x"].astype(np.float64) + 0.5, ev["y"].astype(np.float64) + 0.5
    with np.errstate(invalid="ignore"):
        inside = (
            (x >= box["x0"] - margin)
            & (x <= box["x1"] + margin)
            & (y >= box["y0"] - margin)
            & (y <= box["y1"] + margin)
        )
    late_frames = max(frames - int(np.ceil(after_s * fps)), 0)
    late = int(np.count_nonzero(ev["t"] >= np.uint64(round(after_s * 1e6))))
    return {
        "events": len(ev),
        "in_box_share": float(inside.mean()) if len(ev) else None,
        "events_per_frame_after": late / late_frames if late_frames else None,
        "frames": frames,
        # The widened box's area over the frame's, mean over the frames with a box.
        "box_share_of_frame": float(
            np.nanmean(
                (labels["x1"] - labels["x0"] + 2 * margin)
                * (labels["y1"] - labels["y0"] + 2 * margin)
            )
            / (SENSOR[0] * SENSOR[1])
        ),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--clip", type=Path, default=DEFAULT_CLIP, help="a labelled video")
    parser.add_argument("--margin", type=float, default=5.0, help="box widening, px (5)")
    parser.add_argument("--after", type=float, default=8.0, help="seconds before the late count")
    parser.add_argument("--seconds", type=float, default=None, help="the clip's first seconds")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args(argv)
    if not args.clip.is_file():
        print(f"no clip at {args.clip}: give --clip", file=sys.stderr)
        return 2
    rows = {
        name: measure(args.clip, p, args.margin, args.after, args.seconds)
        for name, p in SETTINGS.items()
    }
    if args.json:
        print(json.dumps({"clip": args.clip.name, "rows": rows}, indent=2))
        return 0
    print(f"{args.clip.name}, sim path to {SENSOR[0]}x{SENSOR[1]}, box widened by "
          f"{args.margin:g} px")  # fmt: skip
    print(f"| setting | events | share of events in the drone's box | events per frame after "
          f"{args.after:g} s |")  # fmt: skip
    print("|---|---|---|---|")
    for name, r in rows.items():
        share = "–" if r["in_box_share"] is None else f"{100 * r['in_box_share']:.1f} %"
        late = "–" if r["events_per_frame_after"] is None else f"{r['events_per_frame_after']:.0f}"
        print(f"| {name} | {r['events']:,} | {share} | {late} |")
    box = next(iter(rows.values()))["box_share_of_frame"]
    print(f"the widened box covers {100 * box:.1f} % of the frame (mean over the labelled frames)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
