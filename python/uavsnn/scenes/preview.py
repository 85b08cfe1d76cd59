"""Pictures of rendered scenes, so that a person can look at what the renderer made."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from uavsnn._files import write_image
from uavsnn.errors import ParameterError, ShapeError

__all__ = ["contact_sheet", "sheet_frames", "write_png"]


def sheet_frames(n: int, count: int) -> np.ndarray:
    """The indices of the frames :func:`contact_sheet` shows of ``n``: ``count`` spread over
    the clip, from the first to the last (fewer when ``n`` is smaller)."""
    return np.unique(np.linspace(0, n - 1, min(count, n)).astype(int))


def contact_sheet(
    frames: np.ndarray,
    labels: np.ndarray | None = None,
    *,
    count: int = 8,
    columns: int = 4,
    scale: float = 1.0,
) -> np.ndarray:
    """A grid of ``count`` frames spread over the clip, as 8-bit BGR, with each frame's label
    box drawn (green for a UAV, orange for another object) and its class written."""
    if frames.ndim not in (3, 4) or len(frames) == 0:
        raise ShapeError(f"frames must be (n, h, w) or (n, h, w, 3), got {frames.shape}")
    if count < 1 or columns < 1 or not scale > 0:
        raise ParameterError(
            f"count, columns and scale must be positive: {count}, {columns}, {scale}"
        )
    picks = sheet_frames(len(frames), count)
    tiles = []
    for k in picks:
        f = frames[k]
        if f.dtype != np.uint8:
            # Linear intensity: show it gamma-encoded, as a camera would.
            f = (np.clip(f / 255.0, 0, 1) ** (1 / 2.2) * 255).astype(np.uint8)
        if f.ndim == 2:
            f = cv2.cvtColor(f, cv2.COLOR_GRAY2BGR)
        f = np.ascontiguousarray(f)
        if scale != 1.0:
            f = cv2.resize(f, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
        if labels is not None and labels[k]["cls"] != "none":
            lab = labels[k]
            colour = (0, 220, 0) if lab["uav"] else (0, 140, 255)
            p0 = (math.floor(lab["x0"] * scale) - 1, math.floor(lab["y0"] * scale) - 1)
            p1 = (math.ceil(lab["x1"] * scale), math.ceil(lab["y1"] * scale))
            cv2.rectangle(f, p0, p1, colour, 1)
            cv2.putText(
                f,
                str(lab["cls"]),
                (p0[0], max(p0[1] - 3, 10)),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.35,
                colour,
                1,
                cv2.LINE_AA,
            )
        tiles.append(f)
    h, w = tiles[0].shape[:2]
    rows = math.ceil(len(tiles) / columns)
    sheet = np.zeros((rows * (h + 2), min(columns, len(tiles)) * (w + 2), 3), dtype=np.uint8)
    for i, tile in enumerate(tiles):
        r, c = divmod(i, columns)
        sheet[r * (h + 2) : r * (h + 2) + h, c * (w + 2) : c * (w + 2) + w] = tile
    return sheet


def write_png(path: str | Path, image: np.ndarray) -> Path:
    """Write an 8-bit image as PNG; returns the path."""
    path = Path(path)
    if not write_image(path, image):
        raise ParameterError(f"could not write a PNG to {path}")
    return path
