"""The "dvs" domain: a DVS sensor emulator in the spirit of v2e and ESIM.

The per-pixel work runs in Rust (``rust/sim/dvs.rs``). Each pixel tracks the difference
``d = L - R`` between its (low-passed) response ``L`` — v2e's ``lin_log`` of BT.601 luma — and
its memorised value ``R``; between frames ``L`` moves linearly and every threshold crossing is
emitted at its exact interpolated time, as ESIM does (no cap on events per frame). On top:

- threshold mismatch: per-pixel ``θ_on``, ``θ_off`` from ``N(θ, σ)`` clipped at 0.01 (v2e);
- refractory period: after any event the pixel is held in reset for ``refractory_us``;
- leak: ``R`` drifts down by ``leak_rate_hz · θ_on`` per second — ON events at ``leak_rate_hz``
  in a static scene — with log-normal per-pixel rates (``leak_spread_decades``, normalised to
  the asked mean) and a random starting phase;
- shot noise: Poisson events at ``shot_noise_rate_hz`` per pixel in the dark, scaled linearly to
  ``shot_noise_bright_factor`` times that at white, half ON, half OFF;
- hot pixels: ``round(hot_pixel_fraction · pixels)`` pixels firing ON at ``hot_pixel_rate_hz``;
- low light: a first-order photoreceptor low-pass with cutoff
  ``cutoff_hz · (Y + c) / (255 + c)``, ``c = cutoff_dark_luma`` (v2e's intensity scaling has
  ``c = 20``; a small ``c`` makes the bandwidth proportional to the light, kHz in daylight and
  tens of Hz at dusk — :data:`SCENE_PARAMS`), so dark pixels are slower as well as noisier;
- sub-frame samples: between two frames, small patches (a rotor, a wing) may be given at more
  times (:meth:`DvsEmulator.process_frame`); their pixels follow those samples, so what moves
  faster than the frame rate reaches them without aliasing.

Every event resets its pixel; noise events do not shift ``R`` by a threshold, so the noise
rates delivered are the rates asked for (with no refractory period). Random draws come from one
PCG stream per pixel row derived from ``seed``: the same seed gives the same events whatever the
number of threads. See ``docs/simulation.md`` for the choices.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from uavsnn import _core
from uavsnn._state import EngineState
from uavsnn._validate import MAX_TIME_US
from uavsnn.errors import ParameterError, SimulationError
from uavsnn.events import EVENT_DTYPE
from uavsnn.sim.checks import check_real, check_seed, check_size
from uavsnn.sim.frames import as_frame_batch, push_frames, whole_microseconds

__all__ = ["GEN3_ON_OFF_RATIO", "SCENE_PARAMS", "DvsEmulator", "DvsParams", "emulate_dvs"]

#: Highest rate accepted for any per-pixel noise process (one event per microsecond).
MAX_RATE_HZ = 1e6


@dataclass(frozen=True)
class DvsParams:
    """Parameters of the emulated sensor, validated on construction
    (:class:`~uavsnn.ParameterError`). Defaults describe a DAVIS240-like sensor in ordinary
    light.

    Attributes:
        threshold_on: mean ON threshold, in log-intensity units (default 0.2, as v2e).
        threshold_off: mean OFF threshold, positive (default 0.2).
        threshold_sigma: per-pixel standard deviation of both thresholds (default 0.03, v2e).
        refractory_us: dead time after each event, microseconds (default 100).
        leak_rate_hz: leak (background-activity) ON events per pixel per second (default 0.1).
        leak_spread_decades: log-normal spread of per-pixel leak rates (default 0.1, v2e).
        shot_noise_rate_hz: shot-noise events per pixel per second in the dark (default 1).
        shot_noise_bright_factor: shot-noise rate at white relative to dark (default 0.25, v2e).
        hot_pixel_fraction: fraction of pixels that are hot (default 1e-4).
        hot_pixel_rate_hz: ON events per second of each hot pixel (default 20).
        cutoff_hz: photoreceptor cutoff at white, Hz; 0 disables the low-pass (default 300).
        linlog_threshold: luma below which the response is linear, not log (default 20, v2e).
        cutoff_dark_luma: luma added before the cutoff scales with intensity, > 0: the cutoff
            at luma ``Y`` is ``cutoff_hz · (Y + c) / (255 + c)`` (default 20, v2e).
    """

    threshold_on: float = 0.2
    threshold_off: float = 0.2
    threshold_sigma: float = 0.03
    refractory_us: float = 100.0
    leak_rate_hz: float = 0.1
    leak_spread_decades: float = 0.1
    shot_noise_rate_hz: float = 1.0
    shot_noise_bright_factor: float = 0.25
    hot_pixel_fraction: float = 1e-4
    hot_pixel_rate_hz: float = 20.0
    cutoff_hz: float = 300.0
    linlog_threshold: float = 20.0
    cutoff_dark_luma: float = 20.0

    def __post_init__(self) -> None:
        check_real("threshold_on", self.threshold_on, low=0.0, low_open=True)
        check_real("threshold_off", self.threshold_off, low=0.0, low_open=True)
        check_real("threshold_sigma", self.threshold_sigma, low=0.0)
        check_real("refractory_us", self.refractory_us, low=0.0)
        check_real("leak_rate_hz", self.leak_rate_hz, low=0.0, high=MAX_RATE_HZ)
        check_real("leak_spread_decades", self.leak_spread_decades, low=0.0, high=3.0)
        check_real("shot_noise_rate_hz", self.shot_noise_rate_hz, low=0.0, high=MAX_RATE_HZ)
        check_real("shot_noise_bright_factor", self.shot_noise_bright_factor, low=0.0)
        check_real(
            "shot_noise_rate_hz * shot_noise_bright_factor",
            float(self.shot_noise_rate_hz) * float(self.shot_noise_bright_factor),
            high=MAX_RATE_HZ,
        )
        check_real("hot_pixel_fraction", self.hot_pixel_fraction, low=0.0, high=1.0)
        check_real("hot_pixel_rate_hz", self.hot_pixel_rate_hz, low=0.0, high=MAX_RATE_HZ)
        check_real("cutoff_hz", self.cutoff_hz, low=0.0)
        check_real("linlog_threshold", self.linlog_threshold, low=0.0, low_open=True)
        check_real("cutoff_dark_luma", self.cutoff_dark_luma, low=0.0, low_open=True)

    @classmethod
    def ideal(cls, **overrides: Any) -> DvsParams:
        """An ideal sensor: uniform thresholds, no refractory period, no noise of any kind,
        unlimited bandwidth. Keyword arguments override fields."""
        base: dict[str, Any] = {
            "threshold_sigma": 0.0,
            "refractory_us": 0.0,
            "leak_rate_hz": 0.0,
            "shot_noise_rate_hz": 0.0,
            "hot_pixel_fraction": 0.0,
            "cutoff_hz": 0.0,
        }
        base.update(overrides)
        return cls(**base)

    @classmethod
    def noisy(cls, **overrides: Any) -> DvsParams:
        """v2e's "noisy" preset (σ 0.05, 30 Hz cutoff, 0.1 Hz leak, 5 Hz shot noise, 10 ms
        refractory period): a dim scene. Keyword arguments override fields."""
        base: dict[str, Any] = {
            "threshold_sigma": 0.05,
            "cutoff_hz": 30.0,
            "leak_rate_hz": 0.1,
            "shot_noise_rate_hz": 5.0,
            "refractory_us": 10_000.0,
        }
        base.update(overrides)
        return cls(**base)

    @classmethod
    def gen3(cls, **overrides: Any) -> DvsParams:
        """A Prophesee Gen3-like sensor, from the spinner comparison of
        ``docs/simulation.md``: the scene sensor's photoreceptor (3 kHz at white, proportional
        to the light), a 1 µs refractory period and an ON threshold of the OFF threshold over
        1.88 — the real camera's ON/OFF events per pixel for one passage of a dark arc
        (:data:`GEN3_ON_OFF_RATIO`). Keyword arguments override fields."""
        base: dict[str, Any] = {
            "cutoff_hz": 3000.0,
            "cutoff_dark_luma": 0.5,
            "refractory_us": 1.0,
            "threshold_on": 0.2 / GEN3_ON_OFF_RATIO,
            "threshold_off": 0.2,
        }
        base.update(overrides)
        return cls(**base)


#: ON over OFF events per pixel of the Prophesee Gen3 spinner recording (15 and 8 for one
#: passage of its dark arc; ``benches/python/spinner_compare.py``): its ON threshold is about
#: its OFF threshold over this ratio.
GEN3_ON_OFF_RATIO = 1.88

#: The sensor of rendered scenes ("dvs" domain): v2e's defaults, with a photoreceptor whose
#: bandwidth is proportional to the light — 3 kHz at white, about 2 kHz under a bright sky, tens
#: of Hz at dusk (``Lighting.level`` 0.03) — as a DAVIS pixel's is (its bandwidth in daylight is
#: several kHz). Rendered luma is proportional to the scene's light, so dusk scenes blur what
#: noon scenes resolve.
SCENE_PARAMS = DvsParams(cutoff_hz=3000.0, cutoff_dark_luma=0.5)


def check_int_time(t_us: Any) -> int:
    """A frame time in microseconds, ``[0, 2^62]`` (the engine's latest time)."""
    if isinstance(t_us, bool) or not isinstance(t_us, (int, np.integer)) or not 0 <= t_us < 2**64:
        raise SimulationError(
            f"a frame time must be an integer number of microseconds, got {t_us!r}"
        )
    if t_us > MAX_TIME_US:
        raise SimulationError(
            f"a frame time of {int(t_us)} µs is beyond the latest time the engine takes "
            f"(2^62 = {MAX_TIME_US} µs)"
        )
    return int(t_us)


class DvsEmulator(EngineState):
    """The emulator fed frames in batches, keeping each pixel's state between calls, so that a
    long rendering runs in bounded memory. It cannot be copied nor pickled (a ``TypeError``):
    its state lives in the engine. A batch stopped part way (Ctrl-C) leaves it past frames
    whose events were lost: every later batch is refused (make a new one).

    Args:
        sensor_size: ``(width, height)`` of the frames, which is the sensor's size.
        params: sensor parameters (defaults: :class:`DvsParams`).
        seed: draws the thresholds, leak rates, hot pixels and all noise.
    """

    def __init__(
        self,
        sensor_size: tuple[int, int],
        *,
        params: DvsParams | None = None,
        seed: int = 0,
    ) -> None:
        self.params = params if params is not None else DvsParams()
        if not isinstance(self.params, DvsParams):
            raise ParameterError(f"params must be DvsParams, got {type(self.params).__name__}")
        width, height = check_size(sensor_size, "sensor_size")
        self.seed = check_seed(seed)
        p = self.params
        self._kernel = _core.DvsKernel(
            width,
            height,
            seed=self.seed,
            threshold_on=p.threshold_on,
            threshold_off=p.threshold_off,
            threshold_sigma=p.threshold_sigma,
            refractory_us=p.refractory_us,
            leak_rate_hz=p.leak_rate_hz,
            leak_spread_decades=p.leak_spread_decades,
            shot_noise_rate_hz=p.shot_noise_rate_hz,
            shot_noise_bright_factor=p.shot_noise_bright_factor,
            hot_pixel_fraction=p.hot_pixel_fraction,
            hot_pixel_rate_hz=p.hot_pixel_rate_hz,
            cutoff_hz=p.cutoff_hz,
            linlog_threshold=p.linlog_threshold,
            cutoff_dark_luma=p.cutoff_dark_luma,
        )
        self.sensor_size = (width, height)

    @property
    def frames_seen(self) -> int:
        """Number of frames consumed so far."""
        return int(self._kernel.frames_seen)

    def hot_pixels(self) -> np.ndarray:
        """``(k, 2)`` array of the hot pixels' ``(x, y)``."""
        idx = np.asarray(self._kernel.hot_pixels(), dtype=np.int64)
        w = self.sensor_size[0]
        return np.stack([idx % w, idx // w], axis=1) if idx.size else np.zeros((0, 2), np.int64)

    def process(self, frames: Any, timestamps_us: Any) -> np.ndarray:
        """Feed frames (see :func:`emulate_dvs`) and return the events they make, sorted by
        time. The first frame ever fed only sets the pixels' state; each batch must continue in
        time after the previous one."""
        return push_frames(self._kernel, frames, timestamps_us, self.sensor_size, "this sensor is")

    def process_frame(
        self,
        frame: Any,
        t_us: int,
        patches: list[tuple[int, int, Any, Any]] = (),  # type: ignore[assignment]
    ) -> np.ndarray:
        """Feed one ``(h, w)`` linear gray frame (float, 0-255 scale) at ``t_us``, with
        sub-frame samples, and return the events since the previous frame, sorted by time.

        ``patches``: ``(x0, y0, times_us, values)`` each — a rectangle of the sensor whose luma
        is also known at ``times_us`` (strictly increasing, strictly between the previous frame
        and this one), ``values`` of shape ``(len(times_us), h, w)``. Inside a patch each pixel's
        response moves linearly from sample to sample; patches must not overlap. The first
        frame takes none.

        Raises:
            SimulationError: a frame that is not real intensities or of the wrong size, a time
                not after the previous frame's or past 2^62 µs, patches that are not
                four-element tuples, off the sensor, overlapping, with times that are not whole
                microseconds >= 0 or not strictly between the frames, or with bad values.
        """
        img = _intensities("a frame", frame)
        if img.shape != (self.sensor_size[1], self.sensor_size[0]):
            raise SimulationError(
                f"a frame of shape {img.shape}; this sensor needs "
                f"({self.sensor_size[1]}, {self.sensor_size[0]})"
            )
        subs = []
        for k, patch in enumerate(_patch_list(patches)):
            x0, y0, times, values = patch
            if not all(
                isinstance(c, (int, np.integer)) and not isinstance(c, bool) and c >= 0
                for c in (x0, y0)
            ):
                raise SimulationError(
                    f"a patch's corner must be whole pixels >= 0, got ({x0!r}, {y0!r})"
                )
            ts = _patch_times(k, times)
            v = _intensities(f"sub-frame patch {k}'s values", values)
            if v.ndim != 3:
                raise SimulationError(f"sub-frame values must be (n, h, w), got {v.shape}")
            subs.append((int(x0), int(y0), ts, v))
        t = check_int_time(t_us)
        return np.asarray(self._kernel.push_float_samples(img, t, subs)).view(EVENT_DTYPE)


def _intensities(what: str, value: Any) -> np.ndarray:
    """``value`` as a contiguous ``float32`` array, if it holds real numbers."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError) as exc:  # a ragged nesting of lists
        raise SimulationError(f"{what} must be an array of intensities: {exc}") from exc
    kind = array.dtype.kind
    if kind not in "uif":
        raise SimulationError(f"{what} must be real intensities (0-255), got dtype {array.dtype}")
    return np.ascontiguousarray(array, dtype=np.float32)


def _patch_list(patches: Any) -> list[tuple[Any, Any, Any, Any]]:
    """``patches`` as a list of four-element tuples."""
    what = "patches must be a sequence of (x0, y0, times_us, values)"
    if isinstance(patches, (str, bytes, np.ndarray)):
        raise SimulationError(f"{what}, got {type(patches).__name__}")
    try:
        items = list(patches)
    except TypeError as exc:
        raise SimulationError(f"{what}, got {type(patches).__name__}") from exc
    for k, patch in enumerate(items):
        if isinstance(patch, (str, bytes)) or not _four(patch):
            raise SimulationError(f"{what}: patch {k} is {patch!r:.80}")
    return [tuple(patch) for patch in items]


def _four(patch: Any) -> bool:
    try:
        return len(patch) == 4
    except TypeError:
        return False


def _patch_times(k: int, times: Any) -> np.ndarray:
    """Patch ``k``'s times as ``uint64``, if each is a whole number of microseconds in
    ``[0, 2^64)`` (their order is the kernel's to check)."""
    where = f"sub-frame patch {k}: times_us"
    try:
        t = np.asarray(times)
    except (TypeError, ValueError, OverflowError) as exc:
        raise SimulationError(f"{where} must be whole microseconds: {exc}") from exc
    if t.ndim != 1:
        raise SimulationError(f"{where} must be 1-D, got shape {t.shape}")
    if len(t) == 0:
        return np.zeros(0, dtype=np.uint64)
    if t.dtype.kind not in "uif":
        raise SimulationError(f"{where} must be whole microseconds, got dtype {t.dtype}")
    return np.ascontiguousarray(whole_microseconds(t, lambda i: f"{where}: {t[i]}"))


def emulate_dvs(
    frames: Any,
    timestamps_us: Any,
    *,
    params: DvsParams | None = None,
    seed: int = 0,
) -> np.ndarray:
    """Turn frames into the events a DVS would give; events at frame size, sorted by time.

    Args:
        frames: ``(n, h, w)`` gray or ``(n, h, w, 3)`` BGR, ``uint8`` or float on the 0–255
            scale, or a sequence of such frames (all of one size). Render them at a high frame
            rate: motion between two frames is taken as linear in log intensity.
        timestamps_us: ``n`` strictly increasing times in microseconds, at most 2^62.
        params: sensor parameters (defaults: :class:`DvsParams`; :meth:`DvsParams.ideal` for a
            noiseless sensor).
        seed: draws thresholds, leak rates, hot pixels and noise; same seed, same events.

    Returns:
        Events of ``uavsnn.EVENT_DTYPE``, sorted by time; ties keep pixel order.

    Raises:
        SimulationError: no frames, frames of mixed sizes or bad shape, integer intensities
            above 255, non-finite or negative intensities, timestamps that are not one per
            frame and strictly increasing, or past 2^62 µs.
        ParameterError: impossible parameters or seed.
    """
    batch = as_frame_batch(frames)
    emulator = DvsEmulator(batch.size, params=params, seed=seed)
    return emulator.process(batch, timestamps_us)
