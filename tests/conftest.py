"""Shared fixtures and hypothesis profiles.

Profiles: ``ci`` (the default, bounded for a 2-core machine) and ``dev`` (more examples); pick
one with ``UAVSNN_HYPOTHESIS_PROFILE``.
"""

from __future__ import annotations

import csv
import errno
import importlib.util
import io
import os
import signal
import subprocess
import sys
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci", max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile("dev", max_examples=300, deadline=None)
settings.load_profile(os.environ.get("UAVSNN_HYPOTHESIS_PROFILE", "ci"))

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
BENCHES = Path(__file__).resolve().parents[1] / "benches" / "python"

#: The small sensor of the streaming tests, and a network on it whose conv3 fires often.
SMALL_SENSOR = (40, 30)


def small_config(estimate: str = "preceding") -> dict[str, Any]:
    """A 40x30 network whose conv3 fires often, PENT on."""
    return {
        "width": SMALL_SENSOR[0],
        "height": SMALL_SENSOR[1],
        "pent": {"mode": "pent", "beta": 2.0, "theta_min": 1.5, "estimate": estimate},
        "conv2": {"threshold": 3.0},
        "conv3": {"threshold": 1.5},
    }


def random_events(n: int, size: tuple[int, int], seed: int = 0) -> np.ndarray:
    """``n`` events at random pixels of a ``size`` sensor, from 1000 µs, 0-29 µs apart."""
    from uavsnn.events import EVENT_DTYPE

    rng = np.random.default_rng(seed)
    ev = np.zeros(n, dtype=EVENT_DTYPE)
    ev["t"] = 1_000 + np.cumsum(rng.integers(0, 30, n))
    ev["x"] = rng.integers(0, size[0], n)
    ev["y"] = rng.integers(0, size[1], n)
    ev["p"] = rng.random(n) < 0.5
    return ev


def blob_events(seed: int, n: int, *, t0: int = 5_000) -> np.ndarray:
    """A blob drifting right over sparse noise on the 40x30 sensor; many equal times."""
    from uavsnn.events import EVENT_DTYPE

    rng = np.random.default_rng(seed)
    ev = np.zeros(n, dtype=EVENT_DTYPE)
    ev["t"] = t0 + np.cumsum(rng.integers(0, 40, n) * (rng.random(n) < 0.7))
    noise = rng.random(n) < 0.25
    cx = 5 + np.arange(n) * 30 // max(n, 1)
    ev["x"] = np.where(noise, rng.integers(0, SMALL_SENSOR[0], n), cx + rng.integers(0, 5, n))
    ev["y"] = np.where(noise, rng.integers(0, SMALL_SENSOR[1], n), 12 + rng.integers(0, 5, n))
    ev["p"] = rng.random(n) < 0.5
    return ev


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The real third-party data beside the project; skips the test when it is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real data not found at {SHARED_DATA} (it sits beside the project in CI)")
    return SHARED_DATA


@pytest.fixture(scope="module")
def bench_script() -> Iterator[Callable[[str], ModuleType]]:
    """``bench_script(NAME)``: ``benches/python/NAME.py`` imported as module ``NAME``, once per
    test module. Its folder is on ``sys.path`` while it loads, as when the script runs, for the
    modules it shares with its siblings; it stays in ``sys.modules`` (dataclasses look their
    module up) until the test module ends."""
    loaded: dict[str, ModuleType] = {}

    def load(name: str) -> ModuleType:
        if name not in loaded:
            spec = importlib.util.spec_from_file_location(name, BENCHES / f"{name}.py")
            assert spec is not None and spec.loader is not None
            module = importlib.util.module_from_spec(spec)
            sys.modules[name] = module
            sys.path.insert(0, str(BENCHES))
            try:
                spec.loader.exec_module(module)
            finally:
                sys.path.remove(str(BENCHES))
            loaded[name] = module
        return loaded[name]

    yield load
    for name, module in list(sys.modules.items()):
        if Path(getattr(module, "__file__", None) or "").parent == BENCHES:
            del sys.modules[name]


def _write_clip(
    folder: Path,
    name: str,
    boxes: Sequence[tuple[int, int] | None],
    *,
    rows: int | None = None,
    size: tuple[int, int] = (320, 256),
    square: tuple[int, int] = (12, 8),
    dark: int = 20,
) -> None:
    """A clip in the Svanström layout: ``folder/name.avi`` (MJPG, 30 fps, ``size``) of a dark
    ``square`` (w, h) at ``boxes[k]`` (its top-left corner; ``None``: not in frame ``k``) on a
    bright sky, and ``name.csv`` with a row for each of the first ``rows`` frames (default:
    every frame), its box or empty."""
    w, h = size
    writer = cv2.VideoWriter(
        str(folder / f"{name}.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, size
    )
    for box in boxes:
        frame = np.full((h, w, 3), 200, dtype=np.uint8)
        if box is not None:
            x, y = box
            frame[y : y + square[1], x : x + square[0]] = dark
        writer.write(frame)
    writer.release()
    with (folder / f"{name}.csv").open("w", newline="") as f:
        out = csv.writer(f)
        out.writerow(["frame", "x", "y", "w", "h"])
        for k in range(len(boxes) if rows is None else rows):
            b = boxes[k]
            out.writerow([k + 1, "", "", "", ""] if b is None else [k + 1, b[0], b[1], *square])


@pytest.fixture(scope="session")
def write_clip() -> Callable[..., None]:
    """``write_clip(folder, name, boxes, *, rows=None, size=(320, 256), square=(12, 8),
    dark=20)``: a labelled clip in the Svanström layout (a dark square moving over a bright
    sky)."""
    return _write_clip


@pytest.fixture
def one_clip(tmp_path: Path, write_clip: Callable[..., None]) -> Path:
    """A folder, ``tmp_path / "videos"``, of one labelled clip: V_DRONE_001.avi (320x256) and
    its .csv, 6 frames."""
    videos = tmp_path / "videos"
    videos.mkdir()
    write_clip(videos, "V_DRONE_001", [(40 + 4 * k, 60) for k in range(6)])
    return videos


@pytest.fixture
def clips(tmp_path: Path, write_clip: Callable[..., None]) -> Path:
    """A folder of five labelled clips of 320x256 (two drones, two birds, an airplane), as the
    tiny reproduce test's: ``tmp_path / "videos"``."""
    folder = tmp_path / "videos"
    folder.mkdir()
    for i, cls in enumerate(("DRONE", "DRONE", "BIRD", "BIRD", "AIRPLANE")):
        write_clip(
            folder, f"V_{cls}_{i + 1:03d}", [(40 + (4 + i) * k, 60 + 2 * k) for k in range(30)]
        )
    return folder


def symlink(link: Path, target: Path) -> None:
    """``link`` made a symbolic link to ``target``; the test is skipped where links cannot be
    made (Windows without the privilege to make them)."""
    try:
        link.symlink_to(target)
    except OSError as exc:
        pytest.skip(f"cannot make a symbolic link here: {exc}")


def kill_group(proc: subprocess.Popen[Any]) -> None:
    """Kill ``proc`` and, on POSIX, its process group (started with ``start_new_session``:
    its forked children too); Windows has no process groups to kill: the process alone."""
    try:
        if hasattr(os, "killpg"):
            os.killpg(proc.pid, signal.SIGKILL)
        else:
            proc.kill()
    except ProcessLookupError:
        pass


def unwritable_folder(monkeypatch: pytest.MonkeyPatch, folder: Path) -> Path:
    """Make ``folder`` and have ``os.access`` call it not writable (the tests run as root, who
    may write anywhere), for the rest of the test."""
    folder.mkdir()
    real_access = os.access

    def access(path: Any, mode: int, **kwargs: Any) -> bool:
        return Path(path) != folder and real_access(path, mode, **kwargs)

    monkeypatch.setattr(os, "access", access)
    return folder


def one_line_exit_2(capsys: pytest.CaptureFixture[str], argv: list[str], match: str) -> str:
    """Run the command line; it must exit 2 with one error line that contains ``match``."""
    from uavsnn.cli import main

    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "error:" in lines[0] and match in lines[0], lines[0]
    return lines[0]


class WindowsClosedPipe(io.RawIOBase):
    """The write end of a pipe whose reader has gone, as Windows reports it: a write raises
    ``OSError(EINVAL)`` (Linux raises ``BrokenPipeError``) until the descriptor is pointed
    elsewhere, as a command does with ``os.dup2`` onto the null device."""

    def __init__(self) -> None:
        read, self.fd = os.pipe()
        os.close(read)
        stat = os.fstat(self.fd)
        self.pipe = (stat.st_dev, stat.st_ino)
        self.refused = 0

    def writable(self) -> bool:
        return True

    def fileno(self) -> int:
        return self.fd

    def write(self, data: Any) -> int:
        stat = os.fstat(self.fd)
        if (stat.st_dev, stat.st_ino) == self.pipe:
            self.refused += 1
            raise OSError(errno.EINVAL, "Invalid argument")
        return os.write(self.fd, bytes(data))

    def close(self) -> None:
        if not self.closed:
            os.close(self.fd)
        super().close()
