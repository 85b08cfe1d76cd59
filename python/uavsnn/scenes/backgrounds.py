"""What lies behind the objects: sky with drifting clouds, a field with trees, a sports hall.

Each background is built once per render as textures a little larger than the frame (so that a
panning camera and drifting clouds stay covered) and each frame is a sub-pixel crop of them,
one bilinear shift per layer (``portable.shift_linear``: the same bits on every CPU, which
OpenCV's ``warpAffine`` is not), no per-pixel Python. The ground and the hall
are ray-cast through the same pinhole camera as the objects, so the horizon, the court lines
and the trees sit where the camera's tilt puts them.

Colours are linear reflectances or radiances (BGR, roughly [0, 1]) before lighting.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from uavsnn.errors import SimulationError
from uavsnn.scenes import portable
from uavsnn.scenes.camera import Camera
from uavsnn.scenes.spec import SceneSpec

__all__ = ["MAX_NOISE_PIXELS", "MAX_TEXTURE_PIXELS", "Backdrop", "fractal_noise", "tone"]

_LUMA = np.array([0.114, 0.587, 0.299], dtype=np.float32)  # BT.601 weights of B, G, R

#: A background's textures (the frame, the pan's travel and the clouds' drift) hold at most
#: this many pixels (2**25; 128 MiB a float32 layer, and a ground or a hall builds about twenty
#: layers). The scenes :func:`uavsnn.scenes.sample_spec` draws on a 1280×720 sensor hold
#: about 10⁶; a fast pan or fast clouds over a long scene, at a long focal length, reach it.
MAX_TEXTURE_PIXELS = 1 << 25
#: :func:`fractal_noise` upsamples grids of at most this many pixels (2**29; 2 GiB of float32).
#: Its features are ``0.3 · focal_px`` across for the clouds, and the grid spans the texture
#: and four features more each way: the scenes :func:`uavsnn.scenes.sample_spec` draws with an
#: 18° view on a 1280×720 sensor need 3·10⁷, a 1° view on a 240×180 one 2.7·10⁸.
MAX_NOISE_PIXELS = 1 << 29


def tone(color: tuple[float, float, float] | np.ndarray, channels: int) -> np.ndarray:
    """A BGR colour as ``channels`` values: itself for 3, its luma for 1."""
    c = np.asarray(color, dtype=np.float32)
    if channels == 1:
        return portable.matmul(c, _LUMA).reshape(1)
    return c


def noise_pixels(height: int, width: int, scale: float, octaves: int = 4) -> int:
    """The pixels of the largest grid :func:`fractal_noise` upsamples for these arguments."""
    most = 0
    for o in range(octaves):
        s = max(scale / (2**o), 2.0)
        gh, gw = math.ceil(height / s) + 3, math.ceil(width / s) + 3
        most = max(most, int(gw * s) * int(gh * s))
    return most


def fractal_noise(
    rng: np.random.Generator, height: int, width: int, scale: float, octaves: int = 4
) -> np.ndarray:
    """Smooth value noise in [0, 1] with features about ``scale`` pixels across: octaves of
    upsampled random grids, each half the size and weight of the one before.

    Raises:
        SimulationError: a grid of more than :data:`MAX_NOISE_PIXELS` (:func:`noise_pixels`).
    """
    need = noise_pixels(height, width, scale, octaves)
    if need > MAX_NOISE_PIXELS:
        raise SimulationError(
            f"noise of {width}x{height} pixels with features {scale:.0f} px across needs a grid "
            f"of {need:,} pixels, more than {MAX_NOISE_PIXELS:,}"
        )
    total = np.zeros((height, width), dtype=np.float32)
    amp, norm = 1.0, 0.0
    for o in range(octaves):
        s = max(scale / (2**o), 2.0)
        gh, gw = math.ceil(height / s) + 3, math.ceil(width / s) + 3
        grid = rng.random((gh, gw), dtype=np.float32)
        up = portable.resize_cubic(grid, (int(gw * s), int(gh * s)), (width, height))
        total += amp * up
        norm += amp
        amp *= 0.5
    total /= norm
    lo, hi = float(total.min()), float(total.max())
    return (total - lo) / max(hi - lo, 1e-6)


def _smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - e0) / max(e1 - e0, 1e-6), 0.0, 1.0)
    return t * t * (3 - 2 * t)


class Backdrop:
    """The object-free scene of a spec, frame by frame: ``frame(t, shift)``."""

    def __init__(
        self,
        spec: SceneSpec,
        camera: Camera,
        shifts: np.ndarray,
        rng: np.random.Generator,
        channels: int,
    ) -> None:
        self.spec = spec
        self.cam = camera
        self.c = channels
        w, h = spec.width, spec.height
        bg = spec.background
        lo = np.floor(np.minimum(shifts.min(axis=0), 0.0))
        hi = np.ceil(np.maximum(shifts.max(axis=0), 0.0))
        # Texture pixel (i, j) shows what frame pixel (i - mx, j - my) shows at t = 0.
        self.mx, self.my = float(hi[0]) + 2, float(hi[1]) + 2
        self.tw = int(w + hi[0] - lo[0] + 4)
        self.th = int(h + hi[1] - lo[1] + 4)
        duration = spec.n_frames / spec.fps
        self.cloud_px_s = camera.f * math.radians(bg.cloud_speed_deg_s)
        drift = abs(self.cloud_px_s) * duration
        self.cw = int(self.tw + math.ceil(drift) + 4)
        self.cloud_x0 = math.ceil(drift) + 2.0 if self.cloud_px_s > 0 else 2.0
        self._check_size()
        self.static = not np.any(shifts)
        self.sky: np.ndarray | None = None
        self.clouds: np.ndarray | None = None
        self.fg: np.ndarray | None = None  # (th, tw, c + 1): colour and alpha
        self.sway: np.ndarray | None = None
        self._cached: np.ndarray | None = None
        if bg.kind in ("sky", "ground"):
            self._build_sky(rng)
        if bg.kind == "ground":
            self._build_ground(rng)
        elif bg.kind == "hall":
            self._build_hall(rng)

    def _check_size(self) -> None:
        """Refuse, before building anything, textures of more than :data:`MAX_TEXTURE_PIXELS`
        and clouds whose noise needs more than :data:`MAX_NOISE_PIXELS`."""
        spec, bg = self.spec, self.spec.background
        clouds = bg.kind in ("sky", "ground") and bg.cloud_cover > 0
        width = max(self.tw, self.cw) if clouds else self.tw
        if self.th * width > MAX_TEXTURE_PIXELS:
            drift = f", the clouds' drift (background.cloud_speed_deg_s {bg.cloud_speed_deg_s})"
            raise SimulationError(
                f"the background's texture would be {width}x{self.th} pixels, more than "
                f"{MAX_TEXTURE_PIXELS:,}: the camera's pan (pan_deg_s {list(spec.pan_deg_s)})"
                f"{drift if clouds else ''} over duration_s {spec.duration_s} at focal_px "
                f"{spec.focal_px:g} carry the view too far; slow them or shorten the scene"
            )
        if clouds:
            scale = max(12.0, 0.3 * self.cam.f)
            need = noise_pixels(self.th, self.cw, scale, 5)
            if need > MAX_NOISE_PIXELS:
                raise SimulationError(
                    f"focal_px {spec.focal_px:g} (a {spec.horizontal_fov_deg:.2g}° view) draws "
                    f"clouds {scale:.0f} px across, whose texture needs {need:,} pixels, more "
                    f"than {MAX_NOISE_PIXELS:,}: widen the view (a smaller focal_px) or clear "
                    "the sky (background.cloud_cover 0)"
                )

    # -- geometry ------------------------------------------------------------------------------

    def _rays(self, height: int, width: int, x_off: float) -> tuple[np.ndarray, ...]:
        """World directions (right, up, forward) through texture pixel centres."""
        cam = self.cam
        u = (np.arange(width, dtype=np.float32) + 0.5 - x_off - cam.cx) / cam.f
        v = (np.arange(height, dtype=np.float32) + 0.5 - self.my - cam.cy) / cam.f
        dx = np.broadcast_to(u[None, :], (height, width))
        dy = np.broadcast_to(v[:, None], (height, width))
        st, ct = math.sin(cam.tilt), math.cos(cam.tilt)
        up = -dy * ct + st
        fwd = dy * st + ct
        return dx, up, fwd

    def _row_elevation(self) -> np.ndarray:
        cam = self.cam
        v = np.arange(self.th, dtype=np.float32) + 0.5 - self.my
        return cam.tilt + portable.arctan((cam.cy - v) / cam.f).astype(np.float32)

    # -- sky -----------------------------------------------------------------------------------

    def _build_sky(self, rng: np.random.Generator) -> None:
        bg = self.spec.background
        c = self.c
        elev = np.clip(self._row_elevation(), 0.0, math.pi / 2)
        mix = portable.power((elev / (math.pi / 3)).clip(0, 1), 0.6).astype(np.float32)
        zenith = (1 - bg.overcast) * tone((0.62, 0.30, 0.12), c) + bg.overcast * tone(
            (0.55, 0.55, 0.55), c
        )
        horizon = (1 - bg.overcast) * tone((0.85, 0.78, 0.70), c) + bg.overcast * tone(
            (0.72, 0.72, 0.72), c
        )
        rows = horizon[None, :] * (1 - mix[:, None]) + zenith[None, :] * mix[:, None]
        self.sky = rows[:, None, :].astype(np.float32)  # (th, 1, c)
        if bg.cloud_cover <= 0:
            return
        scale = max(12.0, 0.3 * self.cam.f)
        n = fractal_noise(rng, self.th, self.cw, scale, octaves=5)
        sample = n[:: max(1, self.th // 64), :: max(1, self.cw // 64)]
        thr = float(np.quantile(sample, 1.0 - bg.cloud_cover))
        alpha = _smoothstep(thr - 0.06, thr + 0.12, n)
        shade = 0.98 - 0.35 * _smoothstep(thr + 0.05, thr + 0.4, n)
        shade = shade * (1 - 0.3 * bg.overcast)
        self.clouds = np.stack([alpha, shade], axis=2).astype(np.float32)

    # -- ground and trees ----------------------------------------------------------------------

    def _build_ground(self, rng: np.random.Generator) -> None:
        bg = self.spec.background
        c, th, tw = self.c, self.th, self.tw
        dx, up, fwd = self._rays(th, tw, self.mx)
        below = up < -1e-4
        s = np.where(below, bg.camera_height_m / np.maximum(-up, 1e-4), 0.0)
        gx, gd = s * dx, s * fwd
        fine = fractal_noise(rng, 256, 256, 16, octaves=3)
        coarse = fractal_noise(rng, 256, 256, 48, octaves=3)

        def lookup(tex: np.ndarray, period_m: float) -> np.ndarray:
            mx = ((gx / period_m) % 1.0 * 256).astype(np.float32)
            my = ((gd / period_m) % 1.0 * 256).astype(np.float32)
            return portable.remap_linear(tex, mx, my, wrap=True)

        # Detail fades where its period shrinks below a few pixels, so the far field is smooth.
        dist = np.maximum(gd, 1e-3)
        fade = np.clip(self.cam.f * 2.0 / dist / 6.0, 0.0, 1.0)
        grass = 0.75 + 0.5 * (lookup(fine, 2.0) - 0.5) * fade + 0.5 * (lookup(coarse, 40.0) - 0.5)
        base = tone((0.05, 0.16, 0.09) if bg.variant % 2 == 0 else (0.06, 0.13, 0.16), c)
        col = base[None, None, :] * grass[:, :, None]
        haze = (1 - portable.exp(-dist / 3000.0).astype(np.float32))[:, :, None]
        col = col * (1 - haze) + tone((0.6, 0.6, 0.6), c)[None, None, :] * haze
        alpha = below.astype(np.float32)
        fg = np.concatenate([col, alpha[:, :, None]], axis=2).astype(np.float32)
        self.sway = np.zeros((th, tw), dtype=np.float32)
        self._plant_trees(fg, rng)
        self.fg = fg

    def _plant_trees(self, fg: np.ndarray, rng: np.random.Generator) -> None:
        """A line of trees along the horizon, and now and then a near tree at a side."""
        bg = self.spec.background
        cam, c = self.cam, self.c
        st, ct = math.sin(cam.tilt), math.cos(cam.tilt)
        half_fov = (self.tw / 2) / cam.f
        trees = []
        n_far = int(rng.integers(6, 18))
        for _ in range(n_far):
            d = float(rng.uniform(80, 400))
            trees.append(
                (d, float(rng.uniform(-1.2, 1.2) * half_fov * d), float(rng.uniform(6, 18)))
            )
        if rng.random() < 0.5:
            d = float(rng.uniform(15, 40))
            side = 1 if rng.random() < 0.5 else -1
            trees.append(
                (d, side * float(rng.uniform(0.6, 1.1)) * half_fov * d, float(rng.uniform(8, 15)))
            )
        trees.sort(key=lambda tr: -tr[0])
        greens = [(0.03, 0.09, 0.04), (0.02, 0.07, 0.05), (0.04, 0.10, 0.07), (0.03, 0.06, 0.06)]
        for d, x, height in trees:

            def to_px(xw: float, yw: float, dw: float = d) -> tuple[float, float]:
                # World (right, up above the camera, forward) to texture pixels.
                yc = -yw * ct + dw * st
                zc = yw * st + dw * ct
                return (
                    cam.cx + cam.f * xw / zc + self.mx - 0.5,
                    cam.cy + cam.f * yc / zc + self.my - 0.5,
                )

            ground = -bg.camera_height_m
            bx, by = to_px(x, ground)
            _, ty = to_px(x, ground + height)
            size = by - ty
            if size < 1.5:
                continue
            crown = size * float(rng.uniform(0.25, 0.4))
            # Work in the tree's own patch of the texture.
            x0 = max(int(bx - 2.5 * crown) - 2, 0)
            x1 = min(int(bx + 2.5 * crown) + 3, fg.shape[1])
            y0 = max(int(ty - crown) - 2, 0)
            y1 = min(int(by) + 3, fg.shape[0])
            if x1 <= x0 or y1 <= y0:
                continue
            mask = np.zeros((y1 - y0, x1 - x0), dtype=np.uint8)
            trunk_w = max(1, round(size * 0.05))
            cv2.rectangle(
                mask,
                (round(bx) - x0 - trunk_w // 2, round(ty + size * 0.5) - y0),
                (round(bx) - x0 + trunk_w // 2, round(by) - y0),
                255,
                -1,
            )
            for _ in range(int(rng.integers(5, 10))):
                ox = rng.normal(0, crown * 0.5)
                oy = rng.uniform(0, size * 0.55)
                r = crown * float(rng.uniform(0.5, 0.9))
                centre = (round((bx + ox - x0) * 16), round((ty + oy - y0) * 16))
                cv2.circle(mask, centre, max(1, round(r * 16)), 255, -1, cv2.LINE_AA, shift=4)
            a = (mask.astype(np.float32) / 255.0)[:, :, None]
            colour = tone(greens[int(rng.integers(len(greens)))], c)
            if noise_pixels(y1 - y0, x1 - x0, max(2.0, crown / 3), 2) > MAX_NOISE_PIXELS:
                raise SimulationError(
                    f"focal_px {self.spec.focal_px:g} draws a tree {size:.0f} px tall, whose "
                    f"leaves' texture needs more than {MAX_NOISE_PIXELS:,} pixels: widen the "
                    "view (a smaller focal_px)"
                )
            leaves = 0.8 + 0.4 * fractal_noise(rng, y1 - y0, x1 - x0, max(2.0, crown / 3), 2)
            patch = fg[y0:y1, x0:x1]
            patch[:, :, :c] = patch[:, :, :c] * (1 - a) + colour * leaves[:, :, None] * a
            patch[:, :, c] = np.maximum(patch[:, :, c], a[:, :, 0])
            if self.sway is not None and bg.wind > 0:
                rows = np.arange(y0, y1, dtype=np.float32)[:, None]
                rel = np.clip((by - rows) / size, 0.0, 1.0)
                amp = (bg.wind * 0.03 * size * rel * (a[:, :, 0] > 0)).astype(np.float32)
                np.maximum(self.sway[y0:y1, x0:x1], amp, out=self.sway[y0:y1, x0:x1])

    # -- the hall ------------------------------------------------------------------------------

    def _build_hall(self, rng: np.random.Generator) -> None:
        """A sports hall ray-cast from one end: wooden floor with court lines, padded walls
        with high windows, a backboard, a ceiling with rows of lights."""
        bg = self.spec.background
        c, th, tw = self.c, self.th, self.tw
        length, width, height = bg.room_m
        hc = bg.camera_height_m
        x_cam = (0.15 * width) * ((bg.variant % 3) - 1) / 2
        dx, up, fwd = self._rays(th, tw, self.mx)
        big = np.float32(1e9)
        with np.errstate(divide="ignore", invalid="ignore"):
            s_floor = np.where(up < 0, hc / -up, big)
            s_ceil = np.where(up > 0, (height - hc) / up, big)
            s_back = np.where(fwd > 0, length / fwd, big)
            s_side = np.where(
                dx > 0, (width / 2 - x_cam) / dx, np.where(dx < 0, (-width / 2 - x_cam) / dx, big)
            )
        stack = np.stack([s_floor, s_ceil, s_back, s_side])
        which = np.argmin(stack, axis=0)
        s = np.min(stack, axis=0)
        px, py, pz = x_cam + s * dx, hc + s * up, s * fwd  # hit point: right, height, forward
        img = np.zeros((th, tw, c), dtype=np.float32)

        def paint(mask: np.ndarray, color: tuple[float, float, float]) -> None:
            img[mask] = tone(color, c)

        # Floor: planks along the hall, then court lines.
        floor = which == 0
        plank = np.floor(px / 0.12)
        grain = 0.85 + 0.15 * portable.sin(plank * 12.9898).astype(np.float32) ** 2
        paint(floor, (0.08, 0.20, 0.36))
        img[floor] *= grain[floor][:, None]
        lw = 0.06
        inset = 1.2
        lines = (
            ((np.abs(np.abs(px) - (width / 2 - inset)) < lw) & (pz > inset) & (pz < length - inset))
            | (
                (
                    (np.abs(pz - inset) < lw)
                    | (np.abs(pz - (length - inset)) < lw)
                    | (np.abs(pz - length / 2) < lw)
                )
                & (np.abs(px) < width / 2 - inset)
            )
            | (np.abs(np.hypot(px, pz - length / 2) - 1.8) < lw)
        )
        paint(floor & lines, (0.75, 0.75, 0.72))
        # Walls: coloured padding up to 2 m, paint above, windows high on the back wall.
        wall = (which == 2) | (which == 3)
        pads = [(0.30, 0.12, 0.04), (0.08, 0.25, 0.10), (0.10, 0.08, 0.35)]
        paint(wall, (0.45, 0.50, 0.52))
        paint(wall & (py < 2.0), pads[bg.variant % 3])
        back = which == 2
        win = back & (py > height * 0.6) & (py < height * 0.85) & ((px % 3.0) < 2.0)
        paint(win, (0.95, 0.92, 0.88))
        board = back & (np.abs(px) < 0.9) & (py > 2.9) & (py < 3.95)
        paint(board, (0.85, 0.85, 0.85))
        rim = board & ((np.abs(px) > 0.8) | (py < 3.0) | (py > 3.85))
        paint(rim, (0.05, 0.25, 0.6))
        # Ceiling with rows of light panels.
        ceil = which == 1
        paint(ceil, (0.22, 0.22, 0.22))
        lights = ceil & ((px % 4.0) < 1.2) & ((pz % 4.0) < 0.4)
        paint(lights, (1.0, 1.0, 1.0))
        # A little texture everywhere, and darker far corners.
        img *= (0.92 + 0.16 * fractal_noise(rng, th, tw, 24, octaves=3))[:, :, None]
        img *= np.clip(1.1 - 0.25 * (s / length), 0.6, 1.1)[:, :, None]
        alpha = np.ones((th, tw, 1), dtype=np.float32)
        self.fg = np.concatenate([img, alpha], axis=2)

    # -- per frame -----------------------------------------------------------------------------

    def _crop(self, tex: np.ndarray, ox: float, oy: float) -> np.ndarray:
        w, h = self.spec.width, self.spec.height
        if ox == round(ox) and oy == round(oy):
            i, j = round(ox), round(oy)
            return np.array(tex[j : j + h, i : i + w])
        return portable.shift_linear(tex, ox, oy, w, h).reshape(h, w, -1)

    def frame(self, t: float, shift: np.ndarray) -> np.ndarray:
        """The background at time ``t`` (seconds) with the pan's image ``shift``: ``(h, w, c)``
        linear float32."""
        bg = self.spec.background
        swaying = self.sway is not None and bg.wind > 0 and np.any(self.sway)
        drifting = self.clouds is not None and self.cloud_px_s != 0
        if self.static and not swaying and not drifting and self._cached is not None:
            return self._cached.copy()
        ox, oy = self.mx - float(shift[0]), self.my - float(shift[1])
        w, h, c = self.spec.width, self.spec.height, self.c
        out: np.ndarray
        if self.sky is not None:
            ys = np.arange(h, dtype=np.float64) + oy
            grid = np.arange(self.th, dtype=np.float64)
            rows = np.stack([np.interp(ys, grid, self.sky[:, 0, k]) for k in range(c)], axis=1)
            out = np.broadcast_to(rows[:, None, :].astype(np.float32), (h, w, c)).copy()
            if self.clouds is not None:
                cl = self._crop(self.clouds, ox + self.cloud_x0 - self.cloud_px_s * t, oy)
                a = cl[:, :, :1]
                out = out * (1 - a) + cl[:, :, 1:2] * a
        else:
            out = np.zeros((h, w, c), dtype=np.float32)
        if self.fg is not None:
            if swaying and self.sway is not None:
                fg = self._crop(self.fg, ox, oy)
                amp = self._crop(self.sway[:, :, None], ox, oy)[:, :, 0]
                j, i = np.nonzero(amp)
                # The swaying pixels move off the pan's crop, each by its own amount.
                x = i.astype(np.float32) + ox
                dx = amp[j, i] * portable.sin(2 * np.pi * 0.6 * t + 0.05 * x).astype(np.float32)
                y = j.astype(np.float32) + oy
                fg[j, i] = portable.remap_linear(self.fg, x + dx, y, wrap=False)
            else:
                fg = self._crop(self.fg, ox, oy)
            a = fg[:, :, c:]
            out = out * (1 - a) + fg[:, :, :c] * a
        out = out.astype(np.float32, copy=False)
        if self.static and not swaying and not drifting:
            self._cached = out.copy()
        return out
