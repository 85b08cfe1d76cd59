"""Rotor signature: the blade-pass frequency of the pixels in a box, event by event.

A thin face of the Rust estimator (``rust/signature.rs``; the method, its parameters and the
detection threshold are described in ``docs/identification.md``). Each pixel's period is the time
between two brightness edges of the same direction (a run of OFF events turning ON, or ON turning
OFF); an interval in the band that repeats the pixel's previous one within ``consistency`` votes
into a logarithmic histogram. The estimate is the strongest three-bin window: its mean frequency,
its ``strength`` (its votes over every interval measured), and how many pixels agree with it.

    >>> est = rotor_signature(events, box=(x0, y0, width, height))
    >>> est.frequency_hz, est.strength, est.pixels, est.detected

The state is fixed when the estimator is made (32 bytes per pixel of the box, at most
``MAX_PIXELS`` pixels) and the work runs in Rust without the GIL.

:func:`compensated_rotor` runs both estimators on a box's events moved to the object's frame
(its velocity by contrast maximisation, :func:`estimate_motion`), a NumPy measurement tool:
``docs/identification.md``, "Motion-compensated rotor", says what it finds and why it is not a
feature.
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from uavsnn import _core
from uavsnn._state import EngineState
from uavsnn._validate import check_real, check_sensor_size, whole
from uavsnn.errors import EventError, ParameterError
from uavsnn.events import SensorSizeLike, packed_bytes

__all__ = [
    "DEFAULTS",
    "MAX_COARSE_STEPS",
    "MAX_PIXELS",
    "MAX_SPECTRUM_BYTES",
    "MOTION_DEFAULTS",
    "SPECTRUM_DEFAULTS",
    "BoxMeasure",
    "CompensatedRotor",
    "MotionEstimate",
    "RotorEstimate",
    "RotorSignature",
    "RotorSpectrum",
    "SpectrumEstimate",
    "compensate_motion",
    "compensated_rotor",
    "estimate_motion",
    "measure_box",
    "motion_line",
    "rotor_signature",
    "rotor_spectrum",
]

_D = _core.rotor_defaults()
#: The estimator's default parameters (from the engine).
DEFAULTS: dict[str, float | int] = {k: v for k, v in _D.items() if k != "max_pixels"}
#: The largest box one estimator may follow, in pixels.
MAX_PIXELS: int = int(_D["max_pixels"])


@dataclass(frozen=True)
class RotorEstimate:
    """The rotor signature of a box.

    Attributes:
        frequency_hz: the strongest peak's frequency (0.0 when no interval voted).
        strength: the peak's votes over every interval measured, in ``[0, 1]``.
        pixels: pixels whose latest voting frequency is within ``agree`` of the peak.
        peak_votes: votes in the peak's three-bin window.
        votes: votes in the whole band.
        intervals: intervals measured (pairs of same-direction edges of a pixel).
        detected: ``strength >= threshold`` and ``pixels >= min_pixels``.
    """

    frequency_hz: float
    strength: float
    pixels: int
    peak_votes: int
    votes: int
    intervals: int
    detected: bool


#: The range of the integers the engine's estimators take (``i64``).
_I64 = (-(1 << 63), (1 << 63) - 1)


def _integer(name: str, value: Any, what: str = "") -> int:
    """An integer parameter for the engine: a whole number (a fraction is refused, not
    truncated) that fits its ``i64`` (the engine checks the parameter's own range).
    ``what`` prefixes the message."""
    result = whole(value)
    if result is None:
        raise ParameterError(f"{what}{name} must be a whole number, got {value!r}")
    if not _I64[0] <= result <= _I64[1]:
        raise ParameterError(f"{what}{name} must be in [-2**63, 2**63 - 1], got {result}")
    return result


def _box(box: Any) -> tuple[int, int, int, int]:
    """A box ``(x0, y0, width, height)`` of whole numbers in ``[0, 65535]``."""
    try:
        sides: tuple[Any, ...] = () if isinstance(box, str | bytes) else tuple(box)
    except TypeError:
        sides = ()
    values = [v for v in map(whole, sides) if v is not None and 0 <= v <= 65535]
    if len(sides) != 4 or len(values) != 4:
        raise ParameterError(
            f"box must be (x0, y0, width, height), four whole numbers in [0, 65535], got {box!r}"
        )
    x0, y0, width, height = values
    return x0, y0, width, height


class _BoxEstimator(EngineState):
    """What both rotor estimators do the same way: one engine estimator over one box (not
    copied nor pickled: :class:`~uavsnn._state.EngineState`)."""

    _inner: _core.RotorSignature | _core.RotorSpectrum

    def update(self, events: np.ndarray) -> None:
        """Feed events of the canonical dtype, in time order (earlier ones are counted as late
        and ignored).

        Raises:
            EventError: not a 1-D array of the canonical dtype.
        """
        self._inner.update(packed_bytes(events))

    def clear(self) -> None:
        """Forget every event (the state keeps its size)."""
        self._inner.clear()

    @property
    def box(self) -> tuple[int, int, int, int]:
        """``(x0, y0, width, height)``."""
        return self._inner.box

    @property
    def state_bytes(self) -> int:
        """Bytes of state, fixed at construction."""
        return self._inner.state_bytes


def _known(params: dict[str, Any], defaults: dict[str, float | int], what: str) -> None:
    """Refuse a parameter name not among ``defaults`` (a misspelt keyword passed on through
    ``**params``, which a type checker cannot see)."""
    unknown = set(params) - set(defaults)
    if unknown:
        raise ParameterError(f"unknown {what} parameters {sorted(unknown)}")


class RotorSignature(_BoxEstimator):
    """A rotor-signature estimator over one box of pixels (or a whole sensor).

    Args:
        box: ``(x0, y0, width, height)`` in sensor pixels; events outside it are counted and
            ignored.
        f_min_hz, f_max_hz: the band searched (default 50–1000 Hz).
        bins: logarithmic histogram bins over the band (default 64).
        consistency: largest relative change between a pixel's successive periods for a vote
            (default 0.1).
        agree: largest relative distance of a pixel's frequency to the peak for it to agree
            (default 0.05).
        threshold: detection threshold on the strength (default: the documented one).
        min_pixels: fewest agreeing pixels for a detection (default 3).

    It cannot be copied nor pickled (a ``TypeError``): its state lives in the engine; make
    another and feed it the same events.

    Raises:
        ParameterError: a parameter out of range, or an empty or oversized box.
    """

    def __init__(
        self,
        box: tuple[int, int, int, int],
        *,
        f_min_hz: float = float(DEFAULTS["f_min_hz"]),
        f_max_hz: float = float(DEFAULTS["f_max_hz"]),
        bins: int = int(DEFAULTS["bins"]),
        consistency: float = float(DEFAULTS["consistency"]),
        agree: float = float(DEFAULTS["agree"]),
        threshold: float = float(DEFAULTS["threshold"]),
        min_pixels: int = int(DEFAULTS["min_pixels"]),
    ) -> None:
        x0, y0, width, height = _box(box)
        what = "rotor signature parameters must be numbers: "
        # Real parameters must be finite numbers (a string such as "0.5" or a bool is refused,
        # not converted); the engine checks each one's range.
        args = (
            check_real("f_min_hz", f_min_hz),
            check_real("f_max_hz", f_max_hz),
            _integer("bins", bins, what),
            check_real("consistency", consistency),
            check_real("agree", agree),
            check_real("threshold", threshold),
            _integer("min_pixels", min_pixels, what),
        )
        self._inner: _core.RotorSignature = _core.RotorSignature(x0, y0, width, height, *args)

    @classmethod
    def for_sensor(cls, sensor_size: SensorSizeLike, **params: Any) -> RotorSignature:
        """An estimator over a whole ``(width, height)`` sensor."""
        width, height = check_sensor_size(sensor_size)
        _known(params, DEFAULTS, "rotor signature")
        return cls((0, 0, width, height), **params)

    def estimate(self) -> RotorEstimate:
        """The estimate from everything fed since construction or the last :meth:`clear`."""
        return RotorEstimate(*self._inner.estimate())

    @property
    def stats(self) -> dict[str, int]:
        """Events used, outside the box, and late (earlier than the latest seen, inside the
        box); and ``on``: the ON events inside the box, late ones included (of the
        ``events + late`` inside it)."""
        events, outside, late, on = self._inner.stats
        return {"events": events, "outside": outside, "late": late, "on": on}

    def count_rate(self, start_us: int, bin_us: int, bins: int) -> None:
        """Count the box's events from now on in ``bins`` bins of ``bin_us`` µs from
        ``start_us`` (:attr:`rate`); bin ``k`` holds the in-order events inside the box with
        ``start_us + k * bin_us <= t < start_us + (k + 1) * bin_us``. :meth:`clear` zeroes the
        counts and keeps the bins.

        Raises:
            ParameterError: a value that is not a whole number, ``bin_us`` below 1, ``bins``
                outside ``1..=4096``, or ``start_us`` outside ``0..=2**63-1``.
        """
        args = (
            _integer("start_us", start_us, "rate bins: "),
            _integer("bin_us", bin_us, "rate bins: "),
            _integer("bins", bins, "rate bins: "),
        )
        self._inner.count_rate(*args)

    @property
    def rate(self) -> np.ndarray:
        """The box's events per rate bin (:meth:`count_rate`), ``uint32``; empty when the
        rate is not counted."""
        return np.asarray(self._inner.rate, dtype=np.uint32)

    @property
    def rate_swing(self) -> float:
        """How strongly :attr:`rate` swings beyond shot noise
        (:func:`uavsnn.features.rate_swing`; 0.0 when the rate is not counted)."""
        return self._inner.rate_swing


def rotor_signature(
    events: np.ndarray, box: tuple[int, int, int, int], **params: Any
) -> RotorEstimate:
    """The rotor signature of ``events`` (canonical dtype, time order) inside ``box``; ``params``
    as :class:`RotorSignature`'s.

    Raises:
        EventError: not a 1-D array of the canonical dtype, or not in time order (a stream's
            :meth:`RotorSignature.update` counts an earlier event as late and skips it; one
            array is refused).
    """
    _known(params, DEFAULTS, "rotor signature")
    estimator = RotorSignature(box, **params)
    estimator.update(events)
    _check_time_order(events)
    return estimator.estimate()


def _check_time_order(events: np.ndarray) -> None:
    """Refuse canonical ``events`` not in time order, naming the first event out of it."""
    back = np.flatnonzero(np.diff(events["t"].astype(np.int64)) < 0)
    if len(back):
        k = int(back[0]) + 1
        raise EventError(
            f"event {k}: t={int(events['t'][k])} is earlier than the event before it "
            f"(t={int(events['t'][k - 1])}): events must be in time order"
        )


def measure_box(
    events: np.ndarray | Sequence[np.ndarray],
    box: tuple[int, int, int, int],
    *,
    rate: tuple[int, int, int] | None = None,
    **params: Any,
) -> BoxMeasure:
    """An object's box measured in one pass: the rotor signature of the events inside ``box``
    ``(x0, y0, width, height)`` (what :func:`rotor_signature` gives), the number of events
    inside it and how many of them are ON, and with ``rate`` ``(start_us, bin_us, bins)`` how
    strongly its events per time bin swing (:meth:`RotorSignature.count_rate`,
    :func:`uavsnn.features.rate_swing`; else 0.0).

    ``events``: canonical events in time order, one array or the chunks of one stream in
    order (fed as they are, not concatenated). Nothing needs selecting first: the estimator
    ignores the events outside the box. Events inside it earlier than one before them are not
    refused: as a stream's late events, the estimator leaves them out of the estimate and
    counts them (so an array in reverse order measures no rotor; :func:`rotor_signature`,
    given one array, refuses it). ``params`` as :class:`RotorSignature`'s.

    Raises:
        EventError: an array not of the canonical dtype.
        ParameterError: as :class:`RotorSignature` and :meth:`RotorSignature.count_rate`, or
            a ``rate`` that is not three numbers ``(start_us, bin_us, bins)``.
    """
    _known(params, DEFAULTS, "rotor signature")
    estimator = RotorSignature(box, **params)
    if rate is not None:
        estimator.count_rate(*_rate(rate))
    for part in (events,) if isinstance(events, np.ndarray) else events:
        estimator.update(part)
    stats = estimator.stats  # the engine counts the box's events as it goes
    n = stats["events"] + stats["late"]
    return BoxMeasure(estimator.estimate(), n, stats["on"], estimator.rate_swing)


def _rate(rate: Any) -> tuple[Any, Any, Any]:
    """``rate`` as its three values ``(start_us, bin_us, bins)`` (each checked by
    :meth:`RotorSignature.count_rate`)."""
    try:
        values = () if isinstance(rate, str | bytes) else tuple(rate)
    except TypeError:
        values = ()
    if len(values) != 3:
        raise ParameterError(f"rate must be (start_us, bin_us, bins), got {rate!r}")
    return values[0], values[1], values[2]


class BoxMeasure(NamedTuple):
    """What :func:`measure_box` measures of a box."""

    #: The rotor signature of the box's events.
    rotor: RotorEstimate
    #: Events inside the box (late ones included).
    events: int
    #: ON events among them.
    on: int
    #: How strongly its events per rate bin swing (:func:`uavsnn.features.rate_swing`; 0.0
    #: without ``rate``).
    rate_swing: float

    @property
    def counts(self) -> tuple[int, int, float]:
        """``(events, on, rate_swing)``: what :attr:`uavsnn.grouping.WindowObject.counts`
        holds."""
        return self.events, self.on, self.rate_swing


# --------------------------------------------------------------------------- rate spectrum

_S = _core.spectrum_defaults()
#: The spectrum estimator's default parameters (from the engine).
SPECTRUM_DEFAULTS: dict[str, float | int] = {k: v for k, v in _S.items() if k != "max_state_bytes"}
#: The largest state one spectrum estimator may hold, in bytes.
MAX_SPECTRUM_BYTES: int = int(_S["max_state_bytes"])


@dataclass(frozen=True)
class SpectrumEstimate:
    """The event-rate spectrum of a box (``docs/identification.md``, "The rate spectrum").

    Attributes:
        frequency_hz: the summed spectrum's peak (the lowest harmonic holding half the highest
            power), 0.0 when no channel had ``min_events`` events.
        prominence: the peak's power over the band's median power.
        pixels: pixels with a channel (ON or OFF) whose own peak is within ``agree`` of it.
        channels: channels (pixel and polarity) with at least ``min_events`` events.
        events: events in those channels.
        detected: ``prominence >= threshold`` and ``pixels >= min_pixels``.
    """

    frequency_hz: float
    prominence: float
    pixels: int
    channels: int
    events: int
    detected: bool


class RotorSpectrum(_BoxEstimator):
    """The per-pixel event-rate spectrum of a box, summed over its pixels (Rust,
    ``rust/signature/spectrum.rs``): each pixel's ON and OFF events counted in ``bin_us`` bins
    over at most ``span_us`` from the first event, then a Hann-windowed DFT per channel at
    ``freqs`` log-spaced frequencies over the band.

    Args:
        box: ``(x0, y0, width, height)`` in sensor pixels.
        bin_us: count bin (default 250 µs).
        span_us: longest stretch followed from the first event (default 100 ms); later events
            are counted as ``beyond`` and ignored.
        f_min_hz, f_max_hz: the band (default 50–1000 Hz).
        freqs: grid frequencies (default 256).
        min_events: fewest events for a channel to count (default 3).
        agree: relative distance of a channel's own peak for its pixel to agree (default 0.03).
        threshold: detection threshold on the prominence (default: the documented one).
        min_pixels: fewest agreeing pixels for a detection (default 2).

    It cannot be copied nor pickled (a ``TypeError``), as :class:`RotorSignature`.

    Raises:
        ParameterError: a parameter out of range, an empty box, or a state above
            :data:`MAX_SPECTRUM_BYTES`.
    """

    def __init__(self, box: tuple[int, int, int, int], **params: Any) -> None:
        x0, y0, width, height = _box(box)
        _known(params, SPECTRUM_DEFAULTS, "rotor spectrum")
        p = {**SPECTRUM_DEFAULTS, **params}
        what = "rotor spectrum parameters must be numbers: "
        ints = {
            k: _integer(k, p[k], what)
            for k in ("bin_us", "span_us", "freqs", "min_events", "min_pixels")
        }
        floats = {k: check_real(k, p[k]) for k in ("f_min_hz", "f_max_hz", "agree", "threshold")}
        self._inner: _core.RotorSpectrum = _core.RotorSpectrum(
            x0,
            y0,
            width,
            height,
            ints["bin_us"],
            ints["span_us"],
            floats["f_min_hz"],
            floats["f_max_hz"],
            ints["freqs"],
            ints["min_events"],
            floats["agree"],
            floats["threshold"],
            ints["min_pixels"],
        )

    def estimate(self) -> SpectrumEstimate:
        """The estimate from everything fed since construction or the last :meth:`clear`."""
        return SpectrumEstimate(*self._inner.estimate())

    def power(self) -> tuple[np.ndarray, np.ndarray]:
        """``(frequencies_hz, power)``: the summed power spectrum on the grid."""
        grid, power = self._inner.power()
        return np.asarray(grid), np.asarray(power)

    @property
    def stats(self) -> dict[str, int]:
        """Events used, outside the box, late, and beyond ``span_us``."""
        events, outside, late, beyond = self._inner.stats
        return {"events": events, "outside": outside, "late": late, "beyond": beyond}


def rotor_spectrum(
    events: np.ndarray, box: tuple[int, int, int, int], **params: Any
) -> SpectrumEstimate:
    """The event-rate spectrum estimate of ``events`` (canonical dtype, time order) inside
    ``box``; ``params`` as :class:`RotorSpectrum`'s.

    Raises:
        EventError: as :func:`rotor_signature`.
    """
    estimator = RotorSpectrum(box, **params)
    estimator.update(events)
    _check_time_order(events)
    return estimator.estimate()


# --------------------------------------------------------------------------- motion compensation

#: Defaults of :func:`estimate_motion` (``docs/identification.md``, "Motion-compensated rotor").
MOTION_DEFAULTS: dict[str, float | int] = {
    "min_events": 32,
    "min_gain": 0.05,
    "coarse_steps": 8,
    "finest_px": 0.25,
    "max_events": 4096,
}
#: The most coarse steps :func:`estimate_motion` takes each way (its search evaluates
#: ``(2 * coarse_steps + 1)**2`` velocities before refining).
MAX_COARSE_STEPS = 32


@dataclass(frozen=True)
class MotionEstimate:
    """The image velocity of the events in a box, by contrast maximisation.

    Attributes:
        vx, vy: the velocity (px/s); 0.0 when the contrast gained is under ``min_gain``.
        t_ref_us: the time the warped events are moved to (the middle of their span).
        gain: the warped events' contrast at the velocity found over their contrast unwarped,
            minus one (0.0 with too few events).
        events: events in the box.
    """

    vx: float
    vy: float
    t_ref_us: float
    gain: float
    events: int

    @property
    def speed(self) -> float:
        """``hypot(vx, vy)`` in px/s."""
        return float(np.hypot(self.vx, self.vy))


@dataclass(frozen=True)
class CompensatedRotor:
    """Both rotor estimators on a box's events moved to the object's frame.

    Attributes:
        motion: the velocity the events were compensated by.
        edges: :func:`rotor_signature` of the warped events.
        spectrum: :func:`rotor_spectrum` of the warped events.
        kept: warped events that land in the box (and were read by the estimators).
    """

    motion: MotionEstimate
    edges: RotorEstimate
    spectrum: SpectrumEstimate
    kept: int

    @property
    def detected(self) -> bool:
        """Either estimator detected a rotor."""
        return bool(self.edges.detected or self.spectrum.detected)


def _in_box(events: np.ndarray, box: tuple[int, int, int, int]) -> np.ndarray:
    packed_bytes(events)  # the canonical dtype, 1-D, or an EventError
    x0, y0, width, height = box
    x = events["x"].astype(np.int64)
    y = events["y"].astype(np.int64)
    return events[(x >= x0) & (x < x0 + width) & (y >= y0) & (y < y0 + height)]


#: The largest image :func:`_contrast` splats into densely (a larger one, for events spread over
#: a large box, is accumulated sparsely).
_DENSE_PIXELS = 1 << 16


def _contrast(x: np.ndarray, y: np.ndarray, dt: np.ndarray, vx: float, vy: float) -> float:
    """Sum of squares of the bilinearly splatted image of the events warped by ``(vx, vy)``
    (box-local coordinates; the image is bounded by the box and its margin)."""
    wx = x - vx * dt
    wy = y - vy * dt
    ix = np.floor(wx)
    iy = np.floor(wy)
    fx = wx - ix
    fy = wy - iy
    ix = ix.astype(np.int64)
    iy = iy.astype(np.int64)
    lo_x, lo_y = int(ix.min()), int(iy.min())
    ix -= lo_x
    iy -= lo_y
    w = int(ix.max()) + 2
    h = int(iy.max()) + 2
    flat = iy * w + ix
    size = w * h
    if size > max(_DENSE_PIXELS, 16 * len(x)):
        # A sparse image (events spread over a large box): its cost follows the events, not
        # the box's area.
        keys = np.concatenate((flat, flat + 1, flat + w, flat + w + 1))
        weights = np.concatenate(((1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy))
        _, inverse = np.unique(keys, return_inverse=True)
        sparse = np.bincount(inverse.ravel(), weights)
        return float(np.dot(sparse, sparse))
    image = np.bincount(flat, (1 - fx) * (1 - fy), size)
    image += np.bincount(flat + 1, fx * (1 - fy), size)
    image += np.bincount(flat + w, (1 - fx) * fy, size)
    image += np.bincount(flat + w + 1, fx * fy, size)
    return float(np.dot(image, image))


def estimate_motion(
    events: np.ndarray,
    box: tuple[int, int, int, int],
    *,
    min_events: int = int(MOTION_DEFAULTS["min_events"]),
    min_gain: float = float(MOTION_DEFAULTS["min_gain"]),
    coarse_steps: int = int(MOTION_DEFAULTS["coarse_steps"]),
    finest_px: float = float(MOTION_DEFAULTS["finest_px"]),
    max_events: int = int(MOTION_DEFAULTS["max_events"]),
) -> MotionEstimate:
    """The image velocity of the events inside ``box`` (canonical dtype, time order).

    The events are warped to the middle of their span, ``(x − vx (t − tm), y − vy (t − tm))``,
    for a grid of velocities, and the velocity whose warped image is sharpest (largest sum of
    squares of a bilinear splat) wins: contrast maximisation. The object is assumed to stay in
    its box over the span, so the grid covers displacements up to the box's width and height
    over the span, first in ``coarse_steps`` steps each way, then refined around the best by
    halving the step down to ``finest_px`` of displacement. A velocity that sharpens the image
    by less than ``min_gain`` (relative) is reported as 0: a still source stays unwarped.
    Beyond ``max_events`` events in the box, an evenly strided subset of that many is used, so
    the cost is bounded whatever the box holds; the box may hold at most :data:`MAX_PIXELS`
    pixels (as the rotor estimators' boxes) and ``coarse_steps`` is at most
    :data:`MAX_COARSE_STEPS`.

    Raises:
        ParameterError: a bad box or parameter, a box above :data:`MAX_PIXELS` pixels, or
            ``coarse_steps`` outside ``1..=MAX_COARSE_STEPS``.
        EventError: events not a 1-D array of the canonical dtype.
    """
    x0, y0, width, height = _box(box)
    if width <= 0 or height <= 0:
        raise ParameterError(f"box must have a positive width and height, got {box!r}")
    if width * height > MAX_PIXELS:
        raise ParameterError(
            f"box {width}x{height} = {width * height} pixels is above the cap of {MAX_PIXELS} "
            "(uavsnn.signature.MAX_PIXELS, as for the rotor estimators)"
        )
    min_events = _integer("min_events", min_events)
    coarse_steps = _integer("coarse_steps", coarse_steps)
    if coarse_steps > MAX_COARSE_STEPS:
        raise ParameterError(
            f"coarse_steps must be at most {MAX_COARSE_STEPS} (uavsnn.signature."
            f"MAX_COARSE_STEPS), got {coarse_steps}"
        )
    max_events = _integer("max_events", max_events)
    for name, value in (("min_gain", min_gain), ("finest_px", finest_px)):
        if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
            raise ParameterError(f"{name} must be a number, got {value!r}")
    if min_events < 2 or not float(min_gain) >= 0.0 or coarse_steps < 1:
        raise ParameterError("min_events >= 2, min_gain >= 0 and coarse_steps >= 1 needed")
    if max_events < min_events:
        raise ParameterError(f"max_events must be at least min_events, got {max_events!r}")
    if not 0.0 < float(finest_px) <= 1.0:
        raise ParameterError(f"finest_px must be in (0, 1], got {finest_px!r}")
    ev = _in_box(events, (x0, y0, width, height))
    if len(ev) == 0:
        return MotionEstimate(0.0, 0.0, 0.0, 0.0, 0)
    t = ev["t"].astype(np.float64)
    t_ref = 0.5 * (t[0] + t[-1])
    span_s = (t[-1] - t[0]) * 1e-6
    if len(ev) < int(min_events) or span_s <= 0.0:
        return MotionEstimate(0.0, 0.0, float(t_ref), 0.0, len(ev))
    n = len(ev)
    if n > int(max_events):
        pick = (np.arange(int(max_events), dtype=np.int64) * n) // int(max_events)
        ev, t = ev[pick], t[pick]
    dt = (t - t_ref) * 1e-6
    x = ev["x"].astype(np.float64) - x0
    y = ev["y"].astype(np.float64) - y0
    base = _contrast(x, y, dt, 0.0, 0.0)
    # search in displacement over the span (px), then convert
    best = (0.0, 0.0)
    best_c = base
    step_x = width / coarse_steps
    step_y = height / coarse_steps
    reach_x, reach_y = float(width), float(height)
    cx, cy = 0.0, 0.0
    while True:
        nx = int(np.floor(reach_x / step_x + 1e-9))
        ny = int(np.floor(reach_y / step_y + 1e-9))
        for i in range(-nx, nx + 1):
            for j in range(-ny, ny + 1):
                dx, dy = cx + i * step_x, cy + j * step_y
                if abs(dx) > width or abs(dy) > height:
                    continue
                c = _contrast(x, y, dt, dx / span_s, dy / span_s)
                if c > best_c:
                    best_c, best = c, (dx, dy)
        if max(step_x, step_y) <= finest_px:
            break
        cx, cy = best
        reach_x, reach_y = step_x, step_y
        step_x, step_y = max(step_x / 2, finest_px / 2), max(step_y / 2, finest_px / 2)
        step_x, step_y = min(step_x, reach_x), min(step_y, reach_y)
    gain = best_c / base - 1.0 if base > 0 else 0.0
    if gain < float(min_gain):
        return MotionEstimate(0.0, 0.0, float(t_ref), float(gain), n)
    return MotionEstimate(
        float(best[0] / span_s), float(best[1] / span_s), float(t_ref), float(gain), n
    )


def compensate_motion(
    events: np.ndarray, box: tuple[int, int, int, int], motion: MotionEstimate
) -> np.ndarray:
    """The events inside ``box`` moved to the object's frame at ``motion.t_ref_us``: each to
    the pixel nearest ``(x − vx (t − tm), y − vy (t − tm))``, those that land outside the box
    dropped. Times and order are kept. A still motion returns the box's events unchanged."""
    x0, y0, width, height = _box(box)
    ev = _in_box(events, (x0, y0, width, height))
    if motion.vx == 0.0 and motion.vy == 0.0:
        return ev
    dt = (ev["t"].astype(np.float64) - motion.t_ref_us) * 1e-6
    wx = np.floor(ev["x"].astype(np.float64) - motion.vx * dt + 0.5).astype(np.int64)
    wy = np.floor(ev["y"].astype(np.float64) - motion.vy * dt + 0.5).astype(np.int64)
    keep = (wx >= x0) & (wx < x0 + width) & (wy >= y0) & (wy < y0 + height)
    out = ev[keep].copy()
    out["x"] = wx[keep]
    out["y"] = wy[keep]
    return out


def compensated_rotor(
    events: np.ndarray,
    box: tuple[int, int, int, int],
    *,
    motion: MotionEstimate | None = None,
    edge_params: dict[str, Any] | None = None,
    spectrum_params: dict[str, Any] | None = None,
    **motion_params: Any,
) -> CompensatedRotor:
    """The rotor estimators on ``events`` inside ``box`` after compensating the box's motion
    (:func:`estimate_motion` with ``motion_params`` unless ``motion`` is given; then
    :func:`compensate_motion`). ``edge_params`` and ``spectrum_params`` go to
    :func:`rotor_signature` and :func:`rotor_spectrum`.

    Raises:
        ParameterError: a bad box or parameter, or an unknown motion parameter.
        EventError: events not a 1-D array of the canonical dtype.
    """
    box = _box(box)
    unknown = set(motion_params) - set(MOTION_DEFAULTS)
    if unknown:
        raise ParameterError(f"unknown motion parameters {sorted(unknown)}")
    if motion is None:
        motion = estimate_motion(events, box, **motion_params)
    warped = compensate_motion(events, box, motion)
    return CompensatedRotor(
        motion,
        rotor_signature(warped, box, **(edge_params or {})),
        rotor_spectrum(warped, box, **(spectrum_params or {})),
        len(warped),
    )


def motion_line(
    frequency_hz: float, motion: MotionEstimate, *, tol: float = 0.05, harmonics: int = 3
) -> bool:
    """Whether ``frequency_hz`` lies within ``tol`` (relative) of ``k·|vx|`` or ``k·|vy|``, the
    velocity in px/s, for ``k`` = ½ and 1..``harmonics``.

    In the object's frame an edge moving at ``v`` px/s crosses one sensor pixel every ``1/v``
    seconds, so its compensated events repeat at ``|vx|`` and ``|vy|`` Hz (and, where a pixel
    answers every other crossing, at half of it): a line there is the pixel grid, not a rotor.
    """
    if not frequency_hz > 0.0:
        return False
    factors = (0.5, *range(1, int(harmonics) + 1))
    for v in (abs(motion.vx), abs(motion.vy)):
        for k in factors:
            if v > 0.0 and abs(frequency_hz - k * v) <= tol * k * v:
                return True
    return False
