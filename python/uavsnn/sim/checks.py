"""Checks of the simulators.

- Validation of simulation parameters: each failure is a :class:`~uavsnn.ParameterError` that
  names the parameter and the value.
- Event-rate spectra (:func:`event_rate_spectrum`, :func:`dominant_frequency`): what periodic
  motion (a rotor's blade pass, a wing beat, a spinner) puts into the events of a box — shared
  by the emulator's checks against physics and real recordings, and by identification work.
- :func:`rotor_events`: a rotor alone, face-on, rendered and emulated, with or without
  sub-frame samples.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from uavsnn._files import write_image
from uavsnn._validate import MAX_TIME_US, check_int, check_real
from uavsnn.errors import EventError, ParameterError

__all__ = [
    "MAX_ROTATION_GRID",
    "MAX_SPECTRUM_POINTS",
    "check_choice",
    "check_int",
    "check_real",
    "check_seed",
    "check_size",
    "dominant_frequency",
    "estimate_rotation",
    "event_rate_spectrum",
    "pixel_rate_spectrum",
    "plot_spectra",
    "rotor_events",
]


#: The most points a spectrum's time series may have once zero-padded (its bins times ``pad``;
#: 2^22): the rate spectra refuse a longer one before counting a bin (a span of 10^12 µs in
#: bins of 50 µs asked for 149 GiB). The project's longest is under 40,000 points (a pulse
#: train of 0.91 s in bins of 100 µs, padded 4 times, in tests/test_rotor.py; the benches' are
#: at most 24,000), so a spectrum may still span 100 s in bins of 100 µs padded 4 times.
MAX_SPECTRUM_POINTS = 1 << 22
#: The most rotation rates :func:`estimate_rotation`'s coarse search tries (each scored over
#: up to 40,000 events): ``2 · max_hz / (50 · step_hz)``. Its defaults try 801, the project's
#: only use (benches/python/spinner_compare.py) too; max_hz = 10^9 at step_hz = 10^-3 asked
#: for 298 GiB.
MAX_ROTATION_GRID = 100_000
#: The most matrix cells (channels times padded points) one chunk of
#: :func:`pixel_rate_spectrum` transforms at a time (2^24: about 130 MB of spectra): its
#: ``chunk`` channels are fewer when the series are long.
_CHUNK_POINTS = 1 << 24


def check_choice(name: str, value: Any, choices: tuple[str, ...]) -> str:
    """One of ``choices``."""
    if value not in choices:
        options = ", ".join(repr(c) for c in choices)
        raise ParameterError(f"{name} must be one of {options}, got {value!r}")
    return str(value)


def check_seed(seed: Any) -> int:
    """A seed in ``[0, 2**64)``."""
    return check_int("seed", seed, low=0, high=2**64 - 1)


def check_size(size: Any, name: str = "size") -> tuple[int, int]:
    """A ``(width, height)`` pair of positive integers below 65536; also parses ``"240x180"``."""
    if isinstance(size, str):
        parts = size.lower().split("x")
        try:
            size = tuple(int(p) for p in parts)
        except ValueError as exc:
            raise ParameterError(f"{name} must look like 240x180, got {size!r}") from exc
    try:
        width, height = size
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be (width, height), got {size!r}") from exc
    return (
        check_int(f"{name} width", width, low=1, high=65535),
        check_int(f"{name} height", height, low=1, high=65535),
    )


def event_rate_spectrum(
    t_us: Any,
    *,
    bin_us: int = 50,
    start_us: int | None = None,
    end_us: int | None = None,
    pad: int = 8,
    relative: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """The power spectrum of an event rate: events counted in bins of ``bin_us``, the mean
    taken out, a Hann window, zero-padded ``pad`` times. Returns ``(freqs_hz, power)``, the
    power normalised to its largest value (all zeros when there is no variation), or with
    ``relative`` the power of the rate's relative modulation (counts over their mean, minus
    one; per bin, Hann-weighted), comparable between recordings of different rates.

    ``start_us``/``end_us`` bound the time span (default: the events' own span).

    Raises:
        ParameterError: times that are not integer microseconds in ``[0, 2^62]``, a bad
            ``bin_us``, ``pad``, ``start_us`` or ``end_us``, or a span whose bins, padded, are
            more than :data:`MAX_SPECTRUM_POINTS`.
    """
    t = _times("t_us", t_us)
    bin_us = check_int("bin_us", bin_us, low=1, high=10**9)
    pad = check_int("pad", pad, low=1, high=64)
    lo, n = _span(t, bin_us, pad, start_us, end_us)
    counts = np.bincount(((t[(t >= lo) & (t < lo + n * bin_us)] - lo) // bin_us), minlength=n)
    x = counts[:n].astype(np.float64)
    mean = x.mean()
    x -= mean
    win = np.hanning(n)
    x *= win
    spec = np.abs(np.fft.rfft(x, n * pad)) ** 2
    freqs = np.fft.rfftfreq(n * pad, bin_us * 1e-6)
    if relative:
        return freqs, spec / (mean * mean * float((win * win).sum())) if mean > 0 else spec
    top = spec.max()
    return freqs, spec / top if top > 0 else spec


def pixel_rate_spectrum(
    events: np.ndarray,
    *,
    bin_us: int = 100,
    start_us: int | None = None,
    end_us: int | None = None,
    pad: int = 4,
    box: tuple[float, float, float, float] | None = None,
    min_events: int = 2,
    chunk: int = 256,
) -> tuple[np.ndarray, np.ndarray]:
    """The mean over pixels and polarities of each pixel's ON and OFF event-rate power spectra
    (binned as :func:`event_rate_spectrum`, each channel's mean taken out, Hann window), for
    the pixels in
    ``box`` (``x0, y0, x1, y1``, continuous pixel coordinates; default all) with at least
    ``min_events`` events. Returns ``(freqs_hz, power)`` normalised to its largest value.

    Per pixel, not summed: a rotor's blades sweep the same area at every instant, so the box's
    total event rate hardly varies, while each pixel sees a blade pass at the blade-pass
    frequency (a per-pixel frequency detector's view, as FrequencyCam's).

    Raises:
        EventError: ``events`` without the fields ``t``, ``x``, ``y`` and ``p``.
        ParameterError: as :func:`event_rate_spectrum`, a ``box`` that is not four finite
            numbers with ``x1 > x0`` and ``y1 > y0``, or a ``min_events`` or ``chunk`` below 1.
    """
    ev = _events(events, ("t", "x", "y", "p"))
    bin_us = check_int("bin_us", bin_us, low=1, high=10**9)
    pad = check_int("pad", pad, low=1, high=64)
    min_events = check_int("min_events", min_events, low=1)
    chunk = check_int("chunk", chunk, low=1)
    if box is not None:
        x0, y0, x1, y1 = _box(box)
        keep = (
            (ev["x"] + 0.5 >= x0)
            & (ev["x"] + 0.5 < x1)
            & (ev["y"] + 0.5 >= y0)
            & (ev["y"] + 0.5 < y1)
        )
        ev = ev[keep]
    t = _times("events' t", ev["t"])
    lo, n = _span(t, bin_us, pad, start_us, end_us)
    # Fewer channels at a time when the series are long: each chunk's spectra stay bounded.
    chunk = min(chunk, max(1, _CHUNK_POINTS // (n * pad)))
    freqs = np.fft.rfftfreq(n * pad, bin_us * 1e-6)
    total = np.zeros(len(freqs))
    inside = (t >= lo) & (t < lo + n * bin_us)
    ev, t = ev[inside], t[inside]
    # One channel per pixel and polarity: a blade passing makes one OFF burst (it comes) and
    # one ON burst (it goes), so each channel beats once per passage, while the pixel's total
    # beats twice when the blade is thin.
    pix = (ev["y"].astype(np.int64) * 65536 + ev["x"].astype(np.int64)) * 2 + ev["p"]
    ids, inverse, counts = np.unique(pix, return_inverse=True, return_counts=True)
    use = np.flatnonzero(counts >= min_events)
    if not len(use):
        return freqs, total
    row_of = np.full(len(ids), -1, dtype=np.int64)
    row_of[use] = np.arange(len(use))
    rows = row_of[inverse]
    ok = rows >= 0
    rows, bins = rows[ok], (t[ok] - lo) // bin_us
    window = np.hanning(n)
    for c0 in range(0, len(use), chunk):
        sel = (rows >= c0) & (rows < c0 + chunk)
        m = min(chunk, len(use) - c0)
        x = np.zeros((m, n))
        np.add.at(x, (rows[sel] - c0, bins[sel]), 1.0)
        x -= x.mean(axis=1, keepdims=True)
        x *= window
        total += (np.abs(np.fft.rfft(x, n * pad, axis=1)) ** 2).sum(axis=0)
    top = total.max()
    return freqs, total / top if top > 0 else total


def _times(name: str, t_us: Any) -> np.ndarray:
    """Event times: a 1-D array of integers in ``[0, MAX_TIME_US]``, as ``int64``."""
    t = np.asarray(t_us)
    if t.ndim != 1 or not (t.dtype.kind in "iu" or (t.dtype.kind == "f" and len(t) == 0)):
        raise ParameterError(
            f"{name} must be a 1-D array of integer microseconds, got {t.dtype} of shape {t.shape}"
        )
    if len(t) and (int(t.min()) < 0 or int(t.max()) > MAX_TIME_US):
        raise ParameterError(
            f"{name} must lie in [0, 2^62] microseconds, got {int(t.min())} to {int(t.max())}"
        )
    return t.astype(np.int64)


def _span(t: np.ndarray, bin_us: int, pad: int, start_us: Any, end_us: Any) -> tuple[int, int]:
    """A rate spectrum's start and its number of bins, refused when they are more than
    :data:`MAX_SPECTRUM_POINTS` once padded."""
    if start_us is not None:
        start_us = check_int("start_us", start_us, low=0, high=MAX_TIME_US)
    if end_us is not None:
        end_us = check_int("end_us", end_us, low=0, high=MAX_TIME_US)
    lo = int(t.min()) if start_us is None and len(t) else int(start_us or 0)
    hi = int(t.max()) + 1 if end_us is None and len(t) else int(end_us or lo + bin_us)
    n = max((hi - lo) // bin_us, 2)
    if n * pad > MAX_SPECTRUM_POINTS:
        raise ParameterError(
            f"a span of {hi - lo} us in bins of bin_us={bin_us} us, padded pad={pad} times, is "
            f"{n * pad:,} points, more than MAX_SPECTRUM_POINTS ({MAX_SPECTRUM_POINTS:,}): "
            "give a shorter span (start_us, end_us), wider bins or less padding"
        )
    return lo, n


def _events(events: Any, fields: tuple[str, ...]) -> np.ndarray:
    """``events`` as a 1-D structured array with ``fields``."""
    ev = np.asarray(events)
    names = ev.dtype.names or ()
    if ev.ndim != 1 or any(f not in names for f in fields):
        raise EventError(
            f"events must be a 1-D array with fields {', '.join(fields)} (uavsnn.EVENT_DTYPE), "
            f"got {ev.dtype} of shape {ev.shape}"
        )
    return ev


def _box(box: Any) -> tuple[float, float, float, float]:
    """A box ``(x0, y0, x1, y1)`` of finite numbers, not empty (``x1 > x0``, ``y1 > y0``: a
    box given as ``(x, y, width, height)``, the rotor estimators' form, is mostly empty)."""
    try:
        x0, y0, x1, y1 = box
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"box must be (x0, y0, x1, y1), got {box!r}") from exc
    corners = (
        check_real("box x0", x0),
        check_real("box y0", y0),
        check_real("box x1", x1),
        check_real("box y1", y1),
    )
    if corners[2] <= corners[0] or corners[3] <= corners[1]:
        raise ParameterError(
            f"box must be (x0, y0, x1, y1) with x1 > x0 and y1 > y0, got {box!r} (the rotor "
            "estimators of uavsnn.signature take (x, y, width, height) instead)"
        )
    return corners


def dominant_frequency(
    freqs: np.ndarray,
    power: np.ndarray,
    *,
    low_hz: float = 20.0,
    high_hz: float | None = None,
) -> float:
    """The frequency of the strongest peak of a spectrum (:func:`pixel_rate_spectrum`,
    :func:`event_rate_spectrum`) in ``[low_hz, high_hz]`` (default: all of it above
    ``low_hz``); NaN when the band holds no power."""
    f, p = np.asarray(freqs), np.asarray(power)
    band = (f >= low_hz) & (f <= (f[-1] if high_hz is None else high_hz))
    if not band.any() or p[band].max() <= 0:
        return float("nan")
    return float(f[band][np.argmax(p[band])])


def rotor_events(
    rev_hz: float,
    diameter_px: float,
    *,
    fps: float = 500.0,
    samples_per_pass: int | None = None,
    duration_s: float = 0.5,
    blades: int = 2,
    sky: float = 0.7,
    level: float = 1.0,
    params: Any = None,
    seed: int = 0,
) -> tuple[np.ndarray, tuple[int, int]]:
    """A rotor alone, face-on against a plain sky: rendered as the "dvs" scenes render a
    quadcopter's rotors (its translucent disc and its blades, :func:`uavsnn.scenes.objects.
    rotor_parts`), frames at ``fps`` with ``ceil(samples_per_pass · blades · rev_hz / fps) -
    1`` sub-frame samples between frames (``samples_per_pass = 0``: none; ``None``: the scenes'
    :data:`~uavsnn.scenes.renderer.SAMPLES_PER_PASS`), emulated by
    :class:`~uavsnn.sim.DvsEmulator` (``params``: default :data:`~uavsnn.sim.SCENE_PARAMS`).

    Returns the events and the frame's ``(width, height)`` (the rotor in its centre, two
    pixels of sky around it). The blade pass is ``blades · rev_hz``.
    """
    from uavsnn.scenes.objects import rotor_parts
    from uavsnn.scenes.renderer import FINE_SS, SAMPLES_PER_PASS, _draw, sub_frame_times
    from uavsnn.sim.dvs import SCENE_PARAMS, DvsEmulator

    if samples_per_pass is None:
        samples_per_pass = SAMPLES_PER_PASS
    rev_hz = check_real("rev_hz", rev_hz, low=0.0)
    diameter_px = check_real("diameter_px", diameter_px, low=0.5, high=1000.0)
    fps = check_real("fps", fps, low=1.0, high=1e6)
    side = math.ceil(diameter_px) + 4
    centre = np.array([side / 2, side / 2])
    n = max(round(duration_s * fps), 2)
    frame_us = np.round(np.arange(n) * 1e6 / fps).astype(np.int64)
    m = (
        max(1, math.ceil(samples_per_pass * blades * rev_hz / fps - 1e-9))
        if samples_per_pass
        else 1
    )
    emulator = DvsEmulator(
        (side, side), params=params if params is not None else SCENE_PARAMS, seed=seed
    )
    bg = np.full((side, side, 1), sky, dtype=np.float32)
    spin = 2 * math.pi * rev_hz

    jitter = np.random.default_rng(seed)

    # Frames and sub-frame samples on one coverage grid, as the scenes draw fast parts: on two,
    # a blade's coverage at frames differed from that between them by its phase, which put
    # lines of the frame rate and its beats with the blade pass into the spectrum.
    def image(t_s: float, ss: int = FINE_SS) -> np.ndarray:
        img = bg.copy()
        # Face-on: the rotor's plane (x, z) seen as the screen's (x, y).
        face = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
        parts = rotor_parts(np.zeros(3), diameter_px / 2, spin * t_s, blades, disc=False)
        _draw(img, parts, face, centre, 1.0, 0.0, True, ss)
        return img[:, :, 0] * np.float32(level * 255.0)

    chunks = []
    for k in range(n):
        patches = []
        if k > 0 and m > 1:
            t0, t1 = int(frame_us[k - 1]), int(frame_us[k])
            sub = sub_frame_times(t0, t1, m, jitter)
            if len(sub):
                values = np.stack([image(ts * 1e-6, FINE_SS) for ts in sub.tolist()])
                patches.append((0, 0, sub, values))
        chunks.append(emulator.process_frame(image(frame_us[k] * 1e-6), int(frame_us[k]), patches))
    return np.concatenate(chunks), (side, side)


def estimate_rotation(
    events: np.ndarray, *, max_hz: float = 200.0, step_hz: float = 0.01
) -> tuple[float, float, float, float]:
    """A rotating thing's ``(rev_hz, cx, cy, concentration)`` from its events: the centre by
    a least-squares circle fit of the events' pixels (Kåsa), then the angular rate ``ω`` that
    best lines the events up in the rotating frame (the largest mean resultant length of
    ``angle - ω t``, searched over ``±max_hz`` in ``step_hz`` steps then refined). Positive:
    the angle ``atan2(y - cy, x - cx)`` grows (clockwise on screen, y pointing down).
    ``concentration`` (0-1) says how well one rate explains the events.

    Raises:
        EventError: ``events`` without the fields ``t``, ``x`` and ``y``.
        ParameterError: fewer than 3 events, a ``max_hz`` or ``step_hz`` that is not a finite
            number > 0, or a coarse search of more than :data:`MAX_ROTATION_GRID` rates.
    """
    ev = _events(events, ("t", "x", "y"))
    max_hz = check_real("max_hz", max_hz, low=0.0, low_open=True)
    step_hz = check_real("step_hz", step_hz, low=0.0, low_open=True)
    coarse = 2 * max_hz / (50 * step_hz)  # the coarse search's steps (inf past a float's range)
    if not coarse <= MAX_ROTATION_GRID - 2:
        raise ParameterError(
            f"max_hz={max_hz:g} in steps of step_hz={step_hz:g} makes a coarse search of "
            f"{coarse:.3g} rates (2 · max_hz / (50 · step_hz)), more than MAX_ROTATION_GRID "
            f"({MAX_ROTATION_GRID:,}): give a smaller max_hz or a larger step_hz"
        )
    if len(ev) < 3:
        raise ParameterError("estimate_rotation needs at least 3 events")
    x, y = ev["x"].astype(np.float64), ev["y"].astype(np.float64)
    t = (ev["t"].astype(np.int64) - int(ev["t"][0])) * 1e-6
    a = np.c_[2 * x, 2 * y, np.ones_like(x)]
    cx, cy, _ = np.linalg.lstsq(a, x * x + y * y, rcond=None)[0]
    ang = np.arctan2(y - cy, x - cx)
    # Subsample for the coarse search; refine on all events.
    sub = slice(None, None, max(1, len(ev) // 20000))

    def score(w: float, s: slice = sub) -> float:
        return float(abs(np.exp(1j * (ang[s] - w * t[s])).mean()))

    grid = 2 * np.pi * np.arange(-max_hz, max_hz + step_hz * 50, step_hz * 50)
    w0 = max(grid, key=score)
    fine = w0 + 2 * np.pi * np.arange(-50, 51) * step_hz
    w = max(fine, key=lambda v: score(v, slice(None)))
    return float(w / (2 * np.pi)), float(cx), float(cy), score(w, slice(None))


def plot_spectra(
    curves: list[tuple[str, np.ndarray, np.ndarray]],
    path: str,
    *,
    title: str = "",
    max_hz: float | None = None,
    marks: tuple[float, ...] = (),
    size: tuple[int, int] = (900, 420),
) -> None:
    """Draw spectra (``(label, freqs_hz, power)`` each, power in [0, 1]) one above the other
    as a PNG with OpenCV (no plotting library needed), frequency axis in Hz with ticks, and
    vertical marks at ``marks`` (e.g. a blade pass)."""
    import cv2

    w, h = size
    colours = [(200, 80, 30), (30, 120, 220), (40, 160, 40), (150, 40, 150)]
    panel_h = (h - 40) // max(len(curves), 1)
    img = np.full((h, w, 3), 255, np.uint8)
    left, right = 60, w - 20
    top_hz = max_hz if max_hz is not None else max(float(c[1][-1]) for c in curves)

    def xpix(f: float) -> int:
        return int(left + (right - left) * f / top_hz)

    cv2.putText(img, title, (left, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 1, cv2.LINE_AA)
    for i, (label, f, p) in enumerate(curves):
        y0 = 24 + i * panel_h
        y1 = y0 + panel_h - 24
        cv2.rectangle(img, (left, y0), (right, y1), (180, 180, 180), 1)
        for m in marks:
            cv2.line(img, (xpix(m), y0), (xpix(m), y1), (0, 0, 200), 1, cv2.LINE_AA)
        keep = f <= top_hz
        pts = np.stack(
            [left + (right - left) * f[keep] / top_hz, y1 - (y1 - y0) * np.clip(p[keep], 0, 1)],
            axis=1,
        )
        cv2.polylines(img, [np.round(pts).astype(np.int32)], False, colours[i % 4], 1, cv2.LINE_AA)
        cv2.putText(
            img,
            label,
            (left + 6, y0 + 14),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.42,
            colours[i % 4],
            1,
            cv2.LINE_AA,
        )
        step = 10 ** math.floor(math.log10(max(top_hz / 4, 1e-9)))
        for k in np.arange(0, top_hz + 1e-9, step * (2 if top_hz / step > 10 else 1)):
            cv2.line(img, (xpix(k), y1), (xpix(k), y1 + 4), (0, 0, 0), 1)
            cv2.putText(
                img,
                f"{k:g}",
                (xpix(k) - 10, y1 + 16),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.35,
                (0, 0, 0),
                1,
                cv2.LINE_AA,
            )
    cv2.putText(
        img, "Hz", (right - 20, h - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA
    )
    if not write_image(path, img):
        raise OSError(f"could not write {path}")
