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
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from uavsnn import _core
from uavsnn._validate import check_sensor_size
from uavsnn.errors import ParameterError
from uavsnn.events import packed_bytes

__all__ = [
    "DEFAULTS",
    "MAX_PIXELS",
    "MAX_SPECTRUM_BYTES",
    "SPECTRUM_DEFAULTS",
    "RotorEstimate",
    "RotorSignature",
    "RotorSpectrum",
    "SpectrumEstimate",
    "measure_box",
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


def _box(box: object) -> tuple[int, int, int, int]:
    try:
        x0, y0, width, height = (int(v) for v in box)  # type: ignore[attr-defined]
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"box must be (x0, y0, width, height), got {box!r}") from exc
    return x0, y0, width, height


class RotorSignature:
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
        try:
            args = (float(f_min_hz), float(f_max_hz), int(bins), float(consistency))
            rest = (float(agree), float(threshold), int(min_pixels))
        except (TypeError, ValueError, OverflowError) as exc:
            raise ParameterError(f"rotor signature parameters must be numbers: {exc}") from exc
        self._inner = _core.RotorSignature(x0, y0, width, height, *args, *rest)

    @classmethod
    def for_sensor(cls, sensor_size: tuple[int, int], **params: Any) -> RotorSignature:
        """An estimator over a whole ``(width, height)`` sensor."""
        width, height = check_sensor_size(sensor_size)
        return cls((0, 0, width, height), **params)

    def update(self, events: np.ndarray) -> None:
        """Feed events of the canonical dtype, in time order (earlier ones are counted as late
        and ignored).

        Raises:
            EventError: not a 1-D array of the canonical dtype.
        """
        self._inner.update(packed_bytes(events))

    def estimate(self) -> RotorEstimate:
        """The estimate from everything fed since construction or the last :meth:`clear`."""
        return RotorEstimate(*self._inner.estimate())

    def clear(self) -> None:
        """Forget every event (the state keeps its size)."""
        self._inner.clear()

    @property
    def box(self) -> tuple[int, int, int, int]:
        """``(x0, y0, width, height)``."""
        return self._inner.box

    @property
    def stats(self) -> dict[str, int]:
        """Events used, outside the box, and late (earlier than the latest seen, inside the
        box); and ``on``: the ON events inside the box, late ones included (of the
        ``events + late`` inside it)."""
        events, outside, late, on = self._inner.stats
        return {"events": events, "outside": outside, "late": late, "on": on}

    @property
    def state_bytes(self) -> int:
        """Bytes of state, fixed at construction."""
        return self._inner.state_bytes


def rotor_signature(
    events: np.ndarray, box: tuple[int, int, int, int], **params: Any
) -> RotorEstimate:
    """The rotor signature of ``events`` (canonical dtype, time order) inside ``box``; ``params``
    as :class:`RotorSignature`'s."""
    estimator = RotorSignature(box, **params)
    estimator.update(events)
    return estimator.estimate()


def measure_box(
    events: np.ndarray | Sequence[np.ndarray], box: tuple[int, int, int, int], **params: Any
) -> tuple[RotorEstimate, int, int]:
    """An object's box measured in one pass: the rotor signature of the events inside ``box``
    ``(x0, y0, width, height)`` (what :func:`rotor_signature` gives), the number of events
    inside it and how many of them are ON.

    ``events``: canonical events in time order, one array or the chunks of one stream in
    order (fed as they are, not concatenated). Nothing needs selecting first: the estimator
    ignores the events outside the box. ``params`` as :class:`RotorSignature`'s.

    Raises:
        EventError: an array not of the canonical dtype.
        ParameterError: as :class:`RotorSignature`.
    """
    estimator = RotorSignature(box, **params)
    for part in (events,) if isinstance(events, np.ndarray) else events:
        estimator.update(part)
    stats = estimator.stats  # the engine counts the box's events as it goes
    return estimator.estimate(), stats["events"] + stats["late"], stats["on"]


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


class RotorSpectrum:
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

    Raises:
        ParameterError: a parameter out of range, an empty box, or a state above
            :data:`MAX_SPECTRUM_BYTES`.
    """

    def __init__(self, box: tuple[int, int, int, int], **params: Any) -> None:
        x0, y0, width, height = _box(box)
        unknown = set(params) - set(SPECTRUM_DEFAULTS)
        if unknown:
            raise ParameterError(f"unknown rotor spectrum parameters {sorted(unknown)}")
        p = {**SPECTRUM_DEFAULTS, **params}
        try:
            ints = {
                k: int(p[k]) for k in ("bin_us", "span_us", "freqs", "min_events", "min_pixels")
            }
            floats = {k: float(p[k]) for k in ("f_min_hz", "f_max_hz", "agree", "threshold")}
        except (TypeError, ValueError, OverflowError) as exc:
            raise ParameterError(f"rotor spectrum parameters must be numbers: {exc}") from exc
        self._inner = _core.RotorSpectrum(
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

    def update(self, events: np.ndarray) -> None:
        """Feed events of the canonical dtype, in time order.

        Raises:
            EventError: not a 1-D array of the canonical dtype.
        """
        self._inner.update(packed_bytes(events))

    def estimate(self) -> SpectrumEstimate:
        """The estimate from everything fed since construction or the last :meth:`clear`."""
        return SpectrumEstimate(*self._inner.estimate())

    def power(self) -> tuple[np.ndarray, np.ndarray]:
        """``(frequencies_hz, power)``: the summed power spectrum on the grid."""
        grid, power = self._inner.power()
        return np.asarray(grid), np.asarray(power)

    def clear(self) -> None:
        """Forget every event (the state keeps its size)."""
        self._inner.clear()

    @property
    def box(self) -> tuple[int, int, int, int]:
        """``(x0, y0, width, height)``."""
        return self._inner.box

    @property
    def stats(self) -> dict[str, int]:
        """Events used, outside the box, late, and beyond ``span_us``."""
        events, outside, late, beyond = self._inner.stats
        return {"events": events, "outside": outside, "late": late, "beyond": beyond}

    @property
    def state_bytes(self) -> int:
        """Bytes of state, fixed at construction."""
        return self._inner.state_bytes


def rotor_spectrum(
    events: np.ndarray, box: tuple[int, int, int, int], **params: Any
) -> SpectrumEstimate:
    """The event-rate spectrum estimate of ``events`` (canonical dtype, time order) inside
    ``box``; ``params`` as :class:`RotorSpectrum`'s."""
    estimator = RotorSpectrum(box, **params)
    estimator.update(events)
    return estimator.estimate()
