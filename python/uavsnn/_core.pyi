"""Type stubs of the compiled engine (`rust/python/`). Checked by `mypy.stubtest` in CI."""

from typing import final

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

def denoise_mask(
    events: npt.NDArray[np.uint8], width: int, height: int, dt_us: int
) -> npt.NDArray[np.bool_]: ...
def downsample_events(
    events: npt.NDArray[np.uint8],
    width: int,
    height: int,
    target_width: int,
    target_height: int,
) -> npt.NDArray[np.uint8]: ...

_WindowArrays = tuple[
    npt.NDArray[np.uint64],
    npt.NDArray[np.int64],
    npt.NDArray[np.uint64],
    npt.NDArray[np.uint16],
    npt.NDArray[np.uint16],
    npt.NDArray[np.int64],
]

MAX_WINDOWS: int

def window_step(length_us: int, overlap: float) -> int: ...
def make_windows(
    events: npt.NDArray[np.uint8],
    width: int,
    height: int,
    length_us: int,
    overlap: float = 0.0,
    median: bool = False,
    start_us: int | None = None,
    end_us: int | None = None,
) -> _WindowArrays: ...
def check_windows(
    width: int,
    height: int,
    length_us: int,
    t0: npt.NDArray[np.uint64],
    offsets: npt.NDArray[np.int64],
    t: npt.NDArray[np.uint64],
    x: npt.NDArray[np.uint16],
    y: npt.NDArray[np.uint16],
) -> None: ...
def window_frames(
    width: int,
    height: int,
    length_us: int,
    t0: npt.NDArray[np.uint64],
    offsets: npt.NDArray[np.int64],
    t: npt.NDArray[np.uint64],
    x: npt.NDArray[np.uint16],
    y: npt.NDArray[np.uint16],
    indices: npt.NDArray[np.int64],
) -> npt.NDArray[np.float32]: ...
def add_noise(
    width: int,
    height: int,
    length_us: int,
    t0: npt.NDArray[np.uint64],
    offsets: npt.NDArray[np.int64],
    t: npt.NDArray[np.uint64],
    x: npt.NDArray[np.uint16],
    y: npt.NDArray[np.uint16],
    n_preceding: npt.NDArray[np.int64],
    fraction: float,
    seed: int,
    first: int,
) -> tuple[_WindowArrays, npt.NDArray[np.float64]]: ...

# ---------------------------------------------------------------- network (issue 3)

def network_default_config() -> str: ...
def portable_unary(op: str, x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
def portable_binary(
    op: str, x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]: ...
def _panic_for_test() -> None: ...

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
    def state_bytes(self) -> int: ...
    def conv1_thresholds(self, n_in: int) -> list[float]: ...
    def run_window(
        self,
        t: npt.NDArray[np.uint64],
        x: npt.NDArray[np.uint16],
        y: npt.NDArray[np.uint16],
        t0: int,
        n_in: int | None = None,
    ) -> tuple[
        npt.NDArray[np.uint8],
        list[int],
        npt.NDArray[np.float32],
        npt.NDArray[np.uint8],
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

@final
class Pix2NvsKernel:
    """PIX2NVS fed batches of frames; returns packed 13-byte event records."""

    def __new__(
        cls,
        width: int,
        height: int,
        *,
        threshold: float,
        n_max: int,
        reference: str,
        block_size: int,
        adaptive: float,
        threshold_min: float,
        threshold_max: float,
        log_offset: float,
        output_size: tuple[int, int] | None = None,
        pooling: str = "strongest",
        compat: bool = False,
    ) -> Pix2NvsKernel: ...
    @property
    def output_size(self) -> tuple[int, int]: ...
    @property
    def frames_seen(self) -> int: ...
    def push_gray(
        self, frames: npt.NDArray[np.uint8], timestamps_us: npt.NDArray[np.uint64]
    ) -> npt.NDArray[np.uint8]: ...
    def push_bgr(
        self, frames: npt.NDArray[np.uint8], timestamps_us: npt.NDArray[np.uint64]
    ) -> npt.NDArray[np.uint8]: ...
    def push_float(
        self, frames: npt.NDArray[np.float32], timestamps_us: npt.NDArray[np.uint64]
    ) -> npt.NDArray[np.uint8]: ...

@final
class DvsKernel:
    """The DVS emulator fed batches of frames; returns packed 13-byte event records."""

    def __new__(
        cls,
        width: int,
        height: int,
        *,
        seed: int,
        threshold_on: float,
        threshold_off: float,
        threshold_sigma: float,
        refractory_us: float,
        leak_rate_hz: float,
        leak_spread_decades: float,
        shot_noise_rate_hz: float,
        shot_noise_bright_factor: float,
        hot_pixel_fraction: float,
        hot_pixel_rate_hz: float,
        cutoff_hz: float,
        linlog_threshold: float,
        cutoff_dark_luma: float = 20.0,
    ) -> DvsKernel: ...
    @property
    def size(self) -> tuple[int, int]: ...
    @property
    def frames_seen(self) -> int: ...
    def hot_pixels(self) -> list[int]: ...
    def push_gray(
        self, frames: npt.NDArray[np.uint8], timestamps_us: npt.NDArray[np.uint64]
    ) -> npt.NDArray[np.uint8]: ...
    def push_bgr(
        self, frames: npt.NDArray[np.uint8], timestamps_us: npt.NDArray[np.uint64]
    ) -> npt.NDArray[np.uint8]: ...
    def push_float(
        self, frames: npt.NDArray[np.float32], timestamps_us: npt.NDArray[np.uint64]
    ) -> npt.NDArray[np.uint8]: ...
    def push_float_samples(
        self,
        frame: npt.NDArray[np.float32],
        t_us: int,
        patches: list[tuple[int, int, npt.NDArray[np.uint64], npt.NDArray[np.float32]]],
    ) -> npt.NDArray[np.uint8]: ...

# ---------------------------------------------------------------- streaming (issue 6)

# (`final` comes from the network section's import above.)

PACKET_FORMATS: list[str]
RESTART_AFTER: int
MAX_HELD_BYTES: int
PUSH_SLICE: int

@final
class PacketDecoder:
    def __new__(cls, format: str, width: int, height: int) -> PacketDecoder: ...
    def decode(self, packet: bytes, arrival_us: int) -> npt.NDArray[np.uint8]: ...
    @property
    def format(self) -> str: ...
    @property
    def last_t(self) -> int | None: ...
    @property
    def restarts(self) -> int: ...
    @property
    def dropped(self) -> int: ...

DETECTION_RECORD_SIZE: int

@final
class StreamDetector:
    def __new__(
        cls,
        config_json: str,
        conv1: npt.NDArray[np.float32],
        conv2: npt.NDArray[np.float32],
        conv3: npt.NDArray[np.float32],
        window_us: int,
        overlap: float,
        start_us: int | None = None,
    ) -> StreamDetector: ...
    def push(self, raw: bytes) -> npt.NDArray[np.uint8]: ...
    def advance(self, t_us: int) -> npt.NDArray[np.uint8]: ...
    def flush(self) -> npt.NDArray[np.uint8]: ...
    def reset(self) -> None: ...
    @property
    def sensor_size(self) -> tuple[int, int]: ...
    @property
    def window_us(self) -> int: ...
    @property
    def overlap(self) -> float: ...
    @property
    def step_us(self) -> int: ...
    @property
    def events_seen(self) -> int: ...
    @property
    def windows_opened(self) -> int: ...
    @property
    def detections_emitted(self) -> int: ...
    @property
    def live_windows(self) -> int: ...
    @property
    def states_allocated(self) -> int: ...
    @property
    def last_t(self) -> int | None: ...

# signature (rust/python/signature.rs)
def rotor_defaults() -> dict[str, float | int]: ...

@final
class RotorSignature:
    def __new__(
        cls,
        x0: int,
        y0: int,
        width: int,
        height: int,
        f_min_hz: float,
        f_max_hz: float,
        bins: int,
        consistency: float,
        agree: float,
        threshold: float,
        min_pixels: int,
    ) -> RotorSignature: ...
    def update(self, events: npt.NDArray[np.uint8]) -> None: ...
    def estimate(self) -> tuple[float, float, int, int, int, int, bool]: ...
    def clear(self) -> None: ...
    @property
    def box(self) -> tuple[int, int, int, int]: ...
    @property
    def stats(self) -> tuple[int, int, int, int]: ...
    def count_rate(self, start_us: int, bin_us: int, bins: int) -> None: ...
    @property
    def rate(self) -> list[int]: ...
    @property
    def rate_swing(self) -> float: ...
    @property
    def state_bytes(self) -> int: ...

def rate_swing(counts: list[int]) -> float: ...
def spectrum_defaults() -> dict[str, float | int]: ...

@final
class RotorSpectrum:
    def __new__(
        cls,
        x0: int,
        y0: int,
        width: int,
        height: int,
        bin_us: int,
        span_us: int,
        f_min_hz: float,
        f_max_hz: float,
        freqs: int,
        min_events: int,
        agree: float,
        threshold: float,
        min_pixels: int,
    ) -> RotorSpectrum: ...
    def update(self, events: npt.NDArray[np.uint8]) -> None: ...
    def estimate(self) -> tuple[float, float, int, int, int, bool]: ...
    def power(self) -> tuple[list[float], list[float]]: ...
    def clear(self) -> None: ...
    @property
    def box(self) -> tuple[int, int, int, int]: ...
    @property
    def stats(self) -> tuple[int, int, int, int]: ...
    @property
    def state_bytes(self) -> int: ...
