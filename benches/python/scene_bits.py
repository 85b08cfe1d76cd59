"""Do the synthetic scenes render the same bits whichever kernels the machine picks?

A synthetic build should be the same on every CPU (docs/dataset.md, "The same data on every
CPU"). This script renders a few scenes of each domain in fresh processes, each on other
kernels of this machine, and counts the frame values and events that differ from the
machine's own choice:

- ``openblas``: OpenBLAS's baseline kernel (``OPENBLAS_CORETYPE=Prescott``, x86-64 only);
- ``numpy``: NumPy's baseline loops in place of every SIMD target it dispatched to
  (``NPY_DISABLE_CPU_FEATURES``);
- ``opencv``: OpenCV's scalar code (``cv2.setUseOptimized(False)``);
- ``glibc``: the C library's variants of ``log``, ``exp``, ``sin``, ``cos``, ``pow`` ... for a
  CPU without AVX2 and FMA (``GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA``, Linux x86-64 with
  glibc only): what Python's ``math``, and the engine's ``f64::ln`` and ``exp``, call. Each
  variant also counts the C library's values on fixed arguments that differ, a control that
  shows whether the variant took effect at all.

The renderer takes its products and transcendental functions of arrays from
``uavsnn.scenes.portable``, so the first two should change nothing; the rest are left to OpenCV
and to the C library.

    python benches/python/scene_bits.py [--scenes 3] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

#: Renders the scenes (frames, then the recording's events) into the folder given.
RENDER = """
import sys
import cv2
import numpy as np
from uavsnn.dataset.synthetic import SceneSource, scene_spec, sim_render_size, synthetic_recording
from uavsnn.scenes import render
out, n, scalar = sys.argv[1], int(sys.argv[2]), sys.argv[3] == "1"
if scalar:
    cv2.setUseOptimized(False)
sources = {
    "dvs": SceneSource("dvs", (240, 180), 500.0, 0.2, sensor=(240, 180)),
    "sim": SceneSource("sim", sim_render_size((240, 180)), None, 1.0, sensor=(240, 180)),
}
for domain, source in sources.items():
    for i in range(n):
        kind, seed = ("uav", "object")[i % 2], 100 + i
        frames, _, _ = render(scene_spec(source, kind, seed), seed=seed)
        events = synthetic_recording(source, kind, seed).recording.events
        np.save(f"{out}/{domain}-{i}-frames.npy", frames)
        np.save(f"{out}/{domain}-{i}-events.npy", events)
# A control: the C library's functions on fixed arguments, as Python's math calls them
import math
xs = np.random.default_rng(0).uniform(-50.0, 50.0, 100_000).tolist()
fs = (math.sin, math.cos, lambda x: math.exp(x / 10), lambda x: math.log(abs(x) + 1e-3))
np.save(f"{out}/libc.npy", np.array([[f(x) for x in xs] for f in fs]))
# conv1's Gabor kernels, which the engine computes with the C library's sin, cos and exp
from uavsnn import Network
np.save(f"{out}/conv1.npy", Network().weights("conv1"))
"""


def dispatched_numpy_features() -> list[str]:
    """The SIMD targets NumPy dispatches to on this CPU (the names its version uses)."""
    try:
        from numpy._core import _multiarray_umath as umath
    except ImportError:  # NumPy 1.26
        from numpy.core import _multiarray_umath as umath  # type: ignore[no-redef]
    found = umath.__cpu_features__
    return [name for name in umath.__cpu_dispatch__ if found.get(name)]


def variants() -> dict[str, tuple[dict[str, str], bool]]:
    """Each variant's environment and whether it turns OpenCV's optimized code off."""
    out: dict[str, tuple[dict[str, str], bool]] = {}
    x86 = platform.machine().lower() in ("x86_64", "amd64")
    if x86:
        out["openblas"] = ({"OPENBLAS_CORETYPE": "Prescott"}, False)
    features = dispatched_numpy_features()
    if features:
        out["numpy"] = ({"NPY_DISABLE_CPU_FEATURES": " ".join(features)}, False)
    out["opencv"] = ({}, True)
    if x86 and platform.system() == "Linux" and platform.libc_ver()[0] == "glibc":
        out["glibc"] = ({"GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA"}, False)
    return out


def render_into(folder: Path, scenes: int, env: dict[str, str], scalar: bool) -> None:
    subprocess.run(
        [sys.executable, "-c", RENDER, str(folder), str(scenes), "1" if scalar else "0"],
        env={**os.environ, **env},
        check=True,
    )


def compare(base: Path, other: Path, scenes: int) -> dict[str, dict[str, int]]:
    """Per domain: frame values, frames and events that differ, and how many of each."""
    out: dict[str, dict[str, int]] = {}
    for domain in ("dvs", "sim"):
        tally = dict.fromkeys(("values", "values_differ", "frames", "frames_differ"), 0)
        tally.update(events=0, event_sets_differ=0, scenes=scenes)
        for i in range(scenes):
            a = np.load(base / f"{domain}-{i}-frames.npy")
            b = np.load(other / f"{domain}-{i}-frames.npy")
            differ = a != b
            tally["values"] += a.size
            tally["values_differ"] += int(differ.sum())
            tally["frames"] += len(a)
            tally["frames_differ"] += int(differ.reshape(len(a), -1).any(axis=1).sum())
            ea = np.load(base / f"{domain}-{i}-events.npy")
            eb = np.load(other / f"{domain}-{i}-events.npy")
            tally["events"] += len(ea)
            tally["event_sets_differ"] += int(ea.shape != eb.shape or not np.array_equal(ea, eb))
        out[domain] = tally
    return out


def compare_libc(base: Path, other: Path) -> dict[str, int]:
    """The control: how many of the C library's values (``sin``, ``cos``, ``exp``, ``log`` on
    fixed arguments, through Python's ``math``) differ between two renders' processes, and how
    many of conv1's Gabor weights (which the engine computes with them)."""
    a, b = np.load(base / "libc.npy"), np.load(other / "libc.npy")
    wa, wb = np.load(base / "conv1.npy"), np.load(other / "conv1.npy")
    return {
        "values": int(a.size),
        "values_differ": int((a != b).sum()),
        "conv1_weights": int(wa.size),
        "conv1_weights_differ": int((wa != wb).sum()),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=3, help="scenes per domain (default 3)")
    ap.add_argument("--json", action="store_true", help="print the tallies as JSON")
    args = ap.parse_args(argv)
    if not 1 <= args.scenes <= 50:
        ap.error("--scenes takes 1 to 50")
    results: dict[str, dict[str, dict[str, int]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "machine"
        base.mkdir()
        render_into(base, args.scenes, {}, False)
        for name, (env, scalar) in variants().items():
            folder = Path(tmp) / name
            folder.mkdir()
            render_into(folder, args.scenes, env, scalar)
            results[name] = compare(base, folder, args.scenes)
            results[name]["c_library"] = compare_libc(base, folder)
    if args.json:
        print(json.dumps(results, indent=2))
        return 0
    for name, per_domain in results.items():
        libc = per_domain.pop("c_library")
        print(
            f"{name:9s} the C library's sin, cos, exp, log: {libc['values_differ']:,} of "
            f"{libc['values']:,} values differ; conv1's Gabor weights: "
            f"{libc['conv1_weights_differ']} of {libc['conv1_weights']}"
        )
        for domain, t in per_domain.items():
            print(
                f"{name:9s} {domain}: {t['values_differ']:,} of {t['values']:,} frame values in "
                f"{t['frames_differ']} of {t['frames']} frames differ; "
                f"{t['event_sets_differ']} of {t['scenes']} scenes' events differ"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
