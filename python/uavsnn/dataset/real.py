"""Real labelled footage: folders laid out like the Svanström drone-detection dataset.

A folder holds videos named ``<PREFIX>_<CLASS>_<ID>.<ext>`` (``V_DRONE_001.mp4``,
``V_BIRD_012.avi``...) and beside each a ``.csv`` of the same name with the header
``frame,x,y,w,h``: one row per frame, frames counted from 1, the box's top-left corner and size
in pixels of the video; an empty box means no target in that frame. Frames without a row
(past the last one, or skipped) are unlabelled and are never scored. ``DRONE`` (or ``UAV``) is
the UAV class; every other class (``BIRD``, ``AIRPLANE``, ``HELICOPTER``...) is not a UAV, and
a class that holds ``DRONE`` or ``UAV`` without being one of them (``DRONES``) is refused.

The videos become events through the "sim" path (:func:`uavsnn.sim.video_to_recording`:
PIX2NVS on the frames cropped, centred, to the sensor's aspect ratio, events pooled onto the
sensor), and the boxes follow the same crop and scale.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from uavsnn.errors import DatasetError
from uavsnn.scenes import LABEL_DTYPE, UAV_CLASS
from uavsnn.sim.video import probe_video

__all__ = [
    "MAX_ROWS_PAST_END",
    "UAV_NAMES",
    "VIDEO_SUFFIXES",
    "Clip",
    "boxes_to_sensor",
    "clip_labels",
    "crop_box",
    "find_clips",
    "read_boxes",
]

VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".m4v", ".webm", ".mpg", ".mpeg")
#: Class names (case-insensitive) that mean a UAV.
UAV_NAMES = ("DRONE", "UAV")
_NAME = re.compile(r"^(?P<prefix>[A-Za-z0-9]+)_(?P<cls>[A-Za-z]+)_(?P<id>[A-Za-z0-9]+)$")
_PATTERN = "<PREFIX>_<CLASS>_<ID>"
_PATTERN_RULE = "PREFIX and ID ASCII letters and digits, CLASS ASCII letters"
#: The most box-file rows past a video's last frame (as its container counts them) that are
#: ignored: 77 of the 140 svanstrom-dev clips have one. More are labels made at another frame
#: rate or for another video, and refused.
MAX_ROWS_PAST_END = 2


@dataclass(frozen=True)
class Clip:
    """One labelled video: its ``name`` (the file stem), paths, class (lower case:
    ``"drone"``, ``"bird"``...) and whether that class is a UAV."""

    name: str
    video: Path
    boxes: Path
    cls: str
    uav: bool


def find_clips(folder: str | Path) -> list[Clip]:
    """The labelled videos of ``folder``, sorted by name.

    A clip is a video (a suffix in :data:`VIDEO_SUFFIXES`) named ``<PREFIX>_<CLASS>_<ID>``:
    ``PREFIX`` and ``ID`` ASCII letters and digits, ``CLASS`` ASCII letters, joined by single
    underscores. Other files are left alone, but a video otherwise named with a ``.csv`` of
    its name beside it is meant as a clip, and refused.

    Raises:
        DatasetError: the folder is missing or holds no video named ``<PREFIX>_<CLASS>_<ID>``,
            a video so named is a link to nothing (a clip that cannot be read is an error,
            never a clip left out), a video has no ``.csv`` beside it, a video with a ``.csv``
            beside it is not so named, or two videos have one name (``V_DRONE_001.avi`` and
            ``V_DRONE_001.mp4``: one box file, and two clips of one name that could land in
            different splits), or a class holds ``DRONE`` or ``UAV`` but is not one of
            :data:`UAV_NAMES` (``LAB_DRONES_1`` would be a non-UAV class ``drones``).
    """
    root = Path(folder)
    if not root.is_dir():
        raise DatasetError(f"video folder {root} does not exist or is not a folder")
    clips = []
    named: dict[str, Path] = {}  # the clips' videos by name
    for path in sorted(root.iterdir(), key=lambda p: p.name):  # as on every OS
        if path.suffix.lower() not in VIDEO_SUFFIXES:
            continue
        boxes = path.with_suffix(".csv")
        m = _NAME.match(path.stem)
        if m is None:
            if (path.is_file() or path.is_symlink()) and (boxes.is_file() or boxes.is_symlink()):
                raise DatasetError(
                    f"video {path.name} in {root} has a box file {boxes.name} but its name is not "
                    f"{_PATTERN} ({_PATTERN_RULE}, e.g. V_DRONE_001): rename the video and its "
                    ".csv"
                )
            continue
        if path.is_symlink() and not path.exists():
            raise DatasetError(
                f"video {path.name} in {root} is a link to nothing (it points to {path.readlink()})"
            )
        if not path.is_file():
            continue  # a folder so named: not a clip
        if not boxes.is_file():
            if boxes.is_symlink() and not boxes.exists():
                raise DatasetError(
                    f"video {path.name}'s box file {boxes.name} is a link to nothing "
                    f"(it points to {boxes.readlink()})"
                )
            raise DatasetError(f"video {path.name} has no box file {boxes.name} beside it")
        if path.stem in named:
            raise DatasetError(
                f"videos {named[path.stem].name} and {path.name} in {root} have one name (and "
                f"one box file, {boxes.name}): keep one of them, or rename the other with its "
                "own .csv"
            )
        named[path.stem] = path
        cls_name = m.group("cls").upper()
        uav = cls_name in UAV_NAMES
        if not uav and any(name in cls_name for name in UAV_NAMES):
            # A drone clip misnamed would be a non-UAV class: its drone labelled "no UAV".
            raise DatasetError(
                f"video {path.name} in {root} has class {m.group('cls')}, which is not a UAV "
                f"class ({' or '.join(UAV_NAMES)}, in any case) but holds one: name a drone "
                f"clip <PREFIX>_DRONE_<ID> (e.g. V_DRONE_001), and another class without "
                f"{' or '.join(UAV_NAMES)} in it; rename the video and its .csv"
            )
        clips.append(Clip(path.stem, path, boxes, UAV_CLASS if uav else cls_name.lower(), uav))
    if not clips:
        raise DatasetError(
            f"no labelled videos in {root}: expected files named like V_DRONE_001.mp4 "
            f"({_PATTERN} with a suffix in {', '.join(VIDEO_SUFFIXES)}) and a .csv "
            f"of the same name"
        )
    return clips


def read_boxes(
    path: str | Path, video_size: tuple[int, int] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Read a ``frame,x,y,w,h`` box file: ``(frames, boxes)``, frame numbers from 1 (int64)
    and ``(x0, y0, x1, y1)`` float32 boxes, NaN for rows with an empty box.

    The file is UTF-8, with or without a byte-order mark (Excel's "CSV UTF-8"); rows with
    nothing in them (blank lines, ``,,,,``) are skipped. With ``video_size`` (width, height),
    a box wholly outside the video's frame is refused (a box that only reaches past its edge
    is kept: the sensor sees the part inside the crop).

    Raises:
        DatasetError: unreadable file, wrong header, a malformed row (named by line), a box of
            zero or negative size, frame numbers below 1 or not increasing, a box wholly
            outside the ``video_size`` frame.
    """
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8-sig") as f:
            reader = csv.reader(f)
            # (line, row) of the rows with something in them; line numbers as an editor's.
            rows = [(reader.line_num, r) for r in reader if any(c.strip() for c in r)]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise DatasetError(f"cannot read box file {path}: {exc}") from exc
    if not rows:
        raise DatasetError(f"box file {path} is empty; expected the header frame,x,y,w,h")
    header = [c.strip().lower() for c in rows[0][1]]
    if header != ["frame", "x", "y", "w", "h"]:
        raise DatasetError(f"box file {path} has header {rows[0][1]}, expected frame,x,y,w,h")
    frames = np.zeros(len(rows) - 1, dtype=np.int64)
    boxes = np.full((len(rows) - 1, 4), np.nan, dtype=np.float32)
    for i, (line, row) in enumerate(rows[1:]):
        cells = [c.strip() for c in row]
        if len(cells) != 5:
            raise DatasetError(f"{path}:{line}: expected 5 fields frame,x,y,w,h, got {row}")
        try:
            frames[i] = int(cells[0])
        except ValueError as exc:
            raise DatasetError(f"{path}:{line}: frame {cells[0]!r} is not an integer") from exc
        if frames[i] < 1 or (i > 0 and frames[i] <= frames[i - 1]):
            raise DatasetError(
                f"{path}:{line}: frame numbers must start at 1 and increase, got {frames[i]}"
                + (f" after {frames[i - 1]}" if i > 0 else "")
            )
        vals = cells[1:]
        if all(v == "" for v in vals):
            continue
        try:
            x, y, w, h = (float(v) for v in vals)
        except ValueError as exc:
            raise DatasetError(f"{path}:{line}: box {vals} is not four numbers or empty") from exc
        if not all(math.isfinite(v) for v in (x, y, w, h)) or w <= 0 or h <= 0:
            raise DatasetError(f"{path}:{line}: box {vals} must be finite with w, h > 0")
        if video_size is not None and (
            x >= video_size[0] or y >= video_size[1] or x + w <= 0 or y + h <= 0
        ):
            raise DatasetError(
                f"{path}:{line}: box {vals} lies wholly outside the video's "
                f"{video_size[0]}x{video_size[1]} frame (x, y, w, h are pixels of the video, "
                "from its top-left corner): labels made for another video or size?"
            )
        boxes[i] = (x, y, x + w, y + h)
    return frames, boxes


def crop_box(
    video_size: tuple[int, int], sensor_size: tuple[int, int]
) -> tuple[int, int, int, int]:
    """``(x0, y0, width, height)`` of the centred crop of a ``video_size`` frame to the
    sensor's aspect ratio — the crop :func:`uavsnn.sim.crop_to_aspect` takes."""
    w, h = video_size
    aspect = sensor_size[0] / sensor_size[1]
    if w / h > aspect:
        cw = min(w, max(1, round(h * aspect)))
        return (w - cw) // 2, 0, cw, h
    ch = min(h, max(1, round(w / aspect)))
    return 0, (h - ch) // 2, w, ch


def boxes_to_sensor(
    labels: np.ndarray, video_size: tuple[int, int], sensor_size: tuple[int, int]
) -> np.ndarray:
    """Frame labels in video pixels to sensor pixels: the centred crop, the scale, clipping to
    the sensor; a box left with less than a pixel's width or height on the sensor (unless it
    was smaller than that to start with) is no longer visible (``cls`` ``"none"``, NaN box,
    range and size). ``size_px`` is scaled with the box; ``range_m`` is kept."""
    x0, y0, cw, ch = crop_box(video_size, sensor_size)
    sx, sy = sensor_size[0] / cw, sensor_size[1] / ch
    out = labels.copy()
    bx0 = (labels["x0"] - x0) * sx
    by0 = (labels["y0"] - y0) * sy
    bx1 = (labels["x1"] - x0) * sx
    by1 = (labels["y1"] - y0) * sy
    cx0, cy0 = np.maximum(bx0, 0), np.maximum(by0, 0)
    cx1, cy1 = np.minimum(bx1, sensor_size[0]), np.minimum(by1, sensor_size[1])
    with np.errstate(invalid="ignore"):
        visible = (
            (cx1 - cx0 >= np.minimum(1.0, bx1 - bx0))
            & (cy1 - cy0 >= np.minimum(1.0, by1 - by0))
            & (cx1 > cx0)
            & (cy1 > cy0)
        )
    visible &= labels["cls"] != "none"
    out["x0"], out["y0"], out["x1"], out["y1"] = cx0, cy0, cx1, cy1
    out["uav"] = labels["uav"] & visible
    out["cls"] = np.where(visible, labels["cls"], "none")
    # The crop has the sensor's aspect ratio, so sx and sy differ by rounding only.
    out["size_px"] = labels["size_px"] * np.float32((sx + sy) / 2)
    for k in ("x0", "y0", "x1", "y1", "range_m", "size_px"):
        out[k] = np.where(visible, out[k], np.nan)
    return out


def clip_labels(
    clip: Clip,
    n_frames: int,
    video_size: tuple[int, int],
    sensor_size: tuple[int, int],
    *,
    video_frames: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Per frame of the video's first ``n_frames``: labels in sensor pixels and whether the
    frame is labelled.

    Rows for frames the video does not have are ignored, up to :data:`MAX_ROWS_PAST_END` past
    its last one; frames without a row are unlabelled. The range of a filmed object is unknown
    (NaN); its size is the longer side of its box. ``video_frames`` is the video's frame count
    as its container reports it (:func:`uavsnn.sim.probe_video`, which is asked when it is not
    given; 0: unknown, not checked); ``n_frames`` may be fewer, to label only the first frames.

    Raises:
        DatasetError: a bad box file (:func:`read_boxes`, with ``video_size``), or one with
            rows for more than :data:`MAX_ROWS_PAST_END` frames past the video's last.
    """
    frames, boxes = read_boxes(clip.boxes, video_size)
    if video_frames is None:
        video_frames = probe_video(clip.video).frame_count
    # A count of 0 is a container that does not know it: nothing to check against.
    if len(frames) and 0 < video_frames < frames[-1] - MAX_ROWS_PAST_END:
        past = int((frames > video_frames).sum())
        raise DatasetError(
            f"box file {clip.boxes} has {len(frames)} rows, to frame {frames[-1]}, but video "
            f"{clip.video.name} has {video_frames} frames ({past} of the rows past its end; "
            f"rows up to {MAX_ROWS_PAST_END} frames past it are ignored): labels made at "
            "another frame rate or for another video?"
        )
    labels = np.zeros(n_frames, dtype=LABEL_DTYPE)
    labels["cls"] = "none"
    for k in ("x0", "y0", "x1", "y1", "range_m", "size_px"):
        labels[k] = np.nan
    labelled = np.zeros(n_frames, dtype=bool)
    idx = frames - 1
    keep = idx < n_frames
    idx, boxes = idx[keep], boxes[keep]
    labelled[idx] = True
    has = ~np.isnan(boxes[:, 0])
    target = idx[has]
    labels["cls"][target] = clip.cls
    labels["uav"][target] = clip.uav
    for j, k in enumerate(("x0", "y0", "x1", "y1")):
        labels[k][target] = boxes[has, j]
    labels["size_px"][target] = np.maximum(
        boxes[has, 2] - boxes[has, 0], boxes[has, 3] - boxes[has, 1]
    )
    return boxes_to_sensor(labels, video_size, sensor_size), labelled
