"""Ordinary video to events (SPEC §4): the paper's two data domains.

- ``"sim"``: :func:`pix2nvs`, PIX2NVS (Bi & Andreopoulos, ICIP 2017) as the paper used it —
  luma, log, threshold, at most ``n_max`` events per pixel per frame with interpolated times,
  its reference-update modes, local inhibition and adaptive threshold.
- ``"dvs"``: :func:`emulate_dvs`, a sensor emulator in the spirit of v2e and ESIM — exact
  threshold crossings between frames, threshold mismatch, refractory period, leak, shot noise,
  hot pixels and low-light bandwidth.
- Video through OpenCV: :func:`read_video`, :func:`iter_video`, and :func:`video_to_recording`
  for the whole path, which streams; :func:`write_preview` for a picture of the result.

Per-pixel work runs in the Rust engine; both simulators are deterministic for a seed. The
choices made, and how they compare with PIX2NVS and v2e, are in ``docs/simulation.md``.
"""

from __future__ import annotations

from uavsnn.sim.dvs import SCENE_PARAMS, DvsEmulator, DvsParams, emulate_dvs
from uavsnn.sim.pix2nvs import Pix2NvsParams, Pix2NvsSimulator, pix2nvs
from uavsnn.sim.preview import event_frame, event_strip, write_preview
from uavsnn.sim.video import (
    crop_to_aspect,
    iter_video,
    probe_video,
    read_video,
    video_to_recording,
)

__all__ = [
    "SCENE_PARAMS",
    "DvsEmulator",
    "DvsParams",
    "Pix2NvsParams",
    "Pix2NvsSimulator",
    "crop_to_aspect",
    "emulate_dvs",
    "event_frame",
    "event_strip",
    "iter_video",
    "pix2nvs",
    "probe_video",
    "read_video",
    "video_to_recording",
    "write_preview",
]
