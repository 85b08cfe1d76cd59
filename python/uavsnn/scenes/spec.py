"""What a scene is made of: the dataclasses that :func:`uavsnn.scenes.render` draws.

A :class:`SceneSpec` is complete and concrete: every size, speed and colour is decided, so one
spec rendered with one seed always gives the same frames. Randomness that only shapes texture
(clouds, trees, video noise) comes from the render seed, not from the spec.

Units: metres, seconds, degrees. Camera coordinates are those of a pinhole camera: ``X`` to the
right, ``Y`` down, ``Z`` forward (the range). Image coordinates are continuous: pixel ``(i, j)``
covers ``[i, i + 1) × [j, j + 1)``, so a box ``(x0, y0, x1, y1)`` covers the pixels it overlaps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from uavsnn.errors import SimulationError
from uavsnn.scenes import portable

__all__ = [
    "BACKGROUNDS",
    "CLASS_OF_KIND",
    "DOMAINS",
    "OBJECT_KINDS",
    "UAV_CLASS",
    "Background",
    "Lighting",
    "ObjectSpec",
    "PathSpec",
    "SceneSpec",
]

DOMAINS = ("dvs", "sim")
#: The nearest range (metres) a lens may be focused at.
NEAR_FOCUS_M = 0.05
BACKGROUNDS = ("sky", "ground", "hall")
UAV_CLASS = "drone"

#: The label class of each object kind; only drones are UAVs.
CLASS_OF_KIND: dict[str, str] = {
    "phantom": UAV_CLASS,
    "tello": UAV_CLASS,
    "bird": "bird",
    "aircraft": "airplane",
    "helicopter": "helicopter",
    "ball": "ball",
    "insect": "insect",
    "leaf": "leaf",
}
OBJECT_KINDS = tuple(CLASS_OF_KIND)


#: Path values (metres, m/s, m/s², Hz, radians) lie within ± this: far beyond any scene
#: :func:`uavsnn.scenes.sample_spec` draws (a ball thrown for 600 s starts 441 km below its
#: midpoint), and small enough that positions over a scene stay finite.
MAX_PATH_VALUE = 1e9
#: The largest object (metres; the largest that :func:`uavsnn.scenes.sample_spec` draws, an
#: airliner, is 70 m long).
MAX_SIZE_M = 1e4
#: The fastest rotor, wing beat or tumble (revolutions or beats per second; the fastest that
#: :func:`uavsnn.scenes.sample_spec` draws, a Tello's rotors, turn at up to 260). Between
#: frames a "dvs" scene samples fast parts at most once a microsecond.
MAX_RATE_HZ = 1e4
#: A path has at most this many wobble terms (``amplitudes``/``freqs``/``phases``; the paths
#: that :func:`uavsnn.scenes.sample_spec` draws have at most 3): each is evaluated at every
#: sample of the object's position.
MAX_HARMONICS = 16
#: A scene has at most this many objects (:func:`uavsnn.scenes.sample_spec` draws at most 2):
#: each is drawn in every frame (about half a millisecond each at 240×180).
MAX_OBJECTS = 64
#: A scene has at most this many frames (500 fps for 600 s is 300,000)...
MAX_FRAMES = 1_000_000
#: ...and its frames, as the float32 gray that the renderer draws, at most this many bytes
#: (2·10⁹ pixels; a 1 s scene at 500 fps on a 1280×720 sensor is 1.8·10⁹ bytes).
MAX_SCENE_BYTES = 8_000_000_000


def _is_number(value: object) -> bool:
    """A real number, not a bool or a string (which NumPy would convert)."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


def _finite(
    name: str,
    value: float,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
) -> None:
    if not _is_number(value):
        raise SimulationError(f"{name} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise SimulationError(f"{name} must be finite, got {value!r}")
    if low is not None and (value < low or (low_open and value == low)):
        op = ">" if low_open else ">="
        raise SimulationError(f"{name} must be {op} {low}, got {value!r}")
    if high is not None and value > high:
        raise SimulationError(f"{name} must be <= {high}, got {value!r}")


def _vector(
    name: str, value: object, shape: tuple[int, ...], bound: float | None = None
) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(shape)
        leaves = np.asarray(value, dtype=object).ravel()
    except (TypeError, ValueError) as exc:
        raise SimulationError(f"{name} must have shape {shape}, got {value!r}") from exc
    if not all(_is_number(v) for v in leaves):
        raise SimulationError(f"{name} must hold numbers, got {value!r}")
    if not np.all(np.isfinite(arr)):
        raise SimulationError(f"{name} must be finite, got {arr.tolist()}")
    if bound is not None and np.any(np.abs(arr) > bound):
        raise SimulationError(f"{name} must lie within ±{bound:g}, got {arr.tolist()}")
    return arr


def _store(spec: object, field: str, arr: np.ndarray) -> None:
    """Set ``field`` of the frozen ``spec`` to ``arr`` as (nested) tuples of Python floats, so
    that what was checked is what is drawn."""

    def tuples(v: object) -> object:
        return tuple(tuples(x) for x in v) if isinstance(v, list) else v

    object.__setattr__(spec, field, tuples(arr.tolist()))


def _variant(name: str, value: object) -> None:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < 0:
        raise SimulationError(f"{name} must be an integer >= 0, got {value!r}")


@dataclass(frozen=True)
class PathSpec:
    """A trajectory in camera coordinates (metres):

    ``p(t) = start + velocity·t + ½·acceleration·t² + Σ_k amplitudes[k]·sin(2π·freqs[k]·t +
    phases[k])``.

    One form covers every path the sampler makes: ``"linear"`` (no acceleration, no wobble),
    ``"curved"`` (a turn and a slow sway), ``"hover"`` (no velocity, small jitter),
    ``"ballistic"`` (gravity), ``"erratic"`` (large fast wobble) and ``"falling"``. ``kind`` only
    names the shape. Every value lies within ±:data:`MAX_PATH_VALUE` (10⁹); a path has at
    most :data:`MAX_HARMONICS` (16) wobble terms.
    """

    kind: str
    start: tuple[float, float, float]
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    acceleration: tuple[float, float, float] = (0.0, 0.0, 0.0)
    amplitudes: tuple[tuple[float, float, float], ...] = ()
    freqs: tuple[float, ...] = ()
    phases: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        for name in ("start", "velocity", "acceleration"):
            _store(self, name, _vector(f"path.{name}", getattr(self, name), (3,), MAX_PATH_VALUE))
        try:
            k = len(self.freqs)
            counts = (len(self.amplitudes), k, len(self.phases))
        except TypeError as exc:
            raise SimulationError(
                f"path.amplitudes, freqs and phases must be lists, got {self.amplitudes!r}, "
                f"{self.freqs!r}, {self.phases!r}"
            ) from exc
        if k > MAX_HARMONICS:
            raise SimulationError(
                f"path wobble has {k} terms, more than {MAX_HARMONICS} (MAX_HARMONICS)"
            )
        if counts[0] != k or counts[2] != k:
            raise SimulationError(
                f"path wobble needs as many amplitudes, freqs and phases: got "
                f"{counts[0]}, {k}, {counts[2]}"
            )
        for name, shape in (("amplitudes", (k, 3)), ("freqs", (k,)), ("phases", (k,))):
            _store(self, name, _vector(f"path.{name}", getattr(self, name), shape, MAX_PATH_VALUE))
        if any(f < 0 for f in self.freqs):
            raise SimulationError(f"path.freqs must be >= 0, got {list(self.freqs)}")

    def position(self, t: np.ndarray) -> np.ndarray:
        """Positions ``(n, 3)`` at times ``t`` (seconds)."""
        t = np.asarray(t, dtype=np.float64)[:, None]
        p = (
            np.asarray(self.start)[None, :]
            + np.asarray(self.velocity)[None, :] * t
            + 0.5 * np.asarray(self.acceleration)[None, :] * t * t
        )
        if self.freqs:
            amps = np.asarray(self.amplitudes)  # (k, 3)
            arg = 2 * np.pi * np.asarray(self.freqs)[None, :] * t + np.asarray(self.phases)
            p = p + portable.matmul(portable.sin(arg), amps)
        return p

    def velocity_at(self, t: np.ndarray) -> np.ndarray:
        """Velocities ``(n, 3)`` at times ``t`` (seconds), the derivative of :meth:`position`."""
        t = np.asarray(t, dtype=np.float64)[:, None]
        v = np.asarray(self.velocity)[None, :] + np.asarray(self.acceleration)[None, :] * t
        if self.freqs:
            w = 2 * np.pi * np.asarray(self.freqs)
            arg = w[None, :] * t + np.asarray(self.phases)
            v = v + portable.matmul(portable.cos(arg) * w[None, :], np.asarray(self.amplitudes))
        return v


@dataclass(frozen=True)
class ObjectSpec:
    """One object: a kind from :data:`OBJECT_KINDS`, its size, look and path.

    ``size_m`` is the object's characteristic width: a quadcopter's frame width without
    propellers (Phantom 0.29 m, Tello 0.098 m), a bird's wingspan, an aircraft's or
    helicopter's length, a ball's diameter, an insect's wingspan, a leaf's length.
    ``rate_hz`` is the rotor speed (revolutions per second), the wing-beat or the leaf's tumble
    rate; ``heading_deg`` is the direction the object faces (0 = to the camera's right, 90 =
    away from the camera); ``color`` is its main reflectance, linear BGR in [0, 1]; ``variant``
    picks a look within the kind (an integer >= 0). ``size_m`` is at most :data:`MAX_SIZE_M`
    and ``rate_hz`` at most :data:`MAX_RATE_HZ` (both 10⁴).
    """

    kind: str
    size_m: float
    path: PathSpec
    rate_hz: float = 0.0
    heading_deg: float = 0.0
    color: tuple[float, float, float] = (0.8, 0.8, 0.8)
    variant: int = 0
    phase: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.kind, str) or self.kind not in CLASS_OF_KIND:
            raise SimulationError(f"object kind must be one of {OBJECT_KINDS}, got {self.kind!r}")
        _finite("object.size_m", self.size_m, low=0.0, low_open=True, high=MAX_SIZE_M)
        _finite("object.rate_hz", self.rate_hz, low=0.0, high=MAX_RATE_HZ)
        _finite("object.heading_deg", self.heading_deg)
        _finite("object.phase", self.phase)
        color = _vector("object.color", self.color, (3,))
        if np.any(color < 0) or np.any(color > 1):
            raise SimulationError(f"object.color must lie in [0, 1], got {color.tolist()}")
        _store(self, "color", color)
        _variant("object.variant", self.variant)
        if not isinstance(self.path, PathSpec):
            raise SimulationError(f"object.path must be a PathSpec, got {self.path!r}")

    @property
    def cls(self) -> str:
        """The label class: ``"drone"`` for quadcopters, otherwise the kind's class."""
        return CLASS_OF_KIND[self.kind]

    @property
    def is_uav(self) -> bool:
        """Whether the object is a UAV."""
        return self.cls == UAV_CLASS


@dataclass(frozen=True)
class Background:
    """The scene behind the objects.

    ``kind``: ``"sky"`` (sky only), ``"ground"`` (sky above a field with trees) or ``"hall"``
    (an indoor sports hall like the paper's gymnasium). ``cloud_cover`` in [0, 1];
    ``overcast`` in [0, 1] greys the sky; ``cloud_speed_deg_s`` is the clouds' angular drift;
    ``wind`` in [0, 1] sways the trees. Where the horizon or the hall's floor falls in the frame
    follows from the camera's tilt and ``camera_height_m``; ``room_m`` is the hall's (length,
    width, height), each in [2, 500] m (three finite numbers for a sky, which does not use
    it). ``variant`` (an integer >= 0) picks a layout.
    """

    kind: str = "sky"
    cloud_cover: float = 0.3
    overcast: float = 0.0
    cloud_speed_deg_s: float = 0.2
    wind: float = 0.0
    camera_height_m: float = 1.5
    room_m: tuple[float, float, float] = (28.0, 15.0, 8.0)
    variant: int = 0

    def __post_init__(self) -> None:
        if self.kind not in BACKGROUNDS:
            raise SimulationError(
                f"background kind must be one of {BACKGROUNDS}, got {self.kind!r}"
            )
        _finite("background.cloud_cover", self.cloud_cover, low=0.0, high=1.0)
        _finite("background.overcast", self.overcast, low=0.0, high=1.0)
        _finite("background.cloud_speed_deg_s", self.cloud_speed_deg_s, low=-30.0, high=30.0)
        _finite("background.wind", self.wind, low=0.0, high=1.0)
        _finite("background.camera_height_m", self.camera_height_m, low=0.05, high=100.0)
        room = _vector("background.room_m", self.room_m, (3,))
        # A sky draws no room: its room_m is kept (three numbers) but never used.
        if self.kind != "sky" and (np.any(room < 2.0) or np.any(room > 500.0)):
            raise SimulationError(f"background.room_m must lie in [2, 500] m, got {room.tolist()}")
        _store(self, "room_m", room)
        _variant("background.variant", self.variant)
        if self.kind == "hall" and self.camera_height_m >= room[2]:
            raise SimulationError(
                f"background.camera_height_m ({self.camera_height_m}) must be below the hall's "
                f"ceiling ({room[2]})"
            )


@dataclass(frozen=True)
class Lighting:
    """How much light there is, and how a video camera copes.

    ``level`` scales every radiance: 1 is bright daylight, 0.3 overcast or a lit hall, 0.1 dim,
    0.03 dark, 0.01 very dark. ``noise`` is a video camera's noise (standard deviation in 8-bit
    levels at full light; it grows as light falls), used only for 8-bit output: the "dvs" domain
    leaves noise to the sensor emulator. ``flicker_hz``/``flicker`` model mains lighting
    (relative amplitude, 0 = none).
    """

    level: float = 1.0
    noise: float = 1.0
    flicker_hz: float = 100.0
    flicker: float = 0.0

    def __post_init__(self) -> None:
        _finite("lighting.level", self.level, low=0.0, low_open=True, high=1.0)
        _finite("lighting.noise", self.noise, low=0.0, high=64.0)
        _finite("lighting.flicker_hz", self.flicker_hz, low=0.0)
        _finite("lighting.flicker", self.flicker, low=0.0, high=1.0)


@dataclass(frozen=True)
class SceneSpec:
    """A scene: camera, background, lighting and objects, over ``duration_s`` at ``fps``.

    ``domain`` says which data domain the frames are for: ``"sim"`` (video, 8-bit BGR frames,
    30-60 fps, up to 1920×1080) or ``"dvs"`` (a high frame rate at the sensor size, 240×180 by
    default, frames of linear gray intensity as ``float32`` on the 0-255 scale for the sensor
    emulator). ``output`` overrides the frame format: ``"bgr8"`` or ``"gray32f"``.
    ``focal_px`` is the pinhole focal length in pixels of this frame size; ``tilt_deg`` raises
    the camera's optical axis above the horizontal; ``pan_deg_s`` turns the camera (yaw, pitch)
    at a steady rate.

    ``aperture_mm`` is the lens's aperture (entrance pupil) diameter and ``focus_m`` the range
    it is focused at (``None``: infinity). A thin lens blurs a point at range ``Z`` into a disk
    of ``focal_px · aperture · |1/Z − 1/focus_m|`` pixels across (:meth:`blur_px`); each object
    is drawn blurred by the disk of its centre's range, the background sharp. The default
    ``aperture_mm = 0`` is a pinhole: every range sharp, as scenes were drawn before the lens
    (:class:`uavsnn.scenes.Lens` sets both from an f-number and the sensor's pixel pitch).

    Size: a scene has at most :data:`MAX_OBJECTS` (64) objects and :data:`MAX_FRAMES` (10⁶)
    frames, and its frames as float32 (4 bytes a pixel, as the renderer draws them) at most
    :data:`MAX_SCENE_BYTES` (8·10⁹ bytes);
    the scenes :func:`uavsnn.scenes.sample_spec` draws by default have at most 500 frames, of
    at most 1.8·10⁹ bytes (1 s at 500 fps on a 1280×720 sensor). :func:`uavsnn.scenes.render`, which
    holds every frame at once, takes less (:data:`uavsnn.scenes.renderer.MAX_RENDER_BYTES`).
    """

    domain: str
    width: int
    height: int
    fps: float
    duration_s: float
    focal_px: float
    background: Background = field(default_factory=Background)
    lighting: Lighting = field(default_factory=Lighting)
    objects: tuple[ObjectSpec, ...] = ()
    tilt_deg: float = 10.0
    pan_deg_s: tuple[float, float] = (0.0, 0.0)
    output: str | None = None
    aperture_mm: float = 0.0
    focus_m: float | None = None

    def __post_init__(self) -> None:
        if self.domain not in DOMAINS:
            raise SimulationError(f"domain must be one of {DOMAINS}, got {self.domain!r}")
        for name in ("width", "height"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or not 8 <= value <= 4096:
                raise SimulationError(f"{name} must be an integer in [8, 4096], got {value!r}")
        _finite("fps", self.fps, low=1.0, high=100_000.0)
        _finite("duration_s", self.duration_s, low=0.0, low_open=True, high=600.0)
        if self.n_frames < 2:
            raise SimulationError(
                f"a scene needs at least 2 frames, got {self.n_frames} "
                f"({self.duration_s} s at {self.fps} fps)"
            )
        if self.n_frames > MAX_FRAMES:
            raise SimulationError(
                f"scene too long: {self.n_frames} frames ({self.duration_s} s at {self.fps} "
                f"fps), more than {MAX_FRAMES:,}: shorten duration_s or lower fps"
            )
        nbytes = 4 * self.n_frames * self.width * self.height
        if nbytes > MAX_SCENE_BYTES:
            raise SimulationError(
                f"scene too large to hold in memory: {self.n_frames} frames of "
                f"{self.width}x{self.height} are {nbytes / 1e9:.1f} GB of float32, more than "
                f"{MAX_SCENE_BYTES / 1e9:g} GB: shorten duration_s, lower fps or the size"
            )
        _finite("focal_px", self.focal_px, low=0.0, low_open=True, high=1e6)
        _finite("tilt_deg", self.tilt_deg, low=-89.0, high=89.0)
        pan = _vector("pan_deg_s", self.pan_deg_s, (2,))
        if np.any(np.abs(pan) > 90):
            raise SimulationError(f"pan_deg_s must be within ±90 deg/s, got {pan.tolist()}")
        _store(self, "pan_deg_s", pan)
        if self.output not in (None, "bgr8", "gray32f"):
            raise SimulationError(f"output must be 'bgr8' or 'gray32f', got {self.output!r}")
        _finite("aperture_mm", self.aperture_mm, low=0.0, high=500.0)
        if self.focus_m is not None:
            _finite("focus_m", self.focus_m, low=NEAR_FOCUS_M, high=1e6)
        if not isinstance(self.background, Background):
            raise SimulationError(f"background must be a Background, got {self.background!r}")
        if not isinstance(self.lighting, Lighting):
            raise SimulationError(f"lighting must be a Lighting, got {self.lighting!r}")
        if len(self.objects) > MAX_OBJECTS:
            raise SimulationError(
                f"a scene has at most {MAX_OBJECTS} objects (MAX_OBJECTS), got {len(self.objects)}"
            )
        for i, obj in enumerate(self.objects):
            if not isinstance(obj, ObjectSpec):
                raise SimulationError(f"objects[{i}] must be an ObjectSpec, got {obj!r}")

    @property
    def n_frames(self) -> int:
        """Number of frames: one at ``t = 0`` and one every ``1/fps`` while ``t < duration``."""
        return math.ceil(self.duration_s * self.fps - 1e-9)

    @property
    def frame_format(self) -> str:
        """``"bgr8"`` or ``"gray32f"``: the explicit ``output``, else the domain's default."""
        if self.output is not None:
            return self.output
        return "bgr8" if self.domain == "sim" else "gray32f"

    def blur_px(self, scale: np.ndarray) -> np.ndarray:
        """The diameter in pixels of the disk the lens blurs a point into, for points drawn at
        ``scale`` pixels per metre (``focal_px / Z``; 0 where not drawn gives 0):
        ``aperture · |scale − focal_px / focus_m|``."""
        scale = np.asarray(scale, dtype=np.float64)
        if self.aperture_mm == 0:
            return np.zeros_like(scale)
        focus = 0.0 if self.focus_m is None else self.focal_px / self.focus_m
        return np.where(scale > 0, 1e-3 * self.aperture_mm * np.abs(scale - focus), 0.0)

    @property
    def horizontal_fov_deg(self) -> float:
        """The horizontal field of view that ``focal_px`` gives at this width."""
        return math.degrees(2 * math.atan(self.width / (2 * self.focal_px)))
