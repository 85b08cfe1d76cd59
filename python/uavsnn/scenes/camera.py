"""The pinhole camera: where an object at a range appears, and how big.

Objects are small beside their range, so each is drawn with *weak perspective*: its centre is
projected exactly (``u = cx + f·X/Z``), and its shape, turned to face the line of sight, is
scaled by ``f/Z``. A camera that pans shifts the whole image by ``f·angle`` (small angles), so
objects and background move together.
"""

from __future__ import annotations

import math

import numpy as np

from uavsnn.scenes.spec import SceneSpec

__all__ = ["Camera", "attitude", "view_rotation"]

#: Objects nearer than this (metres) are behind the lens and not drawn.
NEAR_M = 0.05


def _rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rot_y(a: float) -> np.ndarray:
    # Turns local +x (forward) towards +z (away from the camera) for a > 0.
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def _rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def attitude(heading: float, pitch: float = 0.0, roll: float = 0.0) -> np.ndarray:
    """Rotation from an object's body axes (x forward, y up, z to its right) to the world axes
    (x to the camera's right, y up, z away), angles in radians: roll about x, then pitch about
    z (nose up for ``pitch > 0``), then heading about y."""
    return _rot_y(heading) @ _rot_z(pitch) @ _rot_x(roll)


def view_rotation(elevation: float) -> np.ndarray:
    """Rows: the screen's right and up axes and the depth along the line of sight, for a line
    of sight ``elevation`` radians above the horizontal (the object's underside shows when the
    camera looks up at it)."""
    c, s = math.cos(elevation), math.sin(elevation)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


class Camera:
    """The spec's pinhole camera: principal point at the frame centre, focal length
    ``focal_px``, optical axis ``tilt_deg`` above the horizontal, steady pan."""

    def __init__(self, spec: SceneSpec) -> None:
        self.width = spec.width
        self.height = spec.height
        self.f = float(spec.focal_px)
        self.cx = spec.width / 2.0
        self.cy = spec.height / 2.0
        self.tilt = math.radians(spec.tilt_deg)
        self.pan = tuple(math.radians(a) for a in spec.pan_deg_s)

    def shift(self, t: np.ndarray) -> np.ndarray:
        """Image shift ``(n, 2)`` in pixels that the pan causes at times ``t`` (seconds): a
        camera turning right moves the scene left; turning up moves it down."""
        t = np.asarray(t, dtype=np.float64)
        return np.stack([-self.f * self.pan[0] * t, self.f * self.pan[1] * t], axis=1)

    def project(self, points: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Image centres ``(n, 2)`` (continuous pixel coordinates) and scales ``f/Z`` ``(n,)``
        of camera-frame points ``(n, 3)`` at times ``t``; the scale is 0 where ``Z`` is too
        near."""
        z = points[:, 2]
        ok = z > NEAR_M
        safe = np.where(ok, z, 1.0)
        uv = np.stack(
            [self.cx + self.f * points[:, 0] / safe, self.cy + self.f * points[:, 1] / safe],
            axis=1,
        )
        uv = uv + self.shift(t)
        return uv, np.where(ok, self.f / safe, 0.0)

    def altitude(self, points: np.ndarray, camera_height_m: float) -> np.ndarray:
        """Height above the ground ``(n,)`` of camera-frame points ``(n, 3)`` for a camera
        ``camera_height_m`` above it (the tilt turns the camera's axes)."""
        st, ct = math.sin(self.tilt), math.cos(self.tilt)
        return camera_height_m - points[:, 1] * ct + points[:, 2] * st

    def elevation(self, points: np.ndarray) -> np.ndarray:
        """Elevation of the line of sight (radians above the horizontal) to camera-frame
        points ``(n, 3)``."""
        return self.tilt + np.arctan2(-points[:, 1], np.maximum(points[:, 2], NEAR_M))
