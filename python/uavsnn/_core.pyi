"""Type stubs of the compiled engine (`rust/python/`). Checked by `mypy.stubtest` in CI."""

import numpy as np
import numpy.typing as npt

__version__: str

def validate_events(
    events: npt.NDArray[np.uint8],
    width: int,
    height: int,
    previous_t: int | None = None,
) -> int: ...

# ---------------------------------------------------------------- windows and filters (issue 2)

# ---------------------------------------------------------------- network (issue 3)

from typing_extensions import final  # noqa: E402

def network_default_config() -> str: ...

_SpikeColumns = tuple[
    npt.NDArray[np.uint64],
    npt.NDArray[np.uint16],
    npt.NDArray[np.uint16],
    npt.NDArray[np.uint16],
    npt.NDArray[np.float32],
]

@final
class NetworkCore:
    def __new__(cls, config_json: str, seed: int) -> NetworkCore: ...
    def config_json(self) -> str: ...
    def shapes(self) -> list[tuple[str, tuple[int, int, int]]]: ...
    def weights(self, layer: str) -> npt.NDArray[np.float32]: ...
    def set_weights(self, layer: str, w: npt.NDArray[np.float32]) -> None: ...
    def conv1_thresholds(self, n_in: int) -> list[float]: ...
    def run_window(
        self,
        t: npt.NDArray[np.uint64],
        x: npt.NDArray[np.uint16],
        y: npt.NDArray[np.uint16],
        t0: int,
        n_in: int | None = None,
    ) -> tuple[
        list[_SpikeColumns], npt.NDArray[np.float32], tuple[npt.NDArray[np.generic], ...]
    ]: ...
    def stdp_step(
        self,
        layer: str,
        t: npt.NDArray[np.uint64],
        x: npt.NDArray[np.uint16],
        y: npt.NDArray[np.uint16],
        t0: int,
        n_in: int | None = None,
        a_plus: float | None = None,
        a_minus: float | None = None,
    ) -> _SpikeColumns: ...
    def infer(
        self,
        sensor_size: tuple[int, int],
        length_us: int,
        t0: npt.NDArray[np.uint64],
        offsets: npt.NDArray[np.int64],
        t: npt.NDArray[np.uint64],
        x: npt.NDArray[np.uint16],
        y: npt.NDArray[np.uint16],
        n_preceding: npt.NDArray[np.int64],
        threads: int | None = None,
        record: bool = False,
    ) -> tuple[
        npt.NDArray[np.int64],
        npt.NDArray[np.float32],
        tuple[npt.NDArray[np.generic], ...],
        tuple[tuple[npt.NDArray[np.generic], ...], ...] | None,
    ]: ...
    def train_layer(
        self,
        layer: str,
        sensor_size: tuple[int, int],
        length_us: int,
        t0: npt.NDArray[np.uint64],
        offsets: npt.NDArray[np.int64],
        t: npt.NDArray[np.uint64],
        x: npt.NDArray[np.uint16],
        y: npt.NDArray[np.uint16],
        n_preceding: npt.NDArray[np.int64],
        epochs: int = 1,
        seed: int = 0,
        shuffle: bool = True,
        callback: object | None = None,
        every: int = 64,
    ) -> tuple[list[float], list[float], int, int]: ...
    def save(self, path: str) -> None: ...
    @staticmethod
    def load(path: str) -> NetworkCore: ...
    def same_as(self, other: NetworkCore) -> bool: ...
    def copy(self) -> NetworkCore: ...

# ---------------------------------------------------------------- simulation (issue 4)

# ---------------------------------------------------------------- streaming (issue 6)
