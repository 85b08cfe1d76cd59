"""Many windows as the columns of ``uavsnn.windows.Windows`` that the network reads (docs/api.md),
without that class's checks: the tests hand the engine windows drawn for the reference, and
columns that ``Windows`` itself would refuse, to see the engine's own errors."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class WindowColumns:
    """Window ``i``'s spikes are ``t[offsets[i]:offsets[i+1]]`` (and the same range of ``x``,
    ``y``), as in ``uavsnn.windows.Windows``."""

    sensor_size: tuple[int, int]
    length_us: int
    t0: np.ndarray
    offsets: np.ndarray
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    n_preceding: np.ndarray

    @classmethod
    def of_parts(
        cls,
        parts: Sequence[tuple[np.ndarray, ...]],
        sensor_size: tuple[int, int],
        length_us: int,
        t0: Sequence[int],
        n_preceding: np.ndarray,
    ) -> WindowColumns:
        """The windows whose spikes are ``(t, x, y, ...)`` of each part, in order."""
        counts = [len(p[0]) for p in parts]
        return cls(
            sensor_size=sensor_size,
            length_us=length_us,
            t0=np.array(t0, dtype=np.uint64),
            offsets=np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
            t=np.concatenate([p[0] for p in parts]).astype(np.uint64),
            x=np.concatenate([p[1] for p in parts]).astype(np.uint16),
            y=np.concatenate([p[2] for p in parts]).astype(np.uint16),
            n_preceding=n_preceding,
        )

    def __len__(self) -> int:
        return len(self.t0)

    def spikes(self, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Window ``i``'s input spikes ``(t, x, y)``."""
        part = slice(self.offsets[i], self.offsets[i + 1])
        return self.t[part], self.x[part], self.y[part]

    def n_in(self, config: dict, i: int) -> int | None:
        """PENT's N_in of window ``i`` for the reference: ``None`` means its own spike count."""
        return int(self.n_preceding[i]) if config["pent"]["estimate"] == "preceding" else None
