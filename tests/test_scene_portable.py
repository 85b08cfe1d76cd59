"""The scene renderer's arithmetic gives the same bits whichever kernels the machine picks:
products summed in a fixed order, transcendental functions in software, textures interpolated
without OpenCV (``uavsnn.scenes.portable``), so a synthetic dataset is the same build on every
machine."""

from __future__ import annotations

import math
import os
import platform
import subprocess
import sys
from collections.abc import Callable
from typing import Any

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uavsnn import ParameterError, _core
from uavsnn.scenes import portable

FUNCTIONS = [
    (portable.exp, np.exp, math.exp),
    (portable.sin, np.sin, math.sin),
    (portable.cos, np.cos, math.cos),
    (portable.arctan, np.arctan, math.atan),
]


@pytest.mark.parametrize(("ours", "numpys", "pythons"), FUNCTIONS)
def test_each_function_is_within_two_ulp_of_numpys(
    ours: Callable[[Any], np.ndarray],
    numpys: Callable[[Any], np.ndarray],
    pythons: Callable[[float], float],
) -> None:
    x = np.random.default_rng(0).uniform(-40.0, 40.0, 5000)
    got = ours(x)
    assert got.dtype == np.float64 and got.shape == x.shape
    np.testing.assert_array_max_ulp(got, numpys(x), maxulp=2)
    # And the C library's value, to a rounding.
    assert float(ours(np.array(1.0))) == pytest.approx(pythons(1.0), rel=2e-16)


def test_two_argument_functions_broadcast_as_numpy() -> None:
    y = np.linspace(-3.0, 3.0, 7)[:, None]
    x = np.linspace(-2.0, 2.5, 5)[None, :]
    got = portable.arctan2(y, x)
    assert got.shape == (7, 5)
    np.testing.assert_array_max_ulp(got, np.arctan2(y, x), maxulp=2)
    base = np.linspace(0.0, 1.0, 11, dtype=np.float32)
    powered = portable.power(base, 0.6)
    assert powered.shape == (11,) and powered.dtype == np.float64
    np.testing.assert_array_max_ulp(powered, np.power(base.astype(np.float64), 0.6), maxulp=2)
    assert portable.exp(np.empty((0, 3))).shape == (0, 3)
    assert portable.sin(0.5).shape == ()


@settings(max_examples=50, deadline=None)
@given(
    st.integers(1, 4),
    st.integers(1, 5),
    st.integers(0, 6),
    st.sampled_from([np.float32, np.float64]),
    st.integers(0, 2**32 - 1),
)
def test_matmul_adds_the_products_from_the_first(
    k: int, m: int, n: int, dtype: type, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, k)).astype(dtype)
    b = rng.normal(size=(k, m)).astype(dtype)
    got = portable.matmul(a, b)
    assert got.shape == (n, m) and got.dtype == dtype
    want = a[:, 0, None] * b[0]
    for j in range(1, k):
        want = want + a[:, j, None] * b[j]
    assert np.array_equal(got, want)
    tol = 1e-5 if dtype == np.float32 else 1e-12
    np.testing.assert_allclose(got, a @ b, rtol=tol, atol=tol)
    vector = portable.matmul(a, b[:, 0])
    assert vector.shape == (n,)
    np.testing.assert_allclose(vector, a @ b[:, 0], rtol=tol, atol=tol)


def test_bad_shapes_and_names_are_parameter_errors() -> None:
    with pytest.raises(ParameterError, match="matmul"):
        portable.matmul(np.ones((2, 3)), np.ones((2, 3)))
    with pytest.raises(ParameterError, match="matmul"):
        portable.matmul(np.ones((2, 0)), np.ones((0, 3)))
    with pytest.raises(ParameterError, match="op"):
        _core.portable_unary("log", np.ones(3))
    with pytest.raises(ParameterError, match="op"):
        _core.portable_binary("hypot", np.ones(3), np.ones(3))
    with pytest.raises(ParameterError, match="length"):
        _core.portable_binary("power", np.ones(3), np.ones(2))


def test_norm_is_the_root_of_the_squares_added_in_order() -> None:
    assert portable.norm([3.0, 4.0]) == 5.0
    v = np.array([0.1, 0.2, 0.3])
    assert portable.norm(v) == math.sqrt(0.1 * 0.1 + 0.2 * 0.2 + 0.3 * 0.3)
    assert portable.norm(np.zeros(3)) == 0.0


def test_interpolation_is_opencvs_to_float32_rounding() -> None:
    """The renderer's own interpolation has OpenCV's geometry and weights: at positions on
    OpenCV's 1/32-pixel grid (it rounds its linear weights to it) the two agree to a few
    float32 roundings."""
    rng = np.random.default_rng(0)
    grid = rng.random((13, 17), dtype=np.float32)
    size = (int(17 * 7.3), int(13 * 7.3))
    want = cv2.resize(grid, size, interpolation=cv2.INTER_CUBIC)
    got = portable.resize_cubic(grid, size, (size[0] - 5, size[1] - 3))
    assert got.shape == (size[1] - 3, size[0] - 5) and got.dtype == np.float32
    np.testing.assert_allclose(got, want[: size[1] - 3, : size[0] - 5], atol=1e-6)
    tex = rng.random((50, 60, 3), dtype=np.float32)
    for ox, oy in ((3.25, 4.5), (-2.125, 1.0), (10.40625, 20.96875), (30.0, 40.5)):
        shift = np.array([[1.0, 0.0, ox], [0.0, 1.0, oy]])
        flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
        want = cv2.warpAffine(tex, shift, (40, 30), flags=flags, borderMode=cv2.BORDER_REPLICATE)
        got = portable.shift_linear(tex, ox, oy, 40, 30)
        assert got.shape == (30, 40, 3) and got.dtype == np.float32
        np.testing.assert_allclose(got, want, atol=1e-6)
    flat = rng.random((32, 32), dtype=np.float32)
    mx = (np.round(rng.uniform(0, 32, (20, 25)) * 32) / 32 % 32).astype(np.float32)
    my = (np.round(rng.uniform(0, 32, (20, 25)) * 32) / 32 % 32).astype(np.float32)
    want = cv2.remap(flat, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
    np.testing.assert_allclose(portable.remap_linear(flat, mx, my, wrap=True), want, atol=1e-6)
    mx = (np.round(rng.uniform(-3, 63, (20, 25)) * 32) / 32).astype(np.float32)
    my = np.arange(20, dtype=np.float32)[:, None] + np.float32(2.5)
    want = cv2.remap(tex, mx, np.broadcast_to(my, mx.shape).copy(), cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE)  # fmt: skip
    got = portable.remap_linear(tex, mx, my, wrap=False)
    assert got.shape == (20, 25, 3)
    np.testing.assert_allclose(got, want, atol=1e-6)


#: Renders a short scene of each domain (the uav and the object scenes whose bits moved with
#: the kernels before) and prints a digest of each domain's frames and events; with the
#: argument "scalar", on OpenCV's scalar code.
RENDER = """
import hashlib
import sys
import cv2
import numpy as np
from uavsnn.dataset.synthetic import SceneSource, scene_spec, sim_render_size, synthetic_recording
from uavsnn.scenes import render
if sys.argv[1:] == ["scalar"]:
    cv2.setUseOptimized(False)
for source in (
    SceneSource("dvs", (240, 180), 500.0, 0.1, sensor=(240, 180)),
    SceneSource("sim", sim_render_size((240, 180)), None, 1.0, sensor=(240, 180)),
):
    digest = hashlib.sha256()
    for kind, seed in (("uav", 11), ("object", 12)):
        frames, _, _ = render(scene_spec(source, kind, seed), seed=seed)
        digest.update(np.ascontiguousarray(frames).tobytes())
        digest.update(synthetic_recording(source, kind, seed).recording.events.tobytes())
    print(source.domain, digest.hexdigest())
"""


def _dispatched_numpy_features() -> list[str]:
    """The SIMD targets NumPy dispatches to on this CPU (the names its version uses)."""
    try:
        from numpy._core import _multiarray_umath as umath  # NumPy 2
    except ImportError:  # pragma: no cover - NumPy 1.26
        from numpy.core import _multiarray_umath as umath  # type: ignore[no-redef]
    found = umath.__cpu_features__
    return [name for name in umath.__cpu_dispatch__ if found.get(name)]


def _digests(env: dict[str, str], *args: str) -> dict[str, str]:
    """Each domain's digest, rendered in a fresh process with ``env`` added."""
    proc = subprocess.run(
        [sys.executable, "-c", RENDER, *args],
        env={**os.environ, **env},
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    return dict(line.split() for line in proc.stdout.splitlines())


def test_scenes_render_the_same_bits_whichever_kernels_numpy_picks() -> None:
    """Each variant takes other kernels on this machine: OpenBLAS's baseline kernel for
    products (its Haswell and SkylakeX kernels rounded the sim frames differently), NumPy's
    baseline loops in place of the SIMD ones it dispatched to (its AVX2 float32 ``exp`` moved
    the dvs frames)."""
    variants: list[dict[str, str]] = []
    if platform.machine().lower() in ("x86_64", "amd64"):
        variants.append({"OPENBLAS_CORETYPE": "Prescott"})
    dispatched = _dispatched_numpy_features()
    if dispatched:
        variants.append({"NPY_DISABLE_CPU_FEATURES": " ".join(dispatched)})
    if not variants:
        pytest.skip("neither OpenBLAS's kernels nor NumPy's SIMD loops can be changed here")
    base = _digests({})
    assert set(base) == {"dvs", "sim"}
    for env in variants:
        assert _digests(env) == base, f"other bits with {env}"


def test_scenes_render_the_same_bits_on_opencvs_scalar_code() -> None:
    """The renderer interpolates its float32 textures itself (OpenCV's SIMD and scalar
    ``resize``, ``remap`` and ``warpAffine`` moved every dvs frame), and the sim domain's gamma
    is ``portable.power`` (OpenCV's ``pow`` moved every sim scene, and the sim and combined
    networks between an AMD EPYC's AVX2 and an Intel Xeon's AVX-512). A lens's blur
    (``cv2.filter2D``) is still OpenCV's."""
    assert _digests({}, "scalar") == _digests({})
