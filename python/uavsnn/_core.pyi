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
