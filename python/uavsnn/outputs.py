"""What the network gives back: its spikes' dtypes, one window's trace, many windows'
inference and a layer's training report, with the columns of windows it reads.

Every name here is also in :mod:`uavsnn.network`, whose :class:`~uavsnn.network.Network` makes
them. A spike's times are absolute microseconds; its position is its layer's map, row and
column; a detection adds where it lies on the sensor (docs/model.md §5)::

    result = net.infer(windows)                   # an Inference
    result.detections["x0"]                       # the left side of every detection's box
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from uavsnn._validate import listed
from uavsnn.errors import ParameterError, ShapeError

__all__ = [
    "CONV_LAYERS",
    "DETECTION_DTYPE",
    "LAYERS",
    "SPIKE_DTYPE",
    "WINDOW_DETECTION_DTYPE",
    "WINDOW_SPIKE_DTYPE",
    "Inference",
    "TrainReport",
    "WindowTrace",
    "WindowsLike",
]

LAYERS: tuple[str, ...] = ("conv1", "pool1", "conv2", "pool2", "conv3")
"""The network's layers, in order."""

CONV_LAYERS: tuple[str, ...] = ("conv1", "conv2", "conv3")
"""The layers that have weights (and can be trained)."""

SPIKE_DTYPE = np.dtype([("t", "<u8"), ("map", "<u2"), ("row", "<u2"), ("col", "<u2"), ("v", "<f4")])
"""A spike (or a winner): time, map, position, potential at the firing time (0 for pools)."""

WINDOW_SPIKE_DTYPE = np.dtype([("window", "<i8"), *SPIKE_DTYPE.descr])
"""A spike of one of many windows."""

DETECTION_DTYPE = np.dtype(
    [
        ("t", "<u8"),
        ("map", "<u2"),
        ("row", "<u2"),
        ("col", "<u2"),
        ("x", "<f4"),
        ("y", "<f4"),
        ("x0", "<u2"),
        ("y0", "<u2"),
        ("x1", "<u2"),
        ("y1", "<u2"),
    ]
)
"""A conv3 spike as a detection: time, map, conv3 position, the centre ``x, y`` of its receptive
field and the box ``x0, y0, x1, y1`` (half-open) of the input spikes that it saw, all in sensor
coordinates where pixel ``(x, y)`` covers ``[x, x+1) x [y, y+1)`` (docs/model.md §5)."""

WINDOW_DETECTION_DTYPE = np.dtype([("window", "<i8"), *DETECTION_DTYPE.descr])
"""A detection of one of many windows."""


class WindowsLike(Protocol):
    """What :meth:`~uavsnn.network.Network.infer` and
    :meth:`~uavsnn.network.Network.train_layer` read from a ``uavsnn.windows.Windows``."""

    @property
    def sensor_size(self) -> tuple[int, int]:
        """``(width, height)`` of the sensor."""
        ...

    @property
    def length_us(self) -> int:
        """Window length in microseconds."""
        ...

    @property
    def t0(self) -> np.ndarray:
        """``(n,)`` window starts."""
        ...

    @property
    def offsets(self) -> np.ndarray:
        """``(n + 1,)``: window ``i``'s spikes are ``offsets[i]:offsets[i + 1]``."""
        ...

    @property
    def t(self) -> np.ndarray:
        """Spike times (absolute, sorted within each window)."""
        ...

    @property
    def x(self) -> np.ndarray:
        """Spike columns."""
        ...

    @property
    def y(self) -> np.ndarray:
        """Spike rows."""
        ...

    @property
    def n_preceding(self) -> np.ndarray:
        """``(n,)`` distinct active pixels in ``[t0 - L, t0)``."""
        ...


@dataclass(frozen=True)
class WindowTrace:
    """Everything one window did in inference mode (:meth:`~uavsnn.network.Network.run_window`).

    Each layer's spikes are a structured array of :data:`SPIKE_DTYPE` sorted by
    ``(t, map, row, col)``; ``thresholds`` are conv1's per-map thresholds of the window;
    ``detections`` (:data:`DETECTION_DTYPE`) are the conv3 spikes, sorted like the spikes.
    """

    conv1: np.ndarray
    pool1: np.ndarray
    conv2: np.ndarray
    pool2: np.ndarray
    conv3: np.ndarray
    thresholds: np.ndarray
    detections: np.ndarray

    def __getitem__(self, layer: str) -> np.ndarray:
        """The spikes of ``layer`` (``"conv1"`` ... ``"conv3"``)."""
        if layer not in LAYERS:
            raise ParameterError(f"layer must be one of {', '.join(LAYERS)}, got {layer!r}")
        spikes: np.ndarray = getattr(self, layer)
        return spikes

    @property
    def layers(self) -> dict[str, np.ndarray]:
        """Every layer's spikes by name."""
        return {name: self[name] for name in LAYERS}

    @property
    def counts(self) -> np.ndarray:
        """Spikes per layer, ``(5,)`` int64."""
        return np.array([len(self[name]) for name in LAYERS], dtype=np.int64)


@dataclass(frozen=True)
class Inference:
    """What :meth:`~uavsnn.network.Network.infer` found, per window (``n`` windows).

    - ``detected`` ``(n,)`` bool: at least ``min_detections`` conv3 spikes.
    - ``counts`` ``(n, 5)`` int64: spikes per layer (conv1, pool1, conv2, pool2, conv3).
    - ``first_detection_t`` ``(n,)`` uint64: time of the first conv3 spike (0 if none).
    - ``detections``: every conv3 spike, :data:`WINDOW_DETECTION_DTYPE`, by window then time.
    - ``thresholds`` ``(n, maps)`` float32: conv1's thresholds per window.
    - ``spikes``: with ``spikes=True``, each layer's spikes (:data:`WINDOW_SPIKE_DTYPE`, by
      window then ``(t, map, row, col)``); else ``None``.
    """

    detected: np.ndarray
    counts: np.ndarray
    first_detection_t: np.ndarray
    detections: np.ndarray
    thresholds: np.ndarray
    spikes: dict[str, np.ndarray] | None = None

    def __len__(self) -> int:
        """Number of windows."""
        return len(self.detected)

    @classmethod
    def concatenate(cls, parts: Iterable[Inference]) -> Inference:
        """The inference of consecutive runs of windows as one: ``parts[k]``'s windows follow
        those of ``parts[k - 1]``, and the ``window`` field of its detections and spikes counts
        from the windows of the parts before it. ``spikes`` is kept only when every part has
        it. At least one part; ``parts`` may be any iterable (a list, a generator).

        Raises:
            ShapeError: no parts, or parts of different map counts.
            ParameterError: ``parts`` is not an iterable of :class:`Inference`.
        """
        parts = listed(parts, "Inference")
        for i, part in enumerate(parts):
            if not isinstance(part, Inference):
                raise ParameterError(f"parts[{i}] is a {type(part).__name__}, not an Inference")
        if not parts:
            raise ShapeError("concatenate needs at least one Inference")
        maps = {p.thresholds.shape[1:] for p in parts}
        if len(maps) != 1:
            raise ShapeError(f"parts have thresholds of different shapes: {sorted(maps)}")
        starts = np.cumsum([0] + [len(p) for p in parts[:-1]])

        def renumbered(rows: list[np.ndarray]) -> np.ndarray:
            out = np.concatenate(rows)
            out["window"] += np.repeat(starts, [len(r) for r in rows])
            return out

        spikes = None
        if all(p.spikes is not None for p in parts):
            layers = parts[0].spikes or {}
            spikes = {name: renumbered([(p.spikes or {})[name] for p in parts]) for name in layers}
        return cls(
            detected=np.concatenate([p.detected for p in parts]),
            counts=np.concatenate([p.counts for p in parts]),
            first_detection_t=np.concatenate([p.first_detection_t for p in parts]),
            detections=renumbered([p.detections for p in parts]),
            thresholds=np.concatenate([p.thresholds for p in parts]),
            spikes=spikes,
        )


@dataclass(frozen=True)
class TrainReport:
    """What :meth:`~uavsnn.network.Network.train_layer` did.

    ``convergence`` is ``C = mean(w (1 - w))`` of the trained layer after each window (it falls
    towards 0 as weights settle at 0 or 1); ``a_plus`` the potentiation rate used for each
    window; ``winners`` the number of kernel updates made.
    """

    layer: str
    convergence: list[float]
    a_plus: list[float]
    windows_seen: int
    winners: int
