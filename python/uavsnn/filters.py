"""Event filters of the paper's preprocessing (the work is done in ``rust/filters.rs``).

- :func:`denoise`: the background-activity filter, with the semantics of tonic's
  ``tonic.functional.denoise_numpy``: an event is kept iff one of its four neighbours
  (left, right, up, down) fired less than ``dt_us`` before it, earlier in the stream. As in
  tonic, a pixel that has not fired yet counts as having fired at ``t = 0``. Tonic sizes its
  grid from the events' bounding box, we use the recording's sensor; the two agree whenever
  that box is the sensor or every event has ``t ≥ dt_us``.
- :func:`downsample`: crop the sensor to the largest centred region with the target's aspect
  ratio, then scale coordinates down, ``x' = ⌊(x − x0)·W'/w⌋`` (same for ``y``); a target
  wider or taller than the sensor is refused. Events outside the crop are removed (that is
  what the crop is for); every event inside it is kept, with its time and polarity, in order,
  even when several land on one target pixel (a window takes the first of them).
"""

from __future__ import annotations

from typing import Any

from uavsnn import _core
from uavsnn._validate import check_sensor_size, int_param
from uavsnn.errors import ParameterError
from uavsnn.events import EVENT_DTYPE, Recording, packed_bytes, recording_from_engine

__all__ = ["check_target", "denoise", "downsample"]


def _recording(value: Any) -> Recording:
    if not isinstance(value, Recording):
        raise ParameterError(f"expected a Recording, got {type(value).__name__}")
    return value


def denoise(recording: Recording, dt_us: int) -> Recording:
    """The events of ``recording`` supported by a neighbour that fired less than ``dt_us`` µs
    before them (tonic's ``denoise``); ``metadata["denoise_dt_us"]`` records ``dt_us``.

    Raises:
        ParameterError: ``dt_us`` below 1 µs, NaN or not a whole number.
    """
    rec = _recording(recording)
    dt = int_param("dt_us", dt_us, 1, (1 << 63) - 1)
    width, height = rec.sensor_size
    keep = _core.denoise_mask(packed_bytes(rec.events), width, height, dt)
    return Recording(rec.events[keep], rec.sensor_size, {**rec.metadata, "denoise_dt_us": dt})


def check_target(sensor_size: tuple[int, int], target: Any) -> tuple[int, int]:
    """``target`` as a sensor size :func:`downsample` can take a ``sensor_size`` sensor to (a
    live source's ``downsample_to`` checks it here too).

    Raises:
        ParameterError: a malformed ``target``, or one wider or taller than ``sensor_size``.
    """
    tw, th = check_sensor_size(target)
    width, height = sensor_size
    if tw > width or th > height:
        larger = " and ".join(
            side for side, more in (("wider", tw > width), ("taller", th > height)) if more
        )
        raise ParameterError(
            f"a {width}x{height} sensor cannot be downsampled to {tw}x{th}: downsampling only "
            f"reduces (it crops and scales a larger sensor down), and {tw}x{th} is {larger} "
            f"than {width}x{height}"
        )
    return tw, th


def downsample(recording: Recording, target: tuple[int, int] = (240, 180)) -> Recording:
    """Crop ``recording`` to ``target``'s aspect ratio (centred) and scale its coordinates onto
    a ``target`` sensor, no wider and no taller than the recording's (the same size keeps
    every event where it is); ``metadata["downsampled_from"]`` records the original sensor size.

    Raises:
        ParameterError: a malformed ``target``, or one wider or taller than the recording's
            sensor (scaling up would make pixels the sensor never had).
    """
    rec = _recording(recording)
    tw, th = check_target(rec.sensor_size, target)
    width, height = rec.sensor_size
    packed = _core.downsample_events(packed_bytes(rec.events), width, height, tw, th)
    metadata = {**rec.metadata, "downsampled_from": [width, height]}
    # The engine checked the source and kept its order; every kept event lies on the target:
    # the result needs no second validation pass.
    return recording_from_engine(packed.view(EVENT_DTYPE), (tw, th), metadata)
