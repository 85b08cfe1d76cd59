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

# ---------------------------------------------------------------- simulation (issue 4)

# ---------------------------------------------------------------- streaming (issue 6)

from typing import final  # noqa: E402 (this section's own import)

PACKET_FORMATS: list[str]

@final
class PacketDecoder:
    def __new__(cls, format: str, width: int, height: int) -> PacketDecoder: ...
    def decode(self, packet: bytes, arrival_us: int) -> npt.NDArray[np.uint8]: ...
    @property
    def format(self) -> str: ...
    @property
    def last_t(self) -> int | None: ...
