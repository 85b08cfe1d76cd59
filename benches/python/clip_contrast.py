"""Why a real clip's UAV gives the network no events: how much it changes the video.

PIX2NVS (``uavsnn.sim.pix2nvs``) fires a pixel when its log luma ``B = ln(Y + offset)`` (``Y``
the BT.601 luma, in floating point) changes by its threshold ``θ`` (0.4 by default) from one
frame to the next. For each clip with a labelled UAV in a real-footage dataset's split (the
clips ``uavsnn evaluate --clips`` streams, ``uavsnn.clips.clip_set``), per frame with a
labelled UAV, in the video's own pixels inside the labelled box:

- **change**: the largest ``|ΔB|`` of a box pixel from the frame before (what PIX2NVS compares
  with ``θ``), and the share of frames where it reaches the dataset's ``θ``;
- **contrast**: the largest ``|B − m|`` of a box pixel, ``m`` the median ``B`` of a ring of
  ``--ring`` pixels around the box: how far the UAV stands out from what surrounds it.

Each is the median over the clip's frames. With ``--clips FILE`` (``uavsnn evaluate MODEL
DATASET --clips --json``) each clip's row also says whether a track alarmed under the
any-spike rule and its median events per window on the labelled box::

    uavsnn evaluate MODEL DATASET --clips --json > clips.json
    python benches/python/clip_contrast.py DATASET --clips clips.json [--videos DIR]

``--windows`` counts instead, over the split's UAV windows (any dataset with raw events), the
events inside the labelled box during the window (``uavsnn.clips.box_events``): how many
windows give the network at most 0, 1, 2, 5, 10 or 20 events from the UAV itself::

    python benches/python/clip_contrast.py DATASET --windows
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn.clips import box_events, clip_set
from uavsnn.dataset import load
from uavsnn.dataset.real import read_boxes
from uavsnn.sim.video import iter_video

#: BT.601 luma weights of blue, green, red (OpenCV's channel order).
BGR_LUMA = np.array([0.114, 0.587, 0.299])


def clip_contrast(video: Path, boxes: Path, theta: float, offset: float, ring: int) -> dict:
    """The clip's medians over its frames with a labelled box (see the module's docs)."""
    frames, labelled = read_boxes(boxes)
    box_of = {int(f) - 1: b for f, b in zip(frames, labelled, strict=True) if np.isfinite(b[0])}
    change, contrast = [], []
    before = None
    for k, (frame, _) in enumerate(iter_video(video, size=None, color="bgr")):
        b = np.log(frame.astype(np.float64) @ BGR_LUMA + offset)
        if k in box_of:
            h, w = b.shape
            x0, y0, x1, y1 = box_of[k]
            c0, r0 = max(0, int(np.floor(x0))), max(0, int(np.floor(y0)))
            c1, r1 = min(w, int(np.ceil(x1))), min(h, int(np.ceil(y1)))
            if c1 > c0 and r1 > r0:
                inside = b[r0:r1, c0:c1]
                around = b[max(0, r0 - ring) : r1 + ring, max(0, c0 - ring) : c1 + ring].copy()
                around[r0 - max(0, r0 - ring) : r1 - max(0, r0 - ring),
                       c0 - max(0, c0 - ring) : c1 - max(0, c0 - ring)] = np.nan  # fmt: skip
                contrast.append(float(np.nanmax(np.abs(inside - np.nanmedian(around)))))
                if before is not None:
                    change.append(float(np.abs(inside - before[r0:r1, c0:c1]).max()))
        before = b
    changes = np.asarray(change)
    return {
        "frames": len(contrast),
        "change": float(np.median(changes)) if len(changes) else None,
        "past_threshold": float(np.mean(changes >= theta)) if len(changes) else None,
        "contrast": float(np.median(contrast)) if contrast else None,
    }


def rows(dataset: str, split: str, videos: str | None, ring: int) -> list[dict[str, Any]]:
    """One row per real clip of the split with a labelled UAV."""
    out = []
    for whole in clip_set(dataset, split, videos).clips:
        if whole.real is None:
            continue
        _, _, plan, params = whole.real
        if not plan.frame_labels["uav"][plan.labelled].any():
            continue
        theta = params.threshold
        row = clip_contrast(plan.clip.video, plan.clip.boxes, theta, params.log_offset, ring)
        out.append({"clip": whole.name, "threshold": theta, **row})
    return out


#: The event counts ``--windows`` reports the share of UAV windows at or below.
AT_MOST = (0, 1, 2, 5, 10, 20)


def window_events(dataset: str, split: str) -> np.ndarray:
    """Each UAV window's events inside its labelled box during the window."""
    data = load(dataset, split)
    if data.raw is None:
        raise SystemExit(f"{dataset}: the {split} split holds no raw events")
    length = data.windows.length_us
    out = []
    for i in np.flatnonzero(data.label).tolist():
        t0 = np.asarray([data.windows.t0[i]], dtype=np.uint64)
        out.append(int(box_events(data.raw.window(i), t0, length, data.box[i : i + 1])[0]))
    return np.asarray(out, dtype=np.int64)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset")
    parser.add_argument("--split", default="test")
    parser.add_argument("--videos", help="the clips' folder (default: the manifest's)")
    parser.add_argument("--ring", type=int, default=6, help="pixels around the box (6)")
    parser.add_argument("--clips", help="uavsnn evaluate --clips --json output, for alarms")
    parser.add_argument("--windows", action="store_true", help="events on the UAV per window")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.windows:
        counts = window_events(args.dataset, args.split)
        shares = {k: float(np.mean(counts <= k)) if len(counts) else None for k in AT_MOST}
        if args.json:
            print(json.dumps({"uav_windows": len(counts), "at_most": shares}, indent=2))
            return
        print(f"| events on the UAV's box in the window | UAV windows (of {len(counts)}) |")
        print("|---|---|")
        for k, share in shares.items():
            cell = "–" if share is None else f"{100 * share:.1f} %"
            print(f"| {'none' if k == 0 else f'at most {k}'} | {cell} |")
        return
    table = rows(args.dataset, args.split, args.videos, args.ring)
    if args.clips:
        streamed = json.loads(Path(args.clips).read_text(encoding="utf-8"))
        if "per_clip" not in streamed:  # the whole of `uavsnn evaluate --json`
            streamed = streamed["clips"]
        per_clip = {r["clip"]: r for r in streamed["per_clip"]}
        for row in table:
            r = per_clip.get(row["clip"])
            if r is not None:
                row["alarmed"] = r["rules"]["any_spike"]["alarmed"]
                row["uav_events_per_window"] = r["uav_events_per_window"]
                row["uav_size_px"] = r["uav_size_px"]
    if args.json:
        print(json.dumps(table, indent=2))
        return
    theta = table[0]["threshold"] if table else float("nan")
    print(
        f"| clip | UAV size (px, sensor) | events per window on it | any-spike alarm "
        f"| largest change of log luma, median | frames past θ = {theta:g} "
        f"| contrast with its surroundings, median |"
    )
    print("|---|---|---|---|---|---|---|")

    def fmt(v: Any, spec: str) -> str:
        return "–" if v is None else format(v, spec)

    for row in sorted(table, key=lambda r: r["contrast"] if r["contrast"] is not None else 0):
        alarmed = "–" if "alarmed" not in row else ("yes" if row["alarmed"] else "no")
        past = row["past_threshold"]
        print(
            f"| {row['clip']} | {fmt(row.get('uav_size_px'), '.1f')} "
            f"| {fmt(row.get('uav_events_per_window'), 'g')} | {alarmed} "
            f"| {fmt(row['change'], '.3f')} | {'–' if past is None else f'{100 * past:.0f} %'} "
            f"| {fmt(row['contrast'], '.3f')} |"
        )


if __name__ == "__main__":
    main()
