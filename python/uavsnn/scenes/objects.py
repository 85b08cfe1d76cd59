"""What each object looks like at an instant: 3-D parts in its body frame, in metres.

Every model is a short list of :class:`Part`: a polygon (a flat face: a wing, a rotor disc, a
blade) or a cloud of points whose convex hull is drawn (a volume: a body, a fuselage). Moving
parts — rotors, wings, a ball's panel, a leaf's tumble — are rebuilt at each instant from the
object's ``rate_hz`` and ``phase``. Body axes: x forward, y up, z to the right. Sizes follow the
real things (DJI Phantom 290×290×195 mm, DJI Tello 98×92.5×41 mm), scaled by ``size_m``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from uavsnn.scenes import portable
from uavsnn.scenes.camera import attitude
from uavsnn.scenes.spec import ObjectSpec

__all__ = ["Color", "Part", "model_for", "shade"]


Color = tuple[float, float, float]


def shade(color: Color | tuple[float, ...], k: float, offset: float = 0.0) -> Color:
    """``offset + k·color``, per channel."""
    b, g, r = (float(c) for c in color)
    return (offset + k * b, offset + k * g, offset + k * r)


class Part(NamedTuple):
    """One drawn piece: ``points`` ``(k, 3)`` in the body frame (metres), linear BGR ``color``,
    opacity ``alpha`` (0: not drawn, but part of the object's box), and whether to fill the
    convex ``hull`` of the projected points or the polygon as given."""

    points: np.ndarray
    color: Color
    alpha: float = 1.0
    hull: bool = False


def _ring(n: int, phase: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    a = phase + np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    return portable.cos(a), portable.sin(a)


def ellipsoid(
    center: tuple[float, float, float], radii: tuple[float, float, float], n: int = 10
) -> np.ndarray:
    """Points on an ellipsoid's surface; their hull is the ellipsoid's outline from any side."""
    c, s = _ring(n)
    pts = []
    for lat in (-1.2, -0.6, 0.0, 0.6, 1.2):
        r = math.cos(lat)
        pts.append(np.stack([c * r, np.full(n, math.sin(lat)), s * r], axis=1))
    pts.append(np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]))
    return np.concatenate(pts) * np.asarray(radii) + np.asarray(center)


def disc(
    center: tuple[float, float, float],
    radius: float,
    plane: str = "xz",
    n: int = 16,
    squash: float = 1.0,
) -> np.ndarray:
    """A flat ellipse polygon of ``radius`` (and ``radius·squash`` across) in the ``"xz"``
    (horizontal) or ``"xy"`` (vertical) plane."""
    c, s = _ring(n)
    zero = np.zeros(n)
    if plane == "xz":
        pts = np.stack([c * radius, zero, s * radius * squash], axis=1)
    else:
        pts = np.stack([c * radius, s * radius * squash, zero], axis=1)
    return pts + np.asarray(center)


def stick(p0: tuple[float, float, float], p1: tuple[float, float, float], r: float) -> np.ndarray:
    """Points whose hull is a rod of radius ``r`` from ``p0`` to ``p1``."""
    offsets = np.array(
        [[0, r, 0], [0, -r, 0], [0, 0, r], [0, 0, -r], [r, 0, 0], [-r, 0, 0]], dtype=np.float64
    )
    return np.concatenate([np.asarray(p0) + offsets, np.asarray(p1) + offsets])


def blade(
    center: tuple[float, float, float], angle: float, length: float, width: float, root: float = 0.0
) -> np.ndarray:
    """A thin rectangle in the horizontal plane from ``root`` to ``length`` along ``angle``."""
    d = np.array([math.cos(angle), 0.0, math.sin(angle)])
    n = np.array([-math.sin(angle), 0.0, math.cos(angle)]) * (width / 2)
    c = np.asarray(center)
    a, b = c + d * root, c + d * length
    return np.stack([a - n, b - n * 0.6, b + n * 0.6, a + n])


#: A propeller blade's width at its root and its tip, as fractions of the rotor's radius
#: (a 9.4-inch Phantom propeller: about 25 mm chord at 40 % of its 120 mm radius).
BLADE_ROOT, BLADE_TIP = 0.16, 0.096
#: The spinning disc a rotor's blades sweep: colour and opacity (a faint blur in any one frame).
DISC_COLOR, DISC_ALPHA = (0.25, 0.25, 0.25), 0.22
#: Blade colour and opacity.
BLADE_COLOR, BLADE_ALPHA = (0.18, 0.18, 0.18), 0.9


def rotor_parts(
    hub: np.ndarray, radius: float, angle: float, blades: int = 2, *, disc: bool = True
) -> list[Part]:
    """A rotor in the horizontal plane at ``hub`` (body frame): its disc (the blur a video
    camera's exposure makes; ``disc=False`` for an event camera, which sees the blades at each
    instant), then ``blades`` blades at ``angle`` (radians) and evenly spaced from it."""
    a = angle + 2 * np.pi * np.arange(blades) / blades
    ca, sa = portable.cos(a), portable.sin(a)
    d = np.stack([ca, np.zeros(blades), sa], axis=1)
    nrm = np.stack([-sa, np.zeros(blades), ca], axis=1) * (radius * BLADE_ROOT / 2)
    tip = hub + d * radius
    tip_w = BLADE_TIP / BLADE_ROOT
    quads = np.stack([hub - nrm, tip - tip_w * nrm, tip + tip_w * nrm, hub + nrm], axis=1)
    out = [Part(q, BLADE_COLOR, BLADE_ALPHA) for q in quads]
    if disc:
        out.insert(0, Part(_disc(tuple(hub), radius, n=20), DISC_COLOR, DISC_ALPHA))
    return out


class Model:
    """Base of the object models: ``parts(t, velocity) -> (parts, attitude)``."""

    #: The size ``size_m`` that the model's coordinates are drawn at.
    nominal = 1.0
    #: Drawn facing the camera whatever the line of sight (a sphere looks round from anywhere).
    faces_camera = False

    def fast_hz(self) -> float:
        """The highest rate at which the object's look repeats, in Hz: a rotor's blade pass,
        a wing beat. Sub-frame samples of its patch follow it (0: nothing moves fast)."""
        return float(self.obj.rate_hz)

    def __init__(self, obj: ObjectSpec, *, event_camera: bool = False) -> None:
        self.obj = obj
        #: Seen by an event camera: no blur discs for rotors (a video frame's exposure smears
        #: the blades into a disc; an event camera sees the blades at every instant, and a
        #: disc drawn over them only darkens the sky they pass against).
        self.event_camera = event_camera
        self.k = obj.size_m / self.nominal
        self.color = shade(obj.color, 1.0)
        #: Parts that never change, scaled once: ``id(part) -> (part, scaled part)``.
        self._scaled: dict[int, tuple[Part, Part]] = {}

    def _fixed(self, parts: list[Part]) -> list[Part]:
        """Mark ``parts`` (built once, returned by every ``_parts`` call) as fixed: scaled to
        ``size_m`` once rather than at each instant. Returns them."""
        for p in parts:
            self._scaled[id(p)] = (p, p._replace(points=p.points * self.k))
        return parts

    def heading_of(self, velocity: np.ndarray) -> float:
        """Face the direction of travel when moving, else the spec's heading."""
        vx, vz = float(velocity[0]), float(velocity[2])
        if math.hypot(vx, vz) > 0.3:
            return math.atan2(vz, vx)
        return math.radians(self.obj.heading_deg)

    def parts(self, t: float, velocity: np.ndarray) -> tuple[list[Part], np.ndarray]:
        """The parts at time ``t`` (seconds), scaled to ``size_m``, and the body attitude."""
        parts, rot = self._parts(t, velocity)
        k, scaled = self.k, self._scaled
        out = []
        for p in parts:
            # The cache holds the part itself, so a hit on its id is the same part.
            hit = scaled.get(id(p))
            out.append(
                hit[1] if hit is not None and hit[0] is p else p._replace(points=p.points * k)
            )
        return out, rot

    def _parts(self, t: float, velocity: np.ndarray) -> tuple[list[Part], np.ndarray]:
        raise NotImplementedError


class Quadcopter(Model):
    """A quadcopter: body, four arms with motors, four spinning two-blade rotors; the Phantom
    variant stands on a landing gear. It banks into its motion as real multirotors do."""

    def __init__(self, obj: ObjectSpec, *, event_camera: bool = False) -> None:
        self.phantom = obj.kind == "phantom"
        self.nominal = 0.29 if self.phantom else 0.098
        super().__init__(obj, event_camera=event_camera)
        grey, light, dark = (0.6, 0.6, 0.6), (0.72, 0.72, 0.72), (0.12, 0.12, 0.12)
        if self.phantom:
            # Motors at (±a, ±a): DJI's 350 mm diagonal; 9.4-inch propellers.
            a, self.prop_r, y = 0.124, 0.12, 0.045
            body = np.concatenate(
                [ellipsoid((0, 0, 0), (0.10, 0.045, 0.075)), disc((0, 0.035, 0), 0.06)]
            )
            motor_r, arm_r = 0.016, 0.012
            static = [
                Part(
                    stick((sx * 0.06, -0.03, sz * 0.07), (sx * 0.085, -0.15, sz * 0.085), 0.006),
                    light,
                    hull=True,
                )
                for sx in (-1, 1)
                for sz in (-1, 1)
            ] + [
                Part(
                    stick((-0.10, -0.15, sz * 0.085), (0.10, -0.15, sz * 0.085), 0.007),
                    light,
                    hull=True,
                )
                for sz in (-1, 1)
            ]
        else:
            a, self.prop_r, y = 0.028, 0.021, 0.014
            body = np.concatenate(
                [ellipsoid((0, 0, 0), (0.030, 0.013, 0.022)), disc((0, 0.012, 0), 0.02)]
            )
            motor_r, arm_r = 0.006, 0.004
            static = []
        self.hubs = np.array(
            [[sx * a, y + 0.002, sz * a] for sx, sz in ((1, 1), (-1, 1), (-1, -1), (1, -1))]
        )
        for hub in self.hubs:
            m = (hub[0], 0.0, hub[2])
            # Arms start inside the body's shell, so they do not cross it.
            static.append(Part(stick((0.45 * m[0], 0.0, 0.45 * m[2]), m, arm_r), grey, hull=True))
            static.append(
                Part(
                    np.concatenate(
                        [
                            disc((m[0], -0.004, m[2]), motor_r, n=8),
                            disc((m[0], y, m[2]), motor_r, n=8),
                        ]
                    ),
                    dark,
                    hull=True,
                )
            )
            # For an event camera the disc is not drawn (alpha 0) but still bounds the box.
            alpha = 0.0 if event_camera else DISC_ALPHA
            static.append(Part(disc(tuple(hub), self.prop_r, n=20), DISC_COLOR, alpha))
        static.insert(0, Part(body, self.color, hull=True))
        self.static = static
        self.static_scaled = [p._replace(points=p.points * self.k) for p in static]
        self.blade_hubs = np.repeat(self.hubs, 2, axis=0)
        self.heading = attitude(math.radians(obj.heading_deg))
        self._bank: tuple[tuple[float, float] | None, np.ndarray] = (None, self.heading)
        self.spin = 2 * math.pi * obj.rate_hz
        # Neighbouring rotors turn in opposite directions; two blades each.
        self.turn = np.repeat([1.0, -1.0, 1.0, -1.0], 2)
        self.offset = np.repeat(np.arange(4.0), 2) + np.tile([0.0, math.pi], 4) + obj.phase

    def fast_hz(self) -> float:
        """Two blades per rotor: the blade pass is twice the rotation rate."""
        return 2.0 * float(self.obj.rate_hz)

    def parts(self, t: float, velocity: np.ndarray) -> tuple[list[Part], np.ndarray]:
        """As :meth:`Model.parts`: the fixed parts scaled once, the eight blades built and
        scaled as one array."""
        angle = self.turn * self.spin * t + self.offset  # (8,)
        ca, sa = portable.cos(angle), portable.sin(angle)
        d = np.stack([ca, np.zeros(8), sa], axis=1)
        n = np.stack([-sa, np.zeros(8), ca], axis=1) * (self.prop_r * BLADE_ROOT / 2)
        hub = self.blade_hubs
        tip = hub + d * self.prop_r
        tip_w = BLADE_TIP / BLADE_ROOT
        quads = np.stack([hub - n, tip - tip_w * n, tip + tip_w * n, hub + n], axis=1)  # (8,4,3)
        blades = [Part(q, BLADE_COLOR, BLADE_ALPHA) for q in quads * self.k]
        # Bank into the motion: about 2.5° per m/s, at most 25°.
        vx, vz = float(velocity[0]), float(velocity[2])
        if self._bank[0] != (vx, vz):
            tilt_x = math.radians(max(-25.0, min(25.0, -2.5 * vx)))
            tilt_z = math.radians(max(-25.0, min(25.0, 2.5 * vz)))
            # The frame and its sub-frame samples share a velocity: kept for the next call.
            self._bank = ((vx, vz), portable.matmul(attitude(0.0, tilt_x, tilt_z), self.heading))
        return self.static_scaled + blades, self._bank[1]


class Bird(Model):
    """A bird: body, head, tail and two-segment wings beating at ``rate_hz``; variant 1 (gull
    like) glides between bursts of beats."""

    def __init__(self, obj: ObjectSpec, *, event_camera: bool = False) -> None:
        super().__init__(obj, event_camera=event_camera)
        col = self.color
        body = Part(ellipsoid((0.0, 0.0, 0.0), (0.21, 0.06, 0.065)), col, hull=True)
        head = Part(ellipsoid((0.22, 0.03, 0.0), (0.055, 0.045, 0.04), n=8), col, hull=True)
        beak = Part(
            np.array([[0.27, 0.03, -0.01], [0.32, 0.02, 0.0], [0.27, 0.02, 0.01]]), (0.1, 0.35, 0.6)
        )
        tail = Part(
            np.array(
                [[-0.17, 0.0, -0.03], [-0.32, 0.0, -0.07], [-0.32, 0.0, 0.07], [-0.17, 0.0, 0.03]]
            ),
            shade(col, 0.6),
        )
        self.fixed = self._fixed([tail, body, head, beak])

    def _parts(self, t: float, velocity: np.ndarray) -> tuple[list[Part], np.ndarray]:
        obj = self.obj
        col = self.color
        dark = shade(col, 0.6)
        phase = 2 * math.pi * obj.rate_hz * t + obj.phase
        beat = math.sin(phase)
        if obj.variant == 1:
            # Bursts of beats, then glides: a slow gate in [0, 1].
            gate = 0.5 + 0.5 * math.tanh(4 * math.sin(2 * math.pi * 0.4 * t + obj.phase))
            beat *= gate
        up1 = math.radians(15 + 45 * beat)
        up2 = up1 + math.radians(20 * beat)
        parts = list(self.fixed)
        for side in (-1.0, 1.0):
            r1, r2 = 0.2, 0.25  # inner and outer wing: span = 2·(0.05 + r1 + r2) = 1
            root = np.array([0.0, 0.02, side * 0.05])
            elbow = root + np.array([0.0, r1 * math.sin(up1), side * r1 * math.cos(up1)])
            tip = elbow + np.array([-0.1, r2 * math.sin(up2), side * r2 * math.cos(up2)])
            chord = np.array([1.0, 0.0, 0.0])
            wing = np.stack(
                [
                    root + 0.08 * chord,
                    elbow + 0.06 * chord,
                    tip,
                    elbow - 0.12 * chord,
                    root - 0.12 * chord,
                ]
            )
            parts.append(Part(wing, dark if side > 0 else col))
        return parts, attitude(self.heading_of(velocity))


class Aircraft(Model):
    """A fixed-wing airliner or light aircraft: fuselage, swept wings, tailplane, fin,
    engines."""

    def __init__(self, obj: ObjectSpec, *, event_camera: bool = False) -> None:
        super().__init__(obj, event_camera=event_camera)
        self.fixed = self._fixed(self._build())

    def _parts(self, t: float, velocity: np.ndarray) -> tuple[list[Part], np.ndarray]:
        return list(self.fixed), attitude(self.heading_of(velocity))

    def _build(self) -> list[Part]:
        col = self.color
        grey = (0.55, 0.55, 0.58)
        sweep = 0.12 if self.obj.variant == 0 else 0.0
        fus = Part(
            np.concatenate(
                [
                    ellipsoid((0.0, 0.0, 0.0), (0.5, 0.055, 0.055)),
                    ellipsoid((0.3, 0.0, 0.0), (0.2, 0.06, 0.06)),
                ]
            ),
            col,
            hull=True,
        )
        parts = [fus]
        for side in (-1.0, 1.0):
            wing = np.array(
                [
                    [0.08, -0.02, side * 0.05],
                    [-0.1, -0.02, side * 0.05],
                    [-0.1 - sweep - 0.05, -0.0, side * 0.5],
                    [-sweep - 0.07, 0.0, side * 0.5],
                ]
            )
            tailplane = np.array(
                [
                    [-0.38, 0.02, 0.0],
                    [-0.48, 0.02, 0.0],
                    [-0.52, 0.03, side * 0.17],
                    [-0.46, 0.03, side * 0.17],
                ]
            )
            parts += [Part(wing, grey), Part(tailplane, grey)]
            if self.obj.variant == 0:
                parts.append(
                    Part(
                        ellipsoid((-0.02, -0.06, side * 0.17), (0.07, 0.025, 0.025), n=8),
                        (0.45, 0.45, 0.45),
                        hull=True,
                    )
                )
        fin = np.array(
            [[-0.36, 0.04, 0.0], [-0.5, 0.04, 0.0], [-0.53, 0.19, 0.0], [-0.46, 0.19, 0.0]]
        )
        parts.append(Part(fin, shade(col, 0.8)))
        return parts


class Helicopter(Model):
    """A helicopter: cabin, tail boom, fin, skids, a main rotor of 2-5 blades turning at
    ``rate_hz`` and a fast tail rotor."""

    def fast_hz(self) -> float:
        """The tail rotor (two blade ends, five times the main rotor's rate) or the main
        rotor's blade pass, whichever is faster."""
        n_blades = 2 + self.obj.variant % 4
        return float(self.obj.rate_hz) * max(10.0, n_blades)

    def __init__(self, obj: ObjectSpec, *, event_camera: bool = False) -> None:
        super().__init__(obj, event_camera=event_camera)
        col = self.color
        dark = (0.15, 0.15, 0.15)
        parts = [
            Part(stick((-0.05, 0.03, 0.0), (-0.45, 0.05, 0.0), 0.025), col, hull=True),
            Part(
                np.array(
                    [[-0.43, 0.05, 0.0], [-0.5, 0.05, 0.0], [-0.52, 0.16, 0.0], [-0.47, 0.16, 0.0]]
                ),
                col,
            ),
            Part(ellipsoid((0.12, 0.0, 0.0), (0.22, 0.11, 0.09)), col, hull=True),
            Part(
                ellipsoid((0.22, 0.02, 0.0), (0.1, 0.07, 0.07), n=8), (0.25, 0.22, 0.2), hull=True
            ),
            Part(stick((0.0, -0.15, -0.07), (0.3, -0.15, -0.07), 0.008), dark, hull=True),
            Part(stick((0.0, -0.15, 0.07), (0.3, -0.15, 0.07), 0.008), dark, hull=True),
            Part(stick((0.1, -0.1, 0.0), (0.1, 0.14, 0.0), 0.012), dark, hull=True),
        ]
        hub = (0.1, 0.15, 0.0)
        parts.append(
            Part(disc(hub, 0.45, n=24), (0.3, 0.3, 0.3), 0.0 if self.event_camera else 0.12)
        )
        self.fixed = self._fixed(parts)

    def _parts(self, t: float, velocity: np.ndarray) -> tuple[list[Part], np.ndarray]:
        dark = (0.15, 0.15, 0.15)
        parts = list(self.fixed)
        hub = (0.1, 0.15, 0.0)
        n_blades = 2 + self.obj.variant % 4
        spin = 2 * math.pi * self.obj.rate_hz * t + self.obj.phase
        for i in range(n_blades):
            a = spin + 2 * math.pi * i / n_blades
            parts.append(Part(blade(hub, a, 0.45, 0.025), dark, 0.95))
        tail_hub = np.array([-0.49, 0.08, 0.03])
        if not self.event_camera:
            parts.append(Part(disc(tuple(tail_hub), 0.07, plane="xy", n=12), (0.3, 0.3, 0.3), 0.15))
        ta = 5 * spin
        d = np.array([math.cos(ta), math.sin(ta), 0.0]) * 0.07
        nrm = np.array([-math.sin(ta), math.cos(ta), 0.0]) * 0.006
        parts.append(
            Part(
                np.stack(
                    [tail_hub - d - nrm, tail_hub + d - nrm, tail_hub + d + nrm, tail_hub - d + nrm]
                ),
                dark,
                0.9,
            )
        )
        return parts, attitude(self.heading_of(velocity))


class Ball(Model):
    """A ball with one spinning coloured panel that comes into and out of view."""

    faces_camera = True

    def __init__(self, obj: ObjectSpec, *, event_camera: bool = False) -> None:
        super().__init__(obj, event_camera=event_camera)
        self.fixed = self._fixed([Part(disc((0.0, 0.0, 0.0), 0.5, plane="xy", n=24), self.color)])

    def _parts(self, t: float, velocity: np.ndarray) -> tuple[list[Part], np.ndarray]:
        col = self.color
        parts = list(self.fixed)
        spin = 2 * math.pi * self.obj.rate_hz * t + self.obj.phase
        # The panel: a cap of 40° around a direction turning about a tilted axis.
        d = np.array([math.cos(spin), 0.35, math.sin(spin)])
        d /= portable.norm(d)
        if d[2] < -0.2:  # facing the camera (the viewer looks along +z)
            u = np.cross(d, [0.0, 1.0, 0.0])
            u /= portable.norm(u)
            v = np.cross(d, u)
            c, s = _ring(14)
            ring = 0.5 * (math.cos(0.7) * d + math.sin(0.7) * (c[:, None] * u + s[:, None] * v))
            ring[:, 2] = 0.0  # flattened onto the disc facing the camera
            panel = shade(col, -0.8, 1.0)
            parts.append(Part(ring, panel, 0.9))
        return parts, np.eye(3)


class Insect(Model):
    """A flying insect: a slim body and two translucent wings beating at ``rate_hz``."""

    def __init__(self, obj: ObjectSpec, *, event_camera: bool = False) -> None:
        super().__init__(obj, event_camera=event_camera)
        body = ellipsoid((0.0, 0.0, 0.0), (0.35, 0.07, 0.07), n=8)
        self.fixed = self._fixed([Part(body, self.color, hull=True)])

    def _parts(self, t: float, velocity: np.ndarray) -> tuple[list[Part], np.ndarray]:
        beat = math.sin(2 * math.pi * self.obj.rate_hz * t + self.obj.phase)
        up = math.radians(10 + 60 * beat)
        parts = list(self.fixed)
        for side in (-1.0, 1.0):
            c, s = _ring(10)
            r = 0.45
            pts = np.stack([0.12 * c, np.zeros(10), r * 0.5 * (1 + s)], axis=1)
            # Swing the wing up about the body axis.
            rot = np.array(
                [[1, 0, 0], [0, math.cos(up), math.sin(up)], [0, -math.sin(up), math.cos(up)]]
            )
            pts[:, 2] *= side
            if side < 0:
                rot = rot.T
            wing = portable.matmul(pts, rot.T) + np.array([0.02, 0.03, 0.0])
            parts.append(Part(wing, (0.7, 0.7, 0.7), 0.45))
        return parts, attitude(self.heading_of(velocity))


class Leaf(Model):
    """A leaf with its stalk, tumbling about a tilted axis at ``rate_hz`` as it falls."""

    def __init__(self, obj: ObjectSpec, *, event_camera: bool = False) -> None:
        super().__init__(obj, event_camera=event_camera)
        x = np.linspace(-0.5, 0.5, 9)
        half = 0.22 * np.sqrt(np.clip(1 - (2 * x) ** 2, 0, 1)) * (1.0 - 0.3 * x)
        outline = np.concatenate(
            [
                np.stack([x, np.zeros(9), half], axis=1),
                np.stack([x[::-1], np.zeros(9), -half[::-1]], axis=1),
            ]
        )
        stalk = np.array(
            [[-0.5, 0.0, -0.01], [-0.65, 0.0, -0.01], [-0.65, 0.0, 0.01], [-0.5, 0.0, 0.01]]
        )
        self.fixed = self._fixed([Part(outline, self.color), Part(stalk, shade(self.color, 0.7))])

    def _parts(self, t: float, velocity: np.ndarray) -> tuple[list[Part], np.ndarray]:
        a = 2 * math.pi * self.obj.rate_hz * t + self.obj.phase
        rot = attitude(0.4 * a + self.obj.phase, 1.3 * math.sin(a), a)
        return list(self.fixed), rot


_MODELS: dict[str, type[Model]] = {
    "phantom": Quadcopter,
    "tello": Quadcopter,
    "bird": Bird,
    "aircraft": Aircraft,
    "helicopter": Helicopter,
    "ball": Ball,
    "insect": Insect,
    "leaf": Leaf,
}


def model_for(obj: ObjectSpec, *, event_camera: bool = False) -> Model:
    """The model that draws ``obj`` (for an event camera: without rotor blur discs)."""
    return _MODELS[obj.kind](obj, event_camera=event_camera)


_disc = disc
