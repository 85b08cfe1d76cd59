"""The event camera's optics on the command line: ``--lens F_NUMBER``, ``--focus-m M`` and
``--fov LO,HI``, as ``uavsnn dataset build``, ``uavsnn dataset preview`` and ``uavsnn simulate
--scene`` take them (and ``benches/python/false_alarms.py``)."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from uavsnn.errors import ParameterError, SimulationError

if TYPE_CHECKING:
    from uavsnn.scenes.camera import Lens
    from uavsnn.scenes.spec import SceneSpec

__all__ = ["add_camera_options", "fov_option", "lens_option", "through_lens"]


def add_camera_options(parser: argparse.ArgumentParser, scope: str) -> None:
    """``--lens F_NUMBER``, ``--focus-m M`` and ``--fov LO,HI`` on ``parser`` (read back with
    :func:`lens_option` and :func:`fov_option`); ``scope`` says what they apply to in the help
    ("dvs", "--scene")."""
    parser.add_argument(
        "--lens",
        type=float,
        metavar="F_NUMBER",
        help=f"{scope}: scenes seen through a lens of this f-number (e.g. 1.4) on the sensor's "
        "pixel pitch, focused at --focus-m: near objects blur as a real camera's do (default: "
        "a pinhole, every range sharp; docs/dataset.md, 'The lens')",
    )
    parser.add_argument(
        "--focus-m",
        type=float,
        metavar="M",
        help="with --lens: the range the lens is focused at, in metres (default: infinity)",
    )
    parser.add_argument(
        "--fov",
        metavar="LO,HI",
        help=f"{scope}: draw each scene's horizontal field of view from LO to HI degrees (or "
        "one value) instead of 45-70: a narrower view is a longer lens on the same sensor",
    )


def lens_option(f_number: float | None, focus_m: float | None) -> Lens | None:
    """The lens of ``--lens F_NUMBER [--focus-m M]`` (``None`` without ``--lens``).

    Raises:
        ParameterError: ``--focus-m`` without ``--lens``, or a lens out of range.
    """
    if f_number is None:
        if focus_m is not None:
            raise ParameterError("--focus-m sets the focus of --lens; give --lens too")
        return None
    from uavsnn.scenes.camera import Lens

    try:
        return Lens(f_number, focus_m)
    except SimulationError as exc:
        raise ParameterError(str(exc)) from exc


def fov_option(text: str | None) -> tuple[float, float] | None:
    """``--fov LO,HI`` or ``--fov DEG`` as ``(low, high)`` degrees (``None`` without it;
    the range is checked where it is used, :func:`uavsnn.scenes.sampler.fov_range`)."""
    if text is None:
        return None
    parts = text.split(",")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) not in (1, 2):
        raise ParameterError(f"--fov takes LO,HI or one value in degrees, got {text!r}")
    return (values[0], values[-1])


def through_lens(spec: SceneSpec, lens: Lens | None, sensor: tuple[int, int]) -> SceneSpec:
    """``spec`` seen through ``lens`` (:meth:`uavsnn.scenes.Lens.on`; unchanged without one) on
    ``sensor``.

    Raises:
        ParameterError: no pixel pitch is known for ``sensor`` (give ``--size`` or ``--sensor``
            of a known camera).
    """
    if lens is None:
        return spec
    try:
        return lens.on(spec, sensor)
    except SimulationError as exc:
        raise ParameterError(str(exc)) from exc
