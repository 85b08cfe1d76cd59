"""The "sim" domain: PIX2NVS (Bi & Andreopoulos, ICIP 2017), the simulator Kirkland et al. used.

The model, run in Rust (``rust/sim/pix2nvs.rs``), follows PIX2NVS's released code
(github.com/PIX2NVS/PIX2NVS, ``generate_events.cpp`` and ``print_event.cpp``):

1. luma ``Y`` by BT.601 from BGR, in floating point, and ``B = ln(Y + log_offset)``;
2. local inhibition: in each ``block_size``×``block_size`` block only the pixel with the largest
   change ``|B - R|`` from its reference ``R`` may emit;
3. if ``|ΔB| > θ`` it emits ``min(⌊|ΔB|/θ⌋, n_max)`` events of the change's sign, event ``e`` at
   ``t_prev + e·θ/|ΔB|·(t - t_prev)`` (``e = 1, 2, …``): where a linear change would cross
   ``R ± e·θ``;
4. the reference is updated by one of PIX2NVS's three modes (``-r``): ``"frame"`` (1, copy the
   frame), ``"event_copy"`` (2, copy it only where events were emitted) or
   ``"event_increment"`` (3, move it by the emitted ``n·θ``, keeping the remainder);
5. adaptive threshold (``-a``): the competing pixel's ``θ`` is multiplied by ``1 + adaptive``
   after emitting and by ``1 - adaptive`` otherwise.

Defaults are PIX2NVS's own — ``θ = 0.4``, ``n_max = 5``, reference ``"frame"``, block 1 (no
inhibition) — except ``adaptive = 0`` (PIX2NVS's worked example; its compiled-in 0.05 has no
floor, and the thresholds of quiet pixels decay until compression noise floods the
background; optional bounds ``threshold_min``/``threshold_max`` make it usable). Departures
from the released code (an offset inside the log, updates at the competing pixel rather than
the block's corner, mode 3 starting from the first frame, clipped edge blocks, top-left origin,
time-sorted output) are listed and argued in ``docs/simulation.md``.

``Pix2NvsParams.original()`` (``compat=True``, the command line's ``--pix2nvs-compat``) instead
reproduces the released program's events exactly, quirks included: its luma read from the
frame's BMP bytes two bytes late (the red of pixel ``x`` weighted as blue, the blue and green of
pixel ``x + 1`` as green and red), ``log(Y)`` without an offset, updates of the block's top-left
pixel in modes 2 and 3 and for the adaptive threshold, mode 3 starting from a zero reference,
its adaptive step of 0.05 and its event times; frames must then be 8-bit and a whole number of
blocks. ``docs/simulation.md`` gives the details.

PIX2NVS is deterministic: the ``seed`` argument exists so that both simulators share one
signature, and is recorded with the recording; it changes nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any, Literal

import numpy as np

from uavsnn import _core
from uavsnn._state import EngineState
from uavsnn.errors import ParameterError
from uavsnn.sim.checks import check_choice, check_int, check_real, check_seed, check_size
from uavsnn.sim.frames import as_frame_batch, push_frames

__all__ = ["Pix2NvsParams", "Pix2NvsSimulator", "pix2nvs"]

ReferenceMode = Literal["frame", "event_copy", "event_increment"]
PoolingMode = Literal["strongest", "all"]

REFERENCE_MODES: tuple[str, ...] = ("frame", "event_copy", "event_increment")
POOLING_MODES: tuple[str, ...] = ("strongest", "all")


@dataclass(frozen=True)
class Pix2NvsParams:
    """Parameters of PIX2NVS, validated on construction (:class:`~uavsnn.ParameterError`).

    Attributes:
        threshold: initial threshold ``θ`` on the change of natural-log luma (PIX2NVS ``-f``,
            default 0.4; PIX2NVS accepts 0.2–0.7, any value > 0 is accepted here).
        n_max: at most this many events per pixel per frame (PIX2NVS ``-n``, default 5;
            PIX2NVS accepts 1–5, here 1–127).
        reference: ``"frame"``, ``"event_copy"`` or ``"event_increment"`` (PIX2NVS ``-r`` 1, 2,
            3; default ``"frame"``).
        block_size: side of the local-inhibition blocks, 1 for none (PIX2NVS ``-b``, default 1;
            PIX2NVS accepts 1, 2, 4, here 1–256).
        adaptive: adaptive-threshold step, 0 to disable (PIX2NVS ``-a``; PIX2NVS accepts 0–0.1
            and compiles in 0.05, here [0, 1) with default 0 as in PIX2NVS's worked example
            ``-a 0``: 0.05 without a floor lets quiet pixels' thresholds decay as
            ``0.95**frames`` until compression noise floods the background).
        threshold_min: floor of the adaptive threshold (not in PIX2NVS; default 0, none).
        threshold_max: ceiling of the adaptive threshold (not in PIX2NVS; default ``None``,
            none).
        log_offset: added to luma before the log so black pixels stay finite (not in PIX2NVS,
            which takes ``log(Y)``; default 1). Not used with ``compat``.
        compat: reproduce the released PIX2NVS program's events exactly, quirks included (see
            the module's docs and :meth:`original`); needs ``threshold_min`` 0 and no
            ``threshold_max``.
    """

    threshold: float = 0.4
    n_max: int = 5
    reference: ReferenceMode = "frame"
    block_size: int = 1
    adaptive: float = 0.0
    threshold_min: float = 0.0
    threshold_max: float | None = None
    log_offset: float = 1.0
    compat: bool = False

    @classmethod
    def original(cls, **overrides: Any) -> Pix2NvsParams:
        """The released PIX2NVS program as it runs: ``compat=True`` and its compiled-in
        defaults (``θ = 0.4``, ``n_max = 5``, ``-r 1``, block 1, ``adaptive = 0.05``);
        ``overrides`` set its options (``threshold``, ``n_max``, ``reference``,
        ``block_size``, ``adaptive``).

        Raises:
            ParameterError: a name that is no option (or ``compat``), a value out of its
                range, or one the released program cannot take.
        """
        options = [f.name for f in fields(cls) if f.name != "compat"]
        unknown = sorted(set(overrides) - set(options))
        if unknown:
            raise ParameterError(
                f"Pix2NvsParams.original has no option {unknown[0]!r} (it is the released "
                f"program, compat=True): its options are {', '.join(options)}"
            )
        return cls(**{"adaptive": 0.05, **overrides, "compat": True})

    def __post_init__(self) -> None:
        check_real("threshold", self.threshold, low=0.0, low_open=True)
        check_int("n_max", self.n_max, low=1, high=127)
        check_choice("reference", self.reference, REFERENCE_MODES)
        check_int("block_size", self.block_size, low=1, high=256)
        check_real("adaptive", self.adaptive, low=0.0, high=1.0, high_open=True)
        check_real("threshold_min", self.threshold_min, low=0.0, high=float(self.threshold))
        if self.threshold_max is not None:
            check_real("threshold_max", self.threshold_max, low=float(self.threshold))
        check_real("log_offset", self.log_offset, low=0.0, low_open=True)
        if not isinstance(self.compat, bool):
            raise ParameterError(f"compat must be True or False, got {self.compat!r}")
        if self.compat and (self.threshold_min != 0.0 or self.threshold_max is not None):
            raise ParameterError(
                "PIX2NVS has no bounds on its adaptive threshold: with compat, leave "
                "threshold_min at 0 and threshold_max unset"
            )


class Pix2NvsSimulator(EngineState):
    """PIX2NVS fed frames in batches, keeping its state (references, thresholds) between calls,
    so that a long video runs in bounded memory. It cannot be copied nor pickled, and refuses
    every batch after one stopped part way, as :class:`~uavsnn.sim.DvsEmulator`.

    Args:
        frame_size: ``(width, height)`` of the frames it will be fed.
        params: model parameters (defaults: PIX2NVS's).
        output_size: pool the events onto a smaller ``(width, height)`` sensor; ``None`` keeps
            them at frame size.
        pooling: with ``output_size``, ``"strongest"`` keeps per output pixel and frame only the
            events of the source pixel with the largest change in its area (PIX2NVS's
            local-inhibition rule, so at most ``n_max`` events per pixel per frame, as a native
            sensor of that size); ``"all"`` keeps every event and scales its coordinates.
    """

    def __init__(
        self,
        frame_size: tuple[int, int],
        *,
        params: Pix2NvsParams | None = None,
        output_size: tuple[int, int] | None = None,
        pooling: PoolingMode = "strongest",
    ) -> None:
        self.params = params if params is not None else Pix2NvsParams()
        if not isinstance(self.params, Pix2NvsParams):
            raise ParameterError(f"params must be Pix2NvsParams, got {type(self.params).__name__}")
        width, height = check_size(frame_size, "frame_size")
        out = None if output_size is None else check_size(output_size, "output_size")
        check_choice("pooling", pooling, POOLING_MODES)
        p = self.params
        self._kernel = _core.Pix2NvsKernel(
            width,
            height,
            threshold=p.threshold,
            n_max=p.n_max,
            reference=p.reference,
            block_size=p.block_size,
            adaptive=p.adaptive,
            threshold_min=p.threshold_min,
            threshold_max=math.inf if p.threshold_max is None else p.threshold_max,
            log_offset=p.log_offset,
            output_size=out,
            pooling=pooling,
            compat=p.compat,
        )
        self.frame_size = (width, height)

    @property
    def output_size(self) -> tuple[int, int]:
        """``(width, height)`` of the events it writes."""
        w, h = self._kernel.output_size
        return int(w), int(h)

    @property
    def frames_seen(self) -> int:
        """Number of frames consumed so far."""
        return int(self._kernel.frames_seen)

    def process(self, frames: Any, timestamps_us: Any) -> np.ndarray:
        """Feed frames (see :func:`pix2nvs`) and return the events they make, sorted by time.

        The first frame ever fed only sets the reference. Each batch must continue in time
        after the previous one.
        """
        return push_frames(
            self._kernel, frames, timestamps_us, self.frame_size, "this simulator takes"
        )


def pix2nvs(
    frames: Any,
    timestamps_us: Any,
    *,
    params: Pix2NvsParams | None = None,
    seed: int = 0,
) -> np.ndarray:
    """Turn frames into events with PIX2NVS; events at frame size, sorted by time (stable).

    Args:
        frames: ``(n, h, w)`` gray or ``(n, h, w, 3)`` BGR, ``uint8`` or float on the 0–255
            scale, or a sequence of such frames (all of one size).
        timestamps_us: ``n`` strictly increasing times in microseconds, at most 2^62.
        params: model parameters (defaults: PIX2NVS's own).
        seed: accepted for a signature shared with :func:`~uavsnn.sim.emulate_dvs`; PIX2NVS is
            deterministic and does not use it.

    Returns:
        Events of ``uavsnn.EVENT_DTYPE``; the first frame makes none.

    Raises:
        SimulationError: no frames, frames of mixed sizes or bad shape, integer intensities
            above 255, non-finite or negative intensities, timestamps that are not one per
            frame and strictly increasing, or past 2^62 µs.
        ParameterError: impossible parameters or seed.
    """
    check_seed(seed)
    batch = as_frame_batch(frames)
    sim = Pix2NvsSimulator(batch.size, params=params)
    return sim.process(batch, timestamps_us)
