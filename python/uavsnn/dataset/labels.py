"""From a label per frame to a label per window.

Frame ``k`` (at ``t_k``) stands for the time around it, ``[t_k − Δ/2, t_k + Δ/2)`` with ``Δ``
the frame interval: the events a simulator makes between two frames come from the change
between them, so each frame speaks for half of the interval on either side. A window
``[t0, t0 + L)`` is then:

- **UAV** (``label = True``) when a UAV is labelled and visible during at least
  ``min_fraction`` (default ½) of the window's time; its box is the union of the UAV's boxes in
  the frames that overlap the window;
- **not a UAV** (``label = False``) when no UAV is visible at any moment of the window; its
  class is the other object that is visible longest (of equal times, the first class by
  name), if that is at least ``min_fraction`` of the window (its box the union of that
  object's boxes), else ``"none"`` (box NaN);
- a labelled window (UAV or another object) carries the object's ``range_m`` and ``size_px``:
  their means over the same frames its box unites (NaN for ``"none"``, and ``range_m`` NaN
  where frames do not know it, as for real footage);
- **ambiguous** when a UAV is visible for some but less than ``min_fraction`` of the window,
  and **unscored** when any part of the window has no label (past the last labelled frame,
  beyond the recording's end, or a frame without a label row): both are left out of datasets.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from uavsnn.errors import ParameterError, ShapeError
from uavsnn.scenes import LABEL_DTYPE, UAV_CLASS

__all__ = [
    "AMBIGUOUS",
    "NONE_CLASS",
    "OK",
    "UNSCORED",
    "WindowLabels",
    "frame_spans",
    "label_windows",
]

OK, AMBIGUOUS, UNSCORED = 0, 1, 2
#: The class of a window in which no labelled object is in view.
NONE_CLASS = "none"


@dataclass(frozen=True)
class WindowLabels:
    """Per window: ``label`` (UAV or not), ``cls``, ``box`` ``(n, 4)`` (x0, y0, x1, y1; NaN when
    no object), ``status`` (``OK``, ``AMBIGUOUS`` or ``UNSCORED``), ``uav_fraction`` (share of
    the window with a UAV visible), ``range_m`` and ``size_px`` ``(n,)`` float32 (the labelled
    object's mean range in metres and size in pixels over the window's frames; NaN when no
    object or unknown)."""

    label: np.ndarray
    cls: np.ndarray
    box: np.ndarray
    status: np.ndarray
    uav_fraction: np.ndarray
    range_m: np.ndarray
    size_px: np.ndarray

    @property
    def usable(self) -> np.ndarray:
        """Mask of the windows that can be scored."""
        return self.status == OK


def frame_spans(timestamps_us: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(start, end)`` of the time each frame stands for: halfway to its neighbours (the first
    and last frames reach half an interval out)."""
    t = np.asarray(timestamps_us, dtype=np.float64)
    if t.ndim != 1 or len(t) < 2:
        raise ShapeError(f"need at least two frame times, got shape {t.shape}")
    if np.any(np.diff(t) <= 0):
        raise ShapeError("frame times must increase strictly")
    mid = (t[1:] + t[:-1]) / 2
    start = np.concatenate([[t[0] - (t[1] - t[0]) / 2], mid])
    end = np.concatenate([mid, [t[-1] + (t[-1] - t[-2]) / 2]])
    return start, end


def _coverage(
    start: np.ndarray, end: np.ndarray, on: np.ndarray, a: np.ndarray, b: np.ndarray
) -> np.ndarray:
    """Time within each ``[a, b)`` covered by the frame spans where ``on`` is true."""
    edges = np.concatenate([start, end[-1:]])
    cum = np.concatenate([[0.0], np.cumsum((end - start) * on)])
    # Piecewise-linear cumulative coverage, flat outside the frames.
    return np.interp(b, edges, cum) - np.interp(a, edges, cum)


def label_windows(
    t0: np.ndarray,
    length_us: int,
    timestamps_us: np.ndarray,
    frame_labels: np.ndarray,
    labelled: np.ndarray | None = None,
    *,
    min_fraction: float = 0.5,
) -> WindowLabels:
    """Label windows ``[t0, t0 + length_us)`` from the labels of frames at ``timestamps_us``
    (see the module's rules). ``labelled`` marks the frames that carry a label (all by
    default)."""
    if not 0.0 < min_fraction <= 1.0:
        raise ParameterError(f"min_fraction must be in (0, 1], got {min_fraction!r}")
    if length_us < 1:
        raise ParameterError(f"length_us must be >= 1, got {length_us!r}")
    if frame_labels.dtype != LABEL_DTYPE:
        raise ShapeError(f"frame labels must have dtype {LABEL_DTYPE.descr}")
    n_frames = len(frame_labels)
    if len(timestamps_us) != n_frames:
        raise ShapeError(f"{len(timestamps_us)} frame times for {n_frames} frame labels")
    if labelled is None:
        labelled = np.ones(n_frames, dtype=bool)
    elif len(labelled) != n_frames:
        raise ShapeError(f"labelled has {len(labelled)} entries for {n_frames} frames")
    labelled = np.asarray(labelled, dtype=bool)
    start, end = frame_spans(timestamps_us)
    a = np.asarray(t0, dtype=np.float64)
    b = a + float(length_us)
    length = float(length_us)
    # Outside the frames' spans nothing is labelled: coverage there is zero.
    covered = _coverage(start, end, labelled, a, b)
    uav_on = labelled & frame_labels["uav"]
    f_uav = _coverage(start, end, uav_on, a, b) / length
    n = len(a)
    status = np.full(n, OK, dtype=np.int8)
    status[covered < length - 1e-6] = UNSCORED
    status[(status == OK) & (f_uav > 0) & (f_uav < min_fraction)] = AMBIGUOUS
    label = (status == OK) & (f_uav >= min_fraction)
    cls = np.full(n, NONE_CLASS, dtype="<U12")
    box = np.full((n, 4), np.nan, dtype=np.float32)
    cls[label] = UAV_CLASS
    # The other objects' visible time, class by class.
    others = sorted(set(frame_labels["cls"][labelled].tolist()) - {UAV_CLASS, NONE_CLASS})
    best = np.zeros(n)
    for name in others:
        f = _coverage(start, end, labelled & (frame_labels["cls"] == name), a, b) / length
        pick = (status == OK) & ~label & (f >= min_fraction) & (f > best)
        cls[pick] = name
        best = np.where(pick, f, best)
    range_m = np.full(n, np.nan, dtype=np.float32)
    size_px = np.full(n, np.nan, dtype=np.float32)
    boxes = np.stack([frame_labels[k] for k in ("x0", "y0", "x1", "y1")], axis=1)
    lo = np.searchsorted(end, a, side="right")  # first frame whose span ends after a
    hi = np.searchsorted(start, b, side="left")  # frames starting before b
    for i in np.nonzero((status == OK) & (cls != NONE_CLASS))[0]:
        sel = slice(lo[i], hi[i])
        match = labelled[sel] & (frame_labels["cls"][sel] == cls[i])
        if match.any():
            bx = boxes[sel][match]
            box[i] = (bx[:, 0].min(), bx[:, 1].min(), bx[:, 2].max(), bx[:, 3].max())
            ranges = frame_labels["range_m"][sel][match]
            if np.isfinite(ranges).all():
                range_m[i] = ranges.mean(dtype=np.float64)
            sizes = frame_labels["size_px"][sel][match]
            if np.isfinite(sizes).all():
                size_px[i] = sizes.mean(dtype=np.float64)
    return WindowLabels(label, cls, box, status, f_uav, range_m, size_px)
