"""Draw a :class:`~uavsnn.scenes.SceneSpec` into frames, with a label per frame.

Per frame: crop the background textures (one warp each), draw each object far to near — its
parts projected in one matrix product and filled anti-aliased at 1/16 pixel into a patch around
it, spread by the lens's blur disk at its range when the spec has a lens — then light the frame
and encode it as a camera would (8-bit gamma-encoded BGR with noise for "sim"; linear gray
intensity on the 0-255 scale for the "dvs" sensor emulator, which adds its own noise).
:func:`frames` renders one frame at a time and, for "dvs", also renders fast parts (rotors,
wings) in patches at jittered times between frames for the emulator
(:func:`uavsnn.scenes.record`).

A frame's label is the box of the first visible UAV of the spec; failing that, of the first
visible other object (``uav`` false); failing that, ``cls == "none"`` and a NaN box. A box is the
bound of everything drawn for the object (rotor discs and blades included, and the lens's
blur), clipped to the frame, in continuous pixel coordinates (pixel ``(i, j)`` covers
``[i, i+1) × [j, j+1)``). An object is visible when at least a pixel's width and height of its
box (or all of it, if it is smaller) lies in the frame. The label also carries the object's
range (metres from the camera to its centre) and its size in pixels (the longer side of its
whole bound, before clipping).
"""

from __future__ import annotations

import math
import operator
from collections.abc import Iterator
from functools import lru_cache
from typing import NamedTuple

import cv2
import numpy as np

from uavsnn.errors import SimulationError
from uavsnn.scenes import portable
from uavsnn.scenes.backgrounds import Backdrop, tone
from uavsnn.scenes.camera import Camera, view_rotation
from uavsnn.scenes.objects import Model, Part, model_for
from uavsnn.scenes.spec import SceneSpec

__all__ = ["LABEL_DTYPE", "SAMPLES_PER_PASS", "Frame", "frames", "render", "scene_labels"]

#: One label per frame: is a UAV visible, the class of the labelled object, its box (clipped
#: to the frame), its range in metres (NaN where unknown, as for real footage) and its size in
#: pixels (the longer side of the unclipped bound).
LABEL_DTYPE = np.dtype(
    [
        ("uav", "?"),
        ("cls", "<U12"),
        ("x0", "<f4"),
        ("y0", "<f4"),
        ("x1", "<f4"),
        ("y1", "<f4"),
        ("range_m", "<f4"),
        ("size_px", "<f4"),
    ]
)

#: A frame's label as :meth:`_Objects.draw` gives it.
_Label = tuple[bool, str, float, float, float, float, float, float]

# Coverage: each mask is filled on a grid SS times finer (vertices at 1/16 of a fine pixel,
# cv2's shift=4) and box-averaged down, so a pixel's opacity is the share of it that the
# polygon covers and nothing spills past the polygon (cv2's own antialiasing spreads 1.5 px).
_SS = 4


def _box_visible(
    box: tuple[float, float, float, float], w: int, h: int
) -> tuple[bool, tuple[float, float, float, float]]:
    x0, y0, x1, y1 = box
    cx0, cy0, cx1, cy1 = max(x0, 0.0), max(y0, 0.0), min(x1, float(w)), min(y1, float(h))
    visible = (
        cx1 - cx0 >= min(1.0, x1 - x0)
        and cy1 - cy0 >= min(1.0, y1 - y0)
        and cx1 > cx0
        and cy1 > cy0
    )
    return visible, (cx0, cy0, cx1, cy1)


@lru_cache(maxsize=4096)
def _tone(color: tuple[float, float, float], channels: int) -> np.ndarray:
    return tone(color, channels)


def _draw(
    img: np.ndarray | None,
    parts: list[Part],
    rot: np.ndarray,
    uv: np.ndarray,
    scale: float,
    elevation: float,
    faces_camera: bool,
    ss: int = _SS,
    blur: float = 0.0,
) -> tuple[float, float, float, float]:
    """Fill the parts into ``img`` (in place; ``None`` to only measure) and return the bound
    of what is drawn. ``ss``: the coverage grid's subdivisions per pixel (finer for thin
    fast parts, whose coverage would otherwise step by a sixteenth of a pixel as they turn).
    ``blur``: the diameter (px) of the lens's blur disk at the object's range; each group's
    coverage is spread by that disk (:func:`_disk`) before it is painted, and the bound grows
    by its radius (or by the whole pixels the disk's kernel reaches, where that is more).
    Below a pixel nothing is spread (the disk fits its own pixel).

    Parts of one colour and opacity share a mask; these groups are painted far to near by
    their mean depth along the line of sight.
    """
    m = portable.matmul(np.eye(3) if faces_camera else view_rotation(elevation), rot)
    pts = portable.matmul(np.concatenate([p.points for p in parts]), m.T)
    xy = np.empty((len(pts), 2))
    xy[:, 0] = uv[0] + scale * pts[:, 0]
    xy[:, 1] = uv[1] - scale * pts[:, 1]  # screen y points down
    (x0, y0), (x1, y1) = xy.min(axis=0).tolist(), xy.max(axis=0).tolist()
    kernel = _disk(_blur_key(blur))
    reach = kernel.shape[0] // 2  # pixels the blur reaches past a covered pixel
    if reach:
        r = max(0.5 * blur, reach)
        x0, y0, x1, y1 = x0 - r, y0 - r, x1 + r, y1 + r
    box = (x0, y0, x1, y1)
    if img is None:
        return box
    h, w, c = img.shape
    if box[2] < -1 or box[3] < -1 or box[0] > w + 1 or box[1] > h + 1:
        return box
    # Fine-grid coordinates, with cv2's pixel centres on integers (ours are at +0.5).
    fix = 16 * ss
    fixed = np.round((xy * ss - 0.5) * 16).astype(np.int32)
    sizes = np.array([len(p.points) for p in parts])
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    part_depth = (np.add.reduceat(pts[:, 2], starts) / sizes).tolist()
    # Each part's bounds on the fine grid (its hull's, too: a hull's points are its own).
    part_lo = np.minimum.reduceat(fixed, starts).tolist()
    part_hi = np.maximum.reduceat(fixed, starts).tolist()
    bounds = [*starts.tolist(), len(fixed)]
    groups: dict[tuple[tuple[float, float, float], float], list[int]] = {}
    for i, part in enumerate(parts):
        groups.setdefault((part.color, part.alpha), []).append(i)

    def mean_depth(key: tuple[tuple[float, float, float], float]) -> float:
        members = groups[key]
        return sum(part_depth[i] for i in members) / len(members)

    for key in sorted(groups, key=mean_depth, reverse=True):
        if key[1] <= 0:
            continue
        members = groups[key]
        # The patch drawn: the group's pixels, and as far as the blur reaches past them (off
        # the frame too, so that what lies just outside it blurs in).
        px0 = max(min(part_lo[i][0] for i in members) // fix - 1 - reach, -reach)
        py0 = max(min(part_lo[i][1] for i in members) // fix - 1 - reach, -reach)
        px1 = min(-(-max(part_hi[i][0] for i in members) // fix) + 2 + reach, w + reach)
        py1 = min(-(-max(part_hi[i][1] for i in members) // fix) + 2 + reach, h + reach)
        if px1 <= px0 or py1 <= py0:
            continue
        fine = np.zeros(((py1 - py0) * ss, (px1 - px0) * ss), dtype=np.uint8)
        origin = (-px0 * fix, -py0 * fix)
        for i in members:
            poly: np.ndarray = fixed[bounds[i] : bounds[i + 1]]
            if parts[i].hull:
                poly = cv2.convexHull(poly)
            # One call per polygon: OpenCV fills overlaps of one call's polygons even-odd.
            # The offset is added in the points' own fixed-point units, before the shift.
            cv2.fillPoly(fine, [poly], 255, cv2.LINE_8, shift=4, offset=origin)
        mask = cv2.resize(fine, (px1 - px0, py1 - py0), interpolation=cv2.INTER_AREA)
        a: np.ndarray = mask.astype(np.float32) * np.float32(key[1] / 255.0)
        if reach:
            spread = cv2.filter2D(a, -1, kernel, borderType=cv2.BORDER_CONSTANT)
            cx0, cy0, cx1, cy1 = max(px0, 0), max(py0, 0), min(px1, w), min(py1, h)
            if cx1 <= cx0 or cy1 <= cy0:
                continue
            a = spread[cy0 - py0 : cy1 - py0, cx0 - px0 : cx1 - px0]
            px0, py0, px1, py1 = cx0, cy0, cx1, cy1
        region = img[py0:py1, px0:px1]
        region += a[:, :, None] * (_tone(key[0], c) - region)
    return box


#: The blur disks are cached by diameter in steps of 1/_BLUR_STEPS of a pixel.
_BLUR_STEPS = 16

#: The widest blur disk (diameter in pixels) an object may be drawn with: the lens's blur at an
#: object's range (:meth:`~uavsnn.scenes.SceneSpec.blur_px`, from the spec's ``aperture_mm`` and
#: ``focus_m``) is at most this at every frame, or the scene is refused before anything is drawn.
#: No point nearer than 5 cm is drawn nor focused on, so a lens blurs by less than
#: ``focal_px · aperture / 5 cm``. The scenes :func:`uavsnn.scenes.sample_spec` draws at their
#: default views (45-70°) blur by at most 464 px through any lens the command line takes (f/0.5
#: focused at 5 cm on a 1280×720 Gen4), and at the narrow view of docs/identification.md (18-22°
#: at f/1.4 on 1280×720) by at most 1,134 px (an insect at 5 cm; 600 px in 5,000 insect scenes).
#: A disk this wide is a 2049 × 2049 kernel (17 MB) spread over a patch some 2,050 px across.
MAX_BLUR_PX = 2048

#: Disks up to this many cache steps across (64 px) are kept 512 at a time, wider ones 8 at a
#: time: at most 9 MB and 134 MB of kernels.
_SMALL_DISK = 64 * _BLUR_STEPS


def _blur_key(blur: float) -> int:
    """``blur`` (px) rounded to a step of the disks' cache; 0 for no blur."""
    if not (math.isfinite(blur) and blur > 0):
        return 0
    return round(blur * _BLUR_STEPS)


def _make_disk(key: int) -> np.ndarray:
    """The lens's blur kernel: a uniform disk ``key / _BLUR_STEPS`` pixels across, each of its
    pixels weighted by the share of it the disk covers (on a 16 × 16 grid per pixel), summing
    to 1; ``(1, 1)`` while the disk fits inside one pixel. The grid is sampled a row of pixels
    at a time (16 × 16·n samples, not (16·n)² at once)."""
    radius = key / _BLUR_STEPS / 2
    reach = max(math.ceil(radius - 0.5), 0)
    n, sub = 2 * reach + 1, 16
    c = (np.arange(n * sub) + 0.5) / sub - (reach + 0.5)
    sq, r2 = c**2, radius * radius
    cover = np.empty((n, n), dtype=np.float64)
    for i in range(n):
        inside = (sq[i * sub : (i + 1) * sub, None] + sq[None, :]) <= r2
        cover[i] = inside.reshape(sub, n, sub).sum(axis=(0, 2))
    if cover.sum() == 0:
        return np.ones((1, 1), dtype=np.float32)
    return (cover / cover.sum()).astype(np.float32)


_small_disk = lru_cache(maxsize=512)(_make_disk)
_wide_disk = lru_cache(maxsize=8)(_make_disk)


def _disk(key: int) -> np.ndarray:
    """The blur kernel of :func:`_make_disk`, cached."""
    return _small_disk(key) if key <= _SMALL_DISK else _wide_disk(key)


def _encode_bgr8(
    lin: np.ndarray, level: float, noise: float, rng: np.random.Generator, grain: np.ndarray | None
) -> np.ndarray:
    """A video camera: gamma 1/2.2, read and shot noise that grow as the light falls, 8 bits."""
    x = np.clip(lin * np.float32(level), 0.0, 1.0)
    # In software, as the renderer's other functions (uavsnn.scenes.portable): OpenCV's pow
    # rounds float32 otherwise in its SIMD and scalar code, and the sim frames with it.
    v = portable.power(x, 1.0 / 2.2).astype(np.float32) * np.float32(255.0)
    sigma = noise * (1.0 + 1.5 * math.log10(1.0 / max(level, 1e-3)))
    if sigma > 0 and grain is not None:
        # A random crop of a pre-drawn field of unit noise: independent enough from frame to
        # frame, and ten times cheaper than drawing fresh normals for every pixel.
        h, w = v.shape[:2]
        i = int(rng.integers(0, grain.shape[0] - h + 1))
        j = int(rng.integers(0, grain.shape[1] - w + 1))
        v += grain[i : i + h, j : j + w].reshape(v.shape) * np.float32(sigma)
    v += np.float32(0.5)
    np.clip(v, 0, 255, out=v)
    return v.astype(np.uint8)


def _check(spec: SceneSpec) -> None:
    if not isinstance(spec, SceneSpec):
        raise SimulationError(f"spec must be a SceneSpec, got {type(spec).__name__}")


def _frame_times(spec: SceneSpec) -> tuple[np.ndarray, np.ndarray]:
    times = np.arange(spec.n_frames, dtype=np.float64) / spec.fps
    return times, np.round(times * 1e6).astype(np.uint64)


class _Objects:
    """The spec's objects along their paths: where, how big, seen from how high."""

    def __init__(self, spec: SceneSpec, cam: Camera, times: np.ndarray) -> None:
        self.spec = spec
        ev = spec.frame_format == "gray32f"
        self.models: list[Model] = [model_for(o, event_camera=ev) for o in spec.objects]
        #: Each object's box at the last frame drawn (``None``: not drawn).
        self.boxes: list[tuple[float, float, float, float] | None] = [None] * len(self.models)
        #: Each object's positions, velocities, image centres, scales and elevations by frame.
        self.tracks: list[tuple[np.ndarray, ...]] = []
        grounded = spec.background.kind in ("ground", "hall")
        for obj in spec.objects:
            pos = obj.path.position(times)
            uv, scale = cam.project(pos, times)
            if grounded:
                # Below the ground or the hall's floor, an object is hidden.
                height = cam.altitude(pos, spec.background.camera_height_m)
                scale = np.where(height < 0, 0.0, scale)
            self._check_blur(len(self.tracks), obj.kind, pos, scale)
            self.tracks.append((pos, obj.path.velocity_at(times), uv, scale, cam.elevation(pos)))

    def _check_blur(self, i: int, kind: str, pos: np.ndarray, scale: np.ndarray) -> None:
        """Refuse an object the lens blurs over more than :data:`MAX_BLUR_PX` at any frame (its
        blur disk would be that wide). Between frames the scale is interpolated and the blur,
        ``|scale − focus|`` times the aperture, is largest at a frame."""
        blur = self.spec.blur_px(scale)
        k = int(np.argmax(blur))
        if blur[k] > MAX_BLUR_PX:
            focus = "infinity" if self.spec.focus_m is None else f"{self.spec.focus_m:g} m"
            raise SimulationError(
                f"lens blur too wide: objects[{i}] ({kind}) at {pos[k, 2]:.3g} m is blurred over "
                f"{blur[k]:,.0f} px at frame {k} by aperture_mm {self.spec.aperture_mm:g} focused "
                f"at {focus} (focus_m), more than MAX_BLUR_PX ({MAX_BLUR_PX:,} px): give a "
                "smaller aperture_mm, or a focus_m nearer the object's range"
            )

    def draw_between(
        self,
        img: np.ndarray,
        k: int,
        alpha: float,
        t: float,
        origin: tuple[int, int],
        only: set[int],
        ss: int = _SS,
    ) -> None:
        """Draw the objects ``only`` far to near into ``img``, a patch whose top-left pixel is
        ``origin``, at time ``t`` a fraction ``alpha`` of the way from frame ``k - 1`` to frame
        ``k``: path and view interpolated, moving parts (rotors, wings) at ``t`` itself."""
        order = sorted(only, key=lambda i: -self.tracks[i][0][k, 2])
        b = 1.0 - alpha
        for i in order:
            _, vel, uv, scale, elev = self.tracks[i]
            if scale[k] <= 0 or scale[k - 1] <= 0:
                continue
            parts, rot = self.models[i].parts(t, vel[k])
            at = b * uv[k - 1] + alpha * uv[k] - np.asarray(origin, dtype=np.float64)
            s_at = float(b * scale[k - 1] + alpha * scale[k])
            _draw(
                img,
                parts,
                rot,
                at,
                s_at,
                float(b * elev[k - 1] + alpha * elev[k]),
                self.models[i].faces_camera,
                ss,
                float(self.spec.blur_px(np.array(s_at))),
            )

    def draw(
        self, img: np.ndarray | None, k: int, t: float, fine: frozenset[int] = frozenset()
    ) -> _Label:
        """Draw frame ``k`` at time ``t`` far to near into ``img`` (or only measure, for
        ``None``); return the frame's label. The objects ``fine`` are drawn on the coverage
        grid of the parts drawn between frames (:data:`FINE_SS`), as they are there."""
        boxes: list[tuple[float, float, float, float] | None] = [None] * len(self.models)
        order = sorted(range(len(self.models)), key=lambda i: -self.tracks[i][0][k, 2])
        for i in order:
            _, vel, uv, scale, elev = self.tracks[i]
            if scale[k] <= 0:
                continue
            parts, rot = self.models[i].parts(t, vel[k])
            boxes[i] = _draw(
                img,
                parts,
                rot,
                uv[k],
                float(scale[k]),
                float(elev[k]),
                self.models[i].faces_camera,
                FINE_SS if i in fine else _SS,
                blur=float(self.spec.blur_px(scale[k])),
            )
        self.boxes = boxes
        ranges = [portable.norm(track[0][k]) for track in self.tracks]
        return _label(self.spec, boxes, ranges, self.spec.width, self.spec.height)


#: Coverage grid of objects with fast parts (rotors, wings) in the "dvs" domain, at frames and
#: between them: 8 × 8 per pixel, so that a blade a tenth of a pixel wide covers its pixels
#: smoothly as it turns.
FINE_SS = 8

#: Sub-frame samples per period of an object's fastest motion (a blade passage, a wing beat)
#: that the "dvs" domain's renderings give the emulator (the issue's floor is 4). A blade a
#: tenth of a pixel wide gives its pixels harmonics of the blade pass up to several kHz, and
#: the emulator takes the samples as they come (its photoreceptor's low-pass acts after them):
#: at 6 a passage (1500 samples a second for a 240 Hz blade pass at 500 fps) the harmonics
#: above half that rate folded back about it through the frames, the one sample of each frame
#: interval whose time is not jittered, into lines at 1500 − 240·n Hz (60, 300, 540, 780 Hz), and
#: the sparse samples missed part of the rotor's events; at 24 the folds lie beyond 5 kHz, where
#: the harmonics are weak (``python benches/python/drone_bird_spectra.py --samples-per-pass 6``
#: against the default).
SAMPLES_PER_PASS = 24

#: The sub-frame samples of one patch between two frames hold at most this many bytes
#: (float32): a larger patch gets fewer samples. The scenes that
#: :func:`uavsnn.scenes.sample_spec` draws take at most 7 samples of a patch no larger than the
#: frame (26 MB on a 1280×720 sensor).
MAX_PATCH_BYTES = 1 << 30

#: :func:`render` holds every frame of a scene at once, at most this many bytes of them (4 GiB);
#: :func:`frames` and :func:`uavsnn.scenes.record` hold one frame at a time. A 1 s "dvs" scene
#: at 500 fps on a 1280×720 sensor is 1.8·10⁹ bytes.
MAX_RENDER_BYTES = 1 << 32


class Frame(NamedTuple):
    """One rendered frame: index, time, image, label, and the sub-frame patches since the
    previous frame (``(x0, y0, times_us, values)`` each, see
    :meth:`uavsnn.sim.DvsEmulator.process_frame`; empty for video and for the first frame)."""

    k: int
    t_us: int
    image: np.ndarray
    label: _Label
    patches: list[tuple[int, int, np.ndarray, np.ndarray]]


def frames(
    spec: SceneSpec, *, seed: int, samples_per_pass: int = SAMPLES_PER_PASS
) -> Iterator[Frame]:
    """Render ``spec`` one frame at a time (bounded memory), with sub-frame samples of fast
    objects for the "dvs" format (``gray32f``).

    Between frames ``k - 1`` and ``k``, an object whose look repeats at ``fast_hz`` (a rotor's
    blade pass, a wing beat) is rendered again in a patch around it at
    ``ceil(samples_per_pass · fast_hz / fps) - 1`` evenly spaced times (integer microseconds;
    at most one a microsecond, and no more than :data:`MAX_PATCH_BYTES` of samples a patch),
    on the background interpolated between the two frames and with its path interpolated, its
    moving parts at each time; overlapping patches merge. ``samples_per_pass = 0`` turns this
    off (every motion sampled at the frame rate only, as before). Frames are the same as
    :func:`render`'s.

    Raises:
        SimulationError: a bad spec, seed or ``samples_per_pass``, or an object that the lens
            blurs over more than :data:`MAX_BLUR_PX` at some frame (before anything is drawn).
    """
    _check(spec)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise SimulationError(f"seed must be a non-negative integer, got {seed!r}")
    if (
        isinstance(samples_per_pass, bool)
        or not isinstance(samples_per_pass, (int, np.integer))
        or not 0 <= samples_per_pass <= 64
    ):
        raise SimulationError(
            f"samples_per_pass must be an integer in [0, 64], got {samples_per_pass!r}"
        )
    tex_seq, noise_seq, jitter_seq = np.random.SeedSequence(int(seed)).spawn(3)
    tex_rng, noise_rng = np.random.default_rng(tex_seq), np.random.default_rng(noise_seq)
    jitter = np.random.default_rng(jitter_seq)
    w, h = spec.width, spec.height
    times, timestamps = _frame_times(spec)
    cam = Camera(spec)
    shifts = cam.shift(times)
    fmt = spec.frame_format
    channels = 3 if fmt == "bgr8" else 1
    objects = _Objects(spec, cam, times)  # first: it refuses a blur too wide, before any texture
    backdrop = Backdrop(spec, cam, shifts, tex_rng, channels)
    light = spec.lighting
    grain = None
    if fmt == "bgr8" and light.noise > 0:
        grain = noise_rng.standard_normal((2 * h, 2 * w, 3), dtype=np.float32)
    # Sub-steps per frame interval of each object (1: none between frames).
    steps = [
        max(1, math.ceil(samples_per_pass * m.fast_hz() / spec.fps - 1e-9))
        if fmt != "bgr8" and samples_per_pass
        else 1
        for m in objects.models
    ]
    fast = [i for i, m in enumerate(steps) if m > 1]
    # The objects whose look repeats fast are drawn at frames on the grid their sub-frame
    # samples are drawn on, whether or not they are sampled between frames (render() does not):
    # drawn coarser at frames only, a blade's coverage differed between the frames and the
    # samples between them by its phase, which put a line at a beat of the blade pass with the
    # frame rate into the events (fps/5 for a blade pass of 0.8 fps).
    fine = frozenset(i for i, m in enumerate(objects.models) if fmt != "bgr8" and m.fast_hz() > 0)

    def level_at(t: float) -> float:
        return light.level * (1.0 + light.flicker * math.sin(2 * math.pi * light.flicker_hz * t))

    prev_bg: np.ndarray | None = None
    prev_boxes: list[tuple[float, float, float, float] | None] = []
    for k in range(spec.n_frames):
        t = float(times[k])
        img = backdrop.frame(t, shifts[k])
        bg = img.copy() if fast else None
        label = objects.draw(img, k, t, fine)
        level = level_at(t)
        if fmt == "bgr8":
            image = _encode_bgr8(img, level, light.noise, noise_rng, grain)
        else:
            image = img[:, :, 0] * np.float32(level * 255.0)
        patches: list[tuple[int, int, np.ndarray, np.ndarray]] = []
        if fast and k > 0 and prev_bg is not None and bg is not None:
            t0, t1 = int(timestamps[k - 1]), int(timestamps[k])
            for (x0, y0, x1, y1), members in _patches(fast, prev_boxes, objects.boxes, w, h):
                m = max(steps[i] for i in members)
                m = min(m, MAX_PATCH_BYTES // (4 * (y1 - y0) * (x1 - x0)) + 1)
                sub = sub_frame_times(t0, t1, m, jitter)
                if not len(sub):
                    continue
                # Everything drawn that may cover the patch, not only the fast objects.
                near = {
                    i
                    for i, (bp, bc) in enumerate(zip(prev_boxes, objects.boxes, strict=True))
                    if bp is not None
                    and bc is not None
                    and min(bp[0], bc[0]) < x1
                    and max(bp[2], bc[2]) > x0
                    and min(bp[1], bc[1]) < y1
                    and max(bp[3], bc[3]) > y0
                }
                values = np.empty((len(sub), y1 - y0, x1 - x0), dtype=np.float32)
                a_bg, b_bg = prev_bg[y0:y1, x0:x1], bg[y0:y1, x0:x1]
                for j, ts in enumerate(sub.tolist()):
                    alpha = (ts - t0) / (t1 - t0)
                    patch = a_bg + np.float32(alpha) * (b_bg - a_bg)
                    objects.draw_between(patch, k, alpha, ts * 1e-6, (x0, y0), near, FINE_SS)
                    values[j] = patch[:, :, 0] * np.float32(level_at(ts * 1e-6) * 255.0)
                patches.append((x0, y0, sub, values))
        prev_bg, prev_boxes = bg, list(objects.boxes)
        yield Frame(k, int(timestamps[k]), image, label, patches)


def sub_frame_times(t0: int, t1: int, m: int, rng: np.random.Generator) -> np.ndarray:
    """``m - 1`` sample times strictly between frames at ``t0`` and ``t1`` (µs), one in each
    of the strata centred on ``t0 + j (t1 - t0) / m``, at a random place in it: jittered, so
    that the sampling grid does not put lines of its own into the events' spectrum (regular
    sub-samples make the crossings of barely-crossing pixels bunch at the grid's rate).
    Integer microseconds, duplicates dropped; ``m`` is taken as at most ``t1 - t0`` (one
    stratum a microsecond), so that a huge ``m`` costs no more than the times there are."""
    m = min(m, t1 - t0)
    if m <= 1:
        return np.zeros(0, dtype=np.uint64)
    j = np.arange(1, m) + rng.random(m - 1) - 0.5
    sub = np.unique(np.round(t0 + (t1 - t0) * j / m).astype(np.int64))
    return sub[(sub > t0) & (sub < t1)].astype(np.uint64)


def _patches(
    fast: list[int],
    before: list[tuple[float, float, float, float] | None],
    after: list[tuple[float, float, float, float] | None],
    w: int,
    h: int,
) -> list[tuple[tuple[int, int, int, int], list[int]]]:
    """Disjoint integer rectangles, clipped to the frame, that cover each fast object's box at
    both frames (one pixel of margin), with the objects each covers; a box that is not finite
    (drawn at a scale that overflowed) is skipped."""
    rects: list[tuple[list[int], list[int]]] = []
    for i in fast:
        a, b = before[i], after[i]
        if a is None or b is None or not all(map(math.isfinite, (*a, *b))):
            continue
        r = [
            max(math.floor(min(a[0], b[0])) - 1, 0),
            max(math.floor(min(a[1], b[1])) - 1, 0),
            min(math.ceil(max(a[2], b[2])) + 1, w),
            min(math.ceil(max(a[3], b[3])) + 1, h),
        ]
        if r[2] > r[0] and r[3] > r[1]:
            rects.append((r, [i]))
    merged = True
    while merged:
        merged = False
        for p in range(len(rects)):
            for q in range(p + 1, len(rects)):
                r, s = rects[p][0], rects[q][0]
                if r[0] < s[2] and s[0] < r[2] and r[1] < s[3] and s[1] < r[3]:
                    rects[p] = (
                        [min(r[0], s[0]), min(r[1], s[1]), max(r[2], s[2]), max(r[3], s[3])],
                        rects[p][1] + rects[q][1],
                    )
                    del rects[q]
                    merged = True
                    break
            if merged:
                break
    return [((r[0], r[1], r[2], r[3]), members) for r, members in rects]


def render(spec: SceneSpec, *, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Render ``spec``: ``(frames, timestamps_us, labels)``.

    ``frames``: ``(n, h, w, 3)`` ``uint8`` BGR for the "sim" domain (or ``output="bgr8"``), or
    ``(n, h, w)`` ``float32`` linear gray on the 0-255 scale for "dvs" (``output="gray32f"``).
    ``timestamps_us``: ``(n,)`` ``uint64``, frame ``k`` at ``round(k·1e6/fps)``.
    ``labels``: ``(n,)`` of :data:`LABEL_DTYPE`. The same spec and seed give the same frames;
    the seed shapes only textures (clouds, trees, grain) and camera noise, which do not depend
    on the objects, so the spec without its objects renders the same background.

    Whole frames only: for the "dvs" domain, :func:`uavsnn.scenes.record` also renders fast
    parts between frames (:func:`frames`) and is what the dataset builder uses.

    Raises:
        SimulationError: a bad spec, frames of more than :data:`MAX_RENDER_BYTES` in all, or
            a lens blur wider than :data:`MAX_BLUR_PX` (:func:`frames`).
    """
    _check(spec)
    n, w, h = spec.n_frames, spec.width, spec.height
    nbytes = n * w * h * (3 if spec.frame_format == "bgr8" else 4)
    if nbytes > MAX_RENDER_BYTES:
        raise SimulationError(
            f"render holds every frame at once: {n} frames of {w}x{h} are "
            f"{nbytes / 1e9:.1f} GB, more than {MAX_RENDER_BYTES / 1e9:.1f} GB; shorten the "
            "scene (duration_s), lower its fps, or take its frames one at a time (frames(), "
            "record())"
        )
    out = (
        np.empty((n, h, w, 3), dtype=np.uint8)
        if spec.frame_format == "bgr8"
        else np.empty((n, h, w), dtype=np.float32)
    )
    labels = np.zeros(n, dtype=LABEL_DTYPE)
    _, timestamps = _frame_times(spec)
    for f in frames(spec, seed=seed, samples_per_pass=0):
        out[f.k] = f.image
        labels[f.k] = f.label
    return out, timestamps, labels


def scene_labels(spec: SceneSpec) -> tuple[np.ndarray, np.ndarray]:
    """``(timestamps_us, labels)`` exactly as :func:`render` gives them, without drawing a
    pixel (the objects' geometry is still built frame by frame, so it takes about half the
    time of a small render); the same refusals of a lens blur too wide (:func:`frames`)."""
    _check(spec)
    times, timestamps = _frame_times(spec)
    objects = _Objects(spec, Camera(spec), times)
    labels = np.zeros(spec.n_frames, dtype=LABEL_DTYPE)
    for k in range(spec.n_frames):
        labels[k] = objects.draw(None, k, float(times[k]))
    return timestamps, labels


def _label(
    spec: SceneSpec,
    boxes: list[tuple[float, float, float, float] | None],
    ranges: list[float],
    w: int,
    h: int,
) -> _Label:
    """The frame's label: the first visible UAV, else the first visible other object."""
    visible = []
    for obj, box, range_m in zip(spec.objects, boxes, ranges, strict=True):
        if box is None:
            continue
        ok, clipped = _box_visible(box, w, h)
        if ok:
            size = max(box[2] - box[0], box[3] - box[1])
            visible.append((not obj.is_uav, obj.cls, clipped, range_m, size))
    if not visible:
        nan = float("nan")
        return (False, "none", nan, nan, nan, nan, nan, nan)
    # Stable: UAVs first, then spec order.
    not_uav, cls, (x0, y0, x1, y1), range_m, size = min(visible, key=operator.itemgetter(0))
    return (not not_uav, cls, x0, y0, x1, y1, range_m, size)
