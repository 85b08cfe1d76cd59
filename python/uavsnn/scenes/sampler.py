"""Draw varied scenes: :func:`sample_spec` picks camera, background, light and objects.

Ranges are drawn in metres for each kind of object, within what its surroundings allow (a hall
is 24-34 m long; an airliner is kilometres away), and further limited so that the object spans
at least ``min_object_px`` pixels of the 240-pixel-wide sensor that the frames end up on (a
Tello 80 m away would be a tenth of a pixel: present, but invisible to any detector) and at
most half the frame. Sizes, speeds and rates follow the real things; see ``docs/dataset.md``.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from uavsnn.errors import ParameterError
from uavsnn.scenes.spec import (
    DOMAINS,
    OBJECT_KINDS,
    Background,
    Lighting,
    ObjectSpec,
    PathSpec,
    SceneSpec,
)

__all__ = [
    "MAX_FOV_DEG",
    "SCENE_KINDS",
    "default_format",
    "fov_range",
    "object_shares",
    "sample_spec",
]

#: Scene kinds: one UAV (sometimes with a distractor), one non-UAV object, or nothing.
SCENE_KINDS = ("uav", "object", "empty")

_DEFAULTS = {
    # domain: (size, fps, duration_s)
    "dvs": ((240, 180), 500.0, 1.0),
    "sim": ((640, 360), None, 3.0),
}

_OUTDOOR_OBJECTS = (
    ("bird", 0.32),
    ("aircraft", 0.14),
    ("helicopter", 0.14),
    ("ball", 0.12),
    ("insect", 0.14),
    ("leaf", 0.14),
)
_INDOOR_OBJECTS = (("ball", 0.45), ("insect", 0.3), ("leaf", 0.15), ("bird", 0.1))
_BACKGROUNDS: dict[str, tuple[tuple[str, float], ...]] = {
    "dvs": (("hall", 0.45), ("sky", 0.3), ("ground", 0.25)),
    "sim": (("sky", 0.4), ("ground", 0.4), ("hall", 0.2)),
}


def _objects_in(background: str) -> tuple[tuple[str, float], ...]:
    return _INDOOR_OBJECTS if background == "hall" else _OUTDOOR_OBJECTS


def _share(table: tuple[tuple[str, float], ...], name: str) -> float:
    return sum(w for n, w in table if n == name) / sum(w for _, w in table)


def object_shares(domain: str) -> dict[str, float]:
    """The share of each non-UAV object kind among the objects of the ``"object"`` scenes that
    :func:`sample_spec` draws for ``domain`` (the object it is drawn for, not a second one):
    each background's share times the kind's share in that background's table. They sum to
    1; a split that draws its object scenes by these shares (``object_kind``) keeps the
    domain's mix of objects and backgrounds."""
    if domain not in _BACKGROUNDS:
        raise ParameterError(f"domain must be one of {DOMAINS}, got {domain!r}")
    shares: dict[str, float] = {}
    backgrounds = _BACKGROUNDS[domain]
    for bg, _ in backgrounds:
        for name, _ in _objects_in(bg):
            shares[name] = shares.get(name, 0.0) + _share(backgrounds, bg) * _share(
                _objects_in(bg), name
            )
    return shares


def _v3(x: np.ndarray | tuple[float, ...]) -> tuple[float, float, float]:
    a, b, c = (float(v) for v in x)
    return (a, b, c)


def default_format(domain: str) -> tuple[tuple[int, int], float | None, float]:
    """The domain's default frame size, frame rate (``None``: 30 or 60 at random) and
    duration."""
    if domain not in _DEFAULTS:
        raise ParameterError(f"domain must be one of {DOMAINS}, got {domain!r}")
    return _DEFAULTS[domain]


def _pick(rng: np.random.Generator, table: tuple[tuple[str, float], ...]) -> str:
    names = [n for n, _ in table]
    p = np.array([w for _, w in table], dtype=np.float64)
    return names[int(rng.choice(len(names), p=p / p.sum()))]


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(max(hi, lo * 1.0001)))))


def _lighting(rng: np.random.Generator, domain: str, indoor: bool) -> Lighting:
    # Very dark scenes are the event camera's strength; as 8-bit video they are mostly noise,
    # which PIX2NVS turns into a flood of events, so the "sim" domain stops at "dark".
    bands: tuple[tuple[str, float], ...] = (
        (("bright", 0.35), ("moderate", 0.3), ("dark", 0.2), ("very dark", 0.15))
        if domain == "dvs"
        else (("bright", 0.45), ("moderate", 0.35), ("dark", 0.2))
    )
    band = _pick(rng, bands)
    lo, hi = {
        "bright": (0.5, 1.0),
        "moderate": (0.15, 0.5),
        "dark": (0.03, 0.15),
        "very dark": (0.008, 0.03),
    }[band]
    flicker = 0.0
    if indoor and domain == "dvs" and rng.random() < 0.3:
        flicker = float(rng.uniform(0.005, 0.04))
    return Lighting(
        level=_log_uniform(rng, lo, hi),
        noise=float(rng.uniform(0.5, 2.0)),
        flicker_hz=100.0,
        flicker=flicker,
    )


def _background(
    rng: np.random.Generator, domain: str, object_kind: str | None = None
) -> Background:
    table = _BACKGROUNDS[domain]
    if object_kind is not None:
        # Given the object, each background in proportion to how often it holds that object.
        table = tuple((bg, w * _share(_objects_in(bg), object_kind)) for bg, w in table)
    kind = _pick(rng, table)
    speed = float(rng.uniform(0.03, 0.4)) * (1 if rng.random() < 0.5 else -1)
    return Background(
        kind=kind,
        cloud_cover=float(rng.uniform(0.0, 0.8)) if rng.random() < 0.85 else 0.0,
        overcast=float(rng.uniform(0.0, 1.0)) if rng.random() < 0.35 else 0.0,
        cloud_speed_deg_s=speed,
        wind=float(rng.uniform(0.2, 1.0)) if rng.random() < 0.5 else 0.0,
        camera_height_m=float(rng.uniform(1.2, 1.8)),
        room_m=(float(rng.uniform(24, 34)), float(rng.uniform(13, 20)), float(rng.uniform(7, 10))),
        variant=int(rng.integers(0, 6)),
    )


def _tilt(rng: np.random.Generator, bg: Background, width: int, height: int, f: float) -> float:
    half_v = math.degrees(math.atan(height / 2 / f))
    if bg.kind == "sky":  # looking up: no horizon in view
        return float(half_v + rng.uniform(3, 30))
    if bg.kind == "ground":  # horizon in the lower half
        row = rng.uniform(0.55, 0.92) * height
        return math.degrees(math.atan((row - height / 2) / f))
    return float(rng.uniform(-3, 10))


class _Placer:
    """Puts objects where the camera sees them, at ranges the surroundings allow."""

    def __init__(self, rng: np.random.Generator, spec: SceneSpec, min_px: float) -> None:
        self.rng = rng
        self.spec = spec
        self.f = spec.focal_px
        self.w, self.h = spec.width, spec.height
        self.min_px = min_px
        self.indoor = spec.background.kind == "hall"
        self.room = spec.background.room_m
        self.min_height = 1.0  # metres above the ground at the path's midpoint

    def range_for(self, extent_m: float, lo: float, hi: float) -> float:
        if self.indoor:
            hi = min(hi, self.room[0] - 1.0)
        far = self.f * extent_m / self.min_px  # spans min_px pixels
        near = self.f * extent_m / (0.5 * min(self.w, self.h))  # spans half the frame
        lo, hi = max(lo, near), min(hi, far)
        if hi <= lo:
            hi = lo * 1.05
        return _log_uniform(self.rng, lo, hi)

    def point(self, z: float, margin: float = 0.1) -> np.ndarray:
        """A camera-frame point at range ``z`` seen inside the frame, above the ground (or the
        hall's floor) by ``min_height`` and below the hall's ceiling."""
        u = self.rng.uniform(margin, 1 - margin) * self.w
        lo, hi = margin * self.h, (1 - margin) * self.h
        bg = self.spec.background
        tilt = math.radians(self.spec.tilt_deg)
        cy, f = self.h / 2, self.f
        if bg.kind in ("ground", "hall"):
            # Height above the floor of the point seen at row v and range z (small angles).
            # h(v) = camera_height + z·sin(tilt) − (v − cy)·z·cos(tilt)/f, falling with v.
            def row(height: float) -> float:
                return cy + f * (z * math.sin(tilt) + bg.camera_height_m - height) / (
                    z * math.cos(tilt)
                )

            hi = min(hi, row(self.min_height))
            if bg.kind == "hall":
                lo = max(lo, row(bg.room_m[2] - 0.3))
        if hi <= lo:
            v = min(max(hi, 0.0), float(self.h))
        else:
            v = self.rng.uniform(lo, hi)
        return np.array([(u - self.w / 2) * z / f, (v - cy) * z / f, z])

    def lateral(self, speed: float, depth: float = 0.3) -> np.ndarray:
        a = self.rng.uniform(0, 2 * math.pi)
        d = np.array([math.cos(a), 0.4 * math.sin(a), self.rng.uniform(-depth, depth)])
        return speed * d / np.linalg.norm(d)

    def path(
        self,
        kind: str,
        z: float,
        speed: float,
        *,
        wobble_m: float = 0.0,
        wobble_hz: tuple[float, float] = (0.2, 2.0),
        n_wobble: int = 0,
        accel: tuple[float, float, float] = (0.0, 0.0, 0.0),
        cross: float = 0.8,
        drift: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> PathSpec:
        """A path whose midpoint lies in view, its speed capped so that the object moves at
        most ``cross`` frame widths over the clip (as a camera operator would frame it)."""
        rng = self.rng
        duration = self.spec.duration_s
        span_m = self.w * z / self.f  # the width of the view at range z
        speed = min(speed, cross * span_m / duration)
        mid = self.point(z, 0.15 if kind == "hover" else 0.1)
        vel = np.zeros(3) if kind == "hover" else self.lateral(speed)
        vel = vel + np.asarray(drift, dtype=np.float64)
        acc = np.asarray(accel, dtype=np.float64)
        if kind == "curved":
            acc = acc + self.lateral(speed * rng.uniform(0.3, 0.9) / max(duration, 0.5))
            n_wobble = max(n_wobble, 1)
            wobble_m = max(wobble_m, 0.03 * span_m)
        half = duration / 2
        amps = tuple(_v3(rng.normal(0, wobble_m, 3) * (1.0, 1.0, 0.5)) for _ in range(n_wobble))
        freqs = tuple(float(rng.uniform(*wobble_hz)) for _ in range(n_wobble))
        phases = tuple(float(rng.uniform(0, 2 * math.pi)) for _ in range(n_wobble))
        path = PathSpec(
            kind=kind,
            start=_v3(mid - vel * half - 0.5 * acc * half * half),
            velocity=_v3(vel),
            acceleration=_v3(acc),
            amplitudes=amps,
            freqs=freqs,
            phases=phases,
        )
        # Move the whole path, wobble included, to pass through ``mid`` at mid-clip: tens of
        # centimetres of wobble would otherwise carry a drone 2 m away out of the frame.
        off = mid - path.position(np.array([half]))[0]
        return replace(path, start=_v3(np.asarray(path.start) + off))


#: How high above the ground each kind flies, at least, at the middle of its path (metres).
_MIN_HEIGHT = {
    "phantom": 1.0,
    "tello": 0.5,
    "bird": 2.0,
    "aircraft": 150.0,
    "helicopter": 30.0,
    "ball": 0.5,
    "insect": 0.2,
    "leaf": 0.5,
}


def _object(kind: str, place: _Placer) -> ObjectSpec:
    rng = place.rng
    place.min_height = _MIN_HEIGHT.get(kind, 0.5)
    indoor = place.indoor
    heading = float(rng.uniform(0, 360))
    phase = float(rng.uniform(0, 2 * math.pi))
    if kind in ("phantom", "tello"):
        size = 0.29 if kind == "phantom" else 0.098
        extent = size * (1.8 if kind == "phantom" else 1.0)  # propellers reach past the frame
        z = place.range_for(extent, 1.5, 25.0 if indoor else 120.0)
        path_kind = ("linear", "curved", "hover")[int(rng.integers(3))]
        speed = float(rng.uniform(0.3, 4.0 if indoor else 12.0))
        path = place.path(
            path_kind,
            z,
            speed,
            wobble_m=float(rng.uniform(0.02, 0.2)),
            cross=0.7,
            n_wobble=3 if path_kind == "hover" else 1,
            wobble_hz=(0.2, 2.5),
        )
        rate = float(rng.uniform(100, 150) if kind == "phantom" else rng.uniform(180, 260))
        shade = float(rng.uniform(0.75, 0.92))
        return ObjectSpec(
            kind,
            size,
            path,
            rate_hz=rate,
            heading_deg=heading,
            color=(shade, shade, shade * 0.98),
            phase=phase,
        )
    if kind == "bird":
        span = _log_uniform(rng, 0.25, 0.7 if indoor else 1.6)
        z = place.range_for(span, 2.0, 25.0 if indoor else 150.0)
        speed = float(rng.uniform(3.0, 8.0) if indoor else rng.uniform(5.0, 18.0))
        path = place.path(
            "curved" if rng.random() < 0.4 else "linear",
            z,
            speed,
            cross=1.2,
            wobble_m=0.1 * span,
            n_wobble=1,
        )
        rate = float(np.clip(4.0 / span, 2.5, 14.0) * rng.uniform(0.85, 1.15))
        colors = [(0.06, 0.06, 0.07), (0.38, 0.36, 0.36), (0.82, 0.82, 0.8), (0.1, 0.16, 0.22)]
        variant = 1 if span > 0.8 and rng.random() < 0.5 else 0
        return ObjectSpec(
            kind,
            span,
            path,
            rate_hz=rate,
            heading_deg=heading,
            color=colors[int(rng.integers(len(colors)))],
            variant=variant,
            phase=phase,
        )
    if kind == "aircraft":
        length = _log_uniform(rng, 12.0, 70.0)
        z = place.range_for(length, 400.0, 9000.0)
        speed = float(rng.uniform(50.0, 120.0) if length < 30 else rng.uniform(80.0, 250.0))
        path = place.path("linear", z, speed)
        shade = float(rng.uniform(0.6, 0.9))
        return ObjectSpec(
            kind,
            length,
            path,
            heading_deg=heading,
            color=(shade, shade, shade),
            variant=0 if length >= 30 else 1,
            phase=phase,
        )
    if kind == "helicopter":
        length = float(rng.uniform(9.0, 20.0))
        z = place.range_for(length, 60.0, 1500.0)
        path_kind = ("linear", "curved", "hover")[int(rng.integers(3))]
        path = place.path(
            path_kind,
            z,
            float(rng.uniform(2.0, 60.0)),
            wobble_m=0.3,
            n_wobble=2 if path_kind == "hover" else 0,
        )
        colors = [
            (0.1, 0.2, 0.12),
            (0.1, 0.1, 0.55),
            (0.8, 0.8, 0.8),
            (0.3, 0.12, 0.05),
            (0.1, 0.1, 0.1),
        ]
        return ObjectSpec(
            kind,
            length,
            path,
            rate_hz=float(rng.uniform(4.0, 7.0)),
            heading_deg=heading,
            color=colors[int(rng.integers(len(colors)))],
            variant=int(rng.integers(0, 4)),
            phase=phase,
        )
    if kind == "ball":
        diameter = _log_uniform(rng, 0.065, 0.7)
        z = place.range_for(diameter, 1.5, 15.0 if indoor else 25.0)
        speed = float(rng.uniform(3.0, 15.0))
        path = place.path("ballistic", z, speed, accel=(0.0, 9.81, 0.0), cross=1.5)
        colors = [
            (0.05, 0.35, 0.9),
            (0.1, 0.1, 0.75),
            (0.1, 0.75, 0.85),
            (0.85, 0.85, 0.85),
            (0.7, 0.3, 0.1),
            (0.1, 0.7, 0.6),
        ]
        return ObjectSpec(
            kind,
            diameter,
            path,
            rate_hz=float(rng.uniform(1.0, 10.0)),
            color=colors[int(rng.integers(len(colors)))],
            phase=phase,
        )
    if kind == "insect":
        span = _log_uniform(rng, 0.008, 0.05)
        z = place.range_for(span, 0.15, 3.0)
        path = place.path(
            "erratic",
            z,
            float(rng.uniform(0.2, 2.0)),
            wobble_m=float(rng.uniform(0.03, 0.2)) * z,
            n_wobble=3,
            wobble_hz=(0.5, 4.0),
        )
        return ObjectSpec(
            kind,
            span,
            path,
            rate_hz=float(rng.uniform(80, 250)),
            heading_deg=heading,
            color=(0.05, 0.06, 0.07),
            phase=phase,
        )
    if kind == "leaf":
        length = _log_uniform(rng, 0.04, 0.15)
        z = place.range_for(length, 1.0, 12.0)
        path = place.path(
            "falling",
            z,
            float(rng.uniform(0.1, 1.0)),
            wobble_m=float(rng.uniform(0.1, 0.5)),
            n_wobble=1,
            wobble_hz=(0.3, 1.2),
            drift=(0.0, float(rng.uniform(0.5, 1.8)), 0.0),
        )
        colors = [(0.05, 0.3, 0.12), (0.05, 0.45, 0.55), (0.05, 0.2, 0.4), (0.04, 0.12, 0.5)]
        return ObjectSpec(
            kind,
            length,
            path,
            rate_hz=float(rng.uniform(0.3, 2.0)),
            color=colors[int(rng.integers(len(colors)))],
            phase=phase,
        )
    raise ParameterError(f"unknown object kind {kind!r}")


#: The widest field of view a scene may be drawn with (degrees): the pinhole camera's weak
#: perspective holds for objects near the optical axis, and 120° is already a fisheye's.
MAX_FOV_DEG = 120.0


def fov_range(domain: str, fov_deg: tuple[float, float] | None) -> tuple[float, float]:
    """The horizontal fields of view (degrees) a scene of ``domain`` is drawn from: ``fov_deg``
    checked, or the domain's default.

    Raises:
        ParameterError: not two numbers with ``1 <= low <= high <= MAX_FOV_DEG``.
    """
    if fov_deg is None:
        return (45.0, 70.0) if domain == "dvs" else (35.0, 70.0)
    try:
        low, high = (float(v) for v in fov_deg)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"fov_deg must be (low, high) in degrees, got {fov_deg!r}") from exc
    if not (math.isfinite(low) and math.isfinite(high) and 1.0 <= low <= high <= MAX_FOV_DEG):
        raise ParameterError(
            f"fov_deg must be (low, high) with 1 <= low <= high <= {MAX_FOV_DEG:g} degrees, "
            f"got {fov_deg!r}"
        )
    return low, high


def sample_spec(
    domain: str,
    kind: str,
    rng: np.random.Generator,
    *,
    size: tuple[int, int] | None = None,
    fps: float | None = None,
    duration_s: float | None = None,
    min_object_px: float = 3.0,
    sensor_width: int = 240,
    object_kind: str | None = None,
    fov_deg: tuple[float, float] | None = None,
) -> SceneSpec:
    """A random scene of ``kind`` for ``domain``.

    ``kind``: ``"uav"`` (a Phantom or a Tello, a quarter of the time with a non-UAV distractor),
    ``"object"`` (a non-UAV: bird, aircraft, helicopter, ball, insect or leaf; indoors only
    balls, insects, leaves and now and then a bird), ``"empty"`` (background only), or one
    object kind of :data:`uavsnn.scenes.OBJECT_KINDS` to get that object. ``size``, ``fps``,
    ``duration_s`` override the domain's defaults (dvs: 240×180 at 500 fps for 1 s; sim:
    640×360 at 30 or 60 fps for 3 s). Objects span at least ``min_object_px`` pixels of a
    ``sensor_width``-pixel-wide view: for "dvs", a sensor of that width with the same
    horizontal field of view; for "sim", the frame once cropped to 4:3 and scaled to that width.

    The horizontal field of view is drawn in degrees and every choice after it in metres and
    angles, so the same ``rng`` state gives the same scene at any ``size`` (keep
    ``sensor_width`` at its default): only the focal length in pixels, and so every object's
    size in pixels, grows with the width. A "dvs" scene is laid out for a 4:3 frame of the
    given width, of which a wider sensor (1280×720) sees the middle rows, with the same optical
    axis.

    ``object_kind`` (``kind="object"`` only; one of :func:`object_shares`): the scene's object
    is of that kind, and its background is drawn as the object scenes that hold one are
    (a ball is mostly indoors, a helicopter always outdoors); the rest is drawn as for any
    object scene, a second object included. A split that picks each object scene's kind by
    :func:`object_shares` gets every kind in its share instead of leaving it to chance.

    ``fov_deg`` ``(low, high)``: the range the horizontal field of view is drawn from, in
    degrees (default: 45–70 for "dvs", 35–70 for "sim"); a narrow one is a longer lens on the
    same sensor, which puts more pixels on everything and puts the objects further away where
    they would fill the frame. It takes the same draw, so the rest of the scene is drawn from the
    same random numbers.
    """
    if not isinstance(rng, np.random.Generator):
        raise ParameterError(f"rng must be a numpy Generator, got {type(rng).__name__}")
    if kind not in SCENE_KINDS and kind not in OBJECT_KINDS:
        raise ParameterError(
            f"kind must be one of {SCENE_KINDS} or an object kind {OBJECT_KINDS}, got {kind!r}"
        )
    if not (math.isfinite(min_object_px) and min_object_px > 0):
        raise ParameterError(f"min_object_px must be > 0, got {min_object_px!r}")
    d_size, d_fps, d_duration = default_format(domain)
    if object_kind is not None and (kind != "object" or object_kind not in object_shares(domain)):
        raise ParameterError(
            f"object_kind is for kind='object' and one of {tuple(object_shares(domain))}, "
            f"got kind={kind!r}, object_kind={object_kind!r}"
        )
    width, height = size if size is not None else d_size
    if fps is None:
        fps = d_fps if d_fps is not None else float(rng.choice([30.0, 60.0]))
    duration = duration_s if duration_s is not None else d_duration
    background = _background(rng, domain, object_kind)
    if kind in ("aircraft", "helicopter") and background.kind == "hall":
        background = replace(background, kind="sky")
    fov_low, fov_high = fov_range(domain, fov_deg)
    fov = float(rng.uniform(fov_low, fov_high))
    focal = width / 2 / math.tan(math.radians(fov) / 2)
    indoor = background.kind == "hall"
    pan = (0.0, 0.0)
    if rng.random() < 0.15:
        pan = (float(rng.normal(0, 1.0)), float(rng.normal(0, 0.3)))
    # The layout's frame: for dvs, 4:3 at the sensor's width, whatever the sensor's shape.
    lay_h = round(width * 3 / 4) if domain == "dvs" else int(height)
    spec = SceneSpec(
        domain=domain,
        width=int(width),
        height=lay_h,
        fps=float(fps),
        duration_s=float(duration),
        focal_px=focal,
        background=background,
        lighting=_lighting(rng, domain, indoor),
        tilt_deg=_tilt(rng, background, int(width), lay_h, focal),
        pan_deg_s=pan,
    )
    to_sensor = sensor_width / (width if domain == "dvs" else min(width, height * 4 / 3))
    place = _Placer(rng, spec, min_object_px / to_sensor)
    others = _INDOOR_OBJECTS if indoor else _OUTDOOR_OBJECTS
    kinds: list[str] = []
    if kind == "uav":
        kinds.append("phantom" if rng.random() < 0.5 else "tello")
        if rng.random() < 0.25:
            kinds.append(_pick(rng, others))
    elif kind == "object":
        kinds.append(object_kind if object_kind is not None else _pick(rng, others))
        if rng.random() < 0.15:
            kinds.append(_pick(rng, others))
    elif kind != "empty":
        kinds.append(kind)
    objects = tuple(_object(k, place) for k in kinds)
    return replace(spec, height=int(height), objects=objects)
