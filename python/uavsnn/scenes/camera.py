"""The pinhole camera: where an object at a range appears, and how big.

Objects are small beside their range, so each is drawn with *weak perspective*: its centre is
projected exactly (``u = cx + f·X/Z``), and its shape, turned to face the line of sight, is
scaled by ``f/Z``. A camera that pans shifts the whole image by ``f·angle`` (small angles), so
objects and background move together.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from uavsnn.errors import SimulationError
from uavsnn.scenes import portable
from uavsnn.scenes.spec import NEAR_FOCUS_M, SceneSpec

__all__ = ["PIXEL_PITCH_UM", "Camera", "Lens", "attitude", "view_rotation"]

#: Pixel pitch (µm) of the event sensors of each size the project builds datasets for: the
#: DVS240 and DAVIS346 (18.5 µm), Prophesee's Gen3 VGA (15 µm) and Gen4 / Sony IMX636
#: (4.86 µm), from their data sheets.
PIXEL_PITCH_UM: dict[tuple[int, int], float] = {
    (240, 180): 18.5,
    (346, 260): 18.5,
    (640, 480): 15.0,
    (1280, 720): 4.86,
}


@dataclass(frozen=True)
class Lens:
    """A camera lens of ``f_number`` focused at ``focus_m`` metres (``None``: infinity, as a
    camera watching the sky is set), on a sensor of ``pixel_um`` pitch (``None``: the pitch of
    :data:`PIXEL_PITCH_UM` for the sensor's size).

    A scene's focal length in pixels and the pitch give the lens's focal length
    (``focal_px · pitch``), and the f-number its aperture (``focal length / f_number``). With
    focus at infinity, a point at range ``Z`` spans ``focal_px² · pitch / (f_number · Z)``
    pixels: at one field of view and f-number, a sensor of more pixels (and, for the same
    pixel count, of larger pixels) blurs a near object over more of its pixels.
    """

    f_number: float
    focus_m: float | None = None
    pixel_um: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.f_number) and 0.5 <= self.f_number <= 64):
            raise SimulationError(f"lens f_number must be in [0.5, 64], got {self.f_number!r}")
        if self.focus_m is not None and not (
            math.isfinite(self.focus_m) and NEAR_FOCUS_M <= self.focus_m <= 1e6
        ):
            raise SimulationError(
                f"lens focus_m must be in [{NEAR_FOCUS_M}, 1e6] m or None (infinity), "
                f"got {self.focus_m!r}"
            )
        if self.pixel_um is not None and not (
            math.isfinite(self.pixel_um) and 0.5 <= self.pixel_um <= 100
        ):
            raise SimulationError(f"lens pixel_um must be in [0.5, 100], got {self.pixel_um!r}")

    def pitch_um(self, sensor: tuple[int, int]) -> float:
        """The pixel pitch (µm) of ``sensor``: this lens's ``pixel_um``, else the known one.

        Raises:
            SimulationError: no pitch given and none known for that size.
        """
        if self.pixel_um is not None:
            return self.pixel_um
        size = (int(sensor[0]), int(sensor[1]))
        if size not in PIXEL_PITCH_UM:
            known = ", ".join(f"{w}x{h}" for w, h in PIXEL_PITCH_UM)
            raise SimulationError(
                f"no pixel pitch known for a {size[0]}x{size[1]} sensor (known: {known}); "
                f"give the lens its pixel_um"
            )
        return PIXEL_PITCH_UM[size]

    def on(self, spec: SceneSpec, sensor: tuple[int, int]) -> SceneSpec:
        """``spec`` seen through this lens on ``sensor`` (whose pixels ``spec.focal_px``
        counts): its aperture and focus set, nothing else changed."""
        focal_mm = spec.focal_px * self.pitch_um(sensor) * 1e-3
        return replace(spec, aperture_mm=focal_mm / self.f_number, focus_m=self.focus_m)

    def describe(self) -> dict[str, float | None]:
        """The lens's settings, for a manifest."""
        return {"f_number": self.f_number, "focus_m": self.focus_m, "pixel_um": self.pixel_um}


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
    return portable.matmul(portable.matmul(_rot_y(heading), _rot_z(pitch)), _rot_x(roll))


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
        return self.tilt + portable.arctan2(-points[:, 1], np.maximum(points[:, 2], NEAR_M))
