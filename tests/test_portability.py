"""What works on Linux and must work on Windows and macOS too, checked here by emulating what
those systems lack or do otherwise: modules that do not exist there, Windows' file locking and
text-mode files, a console that cannot encode every character, a closed pipe that Windows
reports as EINVAL."""

from __future__ import annotations

import errno
import io
import os
import subprocess
import sys
import types
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import WindowsClosedPipe

import uavsnn
from uavsnn.errors import DatasetError, ParameterError


def test_every_module_imports_without_the_unix_only_modules() -> None:
    """Windows has no fcntl, resource or termios: no module may need them to import (a
    top-level ``import fcntl`` once stopped five commands there)."""
    script = """
import importlib, pkgutil, sys
for name in ("fcntl", "resource", "termios"):
    sys.modules[name] = None
import uavsnn
failed = []
for m in pkgutil.walk_packages(uavsnn.__path__, "uavsnn."):
    if m.name != "uavsnn.__main__":
        try:
            importlib.import_module(m.name)
        except ImportError as exc:
            failed.append(f"{m.name}: {exc}")
print("\\n".join(failed))
"""
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=300, check=True
    )
    assert done.stdout.strip() == "", done.stdout


def test_every_test_module_imports_without_the_unix_only_modules() -> None:
    """The same for the test suite: a test module importing fcntl at its top fails to collect on
    Windows, and every test in it with it (test_bad_input.py did, for one lock test)."""
    script = """
import importlib, pathlib, sys
for name in ("fcntl", "resource", "termios"):
    sys.modules[name] = None
sys.path.insert(0, sys.argv[1])
failed = []
for f in sorted(pathlib.Path(sys.argv[1]).glob("test_*.py")):
    try:
        importlib.import_module(f.stem)
    except ImportError as exc:
        failed.append(f"{f.name}: {exc}")
print("\\n".join(failed))
"""
    tests = Path(__file__).resolve().parent
    done = subprocess.run(
        [sys.executable, "-c", script, str(tests)],
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    )
    assert done.stdout.strip() == "", done.stdout


class _FakeMsvcrt(types.ModuleType):
    """Windows' ``msvcrt.locking`` on this machine: a byte range locked by one file handle at
    a time, across handles of the same file."""

    LK_NBLCK = 2

    def __init__(self) -> None:
        super().__init__("msvcrt")
        self.held: dict[tuple[int, int], int] = {}

    def locking(self, fd: int, mode: int, nbytes: int) -> None:
        assert (mode, nbytes) == (self.LK_NBLCK, 1)
        st = os.fstat(fd)
        key = (st.st_dev, st.st_ino)
        if key in self.held and self.held[key] != fd:
            raise PermissionError(13, "Permission denied")
        self.held[key] = fd


def test_a_build_folder_is_locked_on_windows_too(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from uavsnn.dataset.format import LOCK, locked_folder

    msvcrt = _FakeMsvcrt()
    monkeypatch.setattr(sys, "platform", "win32")
    monkeypatch.setitem(sys.modules, "msvcrt", msvcrt)
    monkeypatch.setitem(sys.modules, "fcntl", None)  # not there
    out = tmp_path / "data"
    with locked_folder(out):
        assert (out / LOCK).exists()
        assert len(msvcrt.held) == 1  # locked the Windows way
        with pytest.raises(DatasetError, match="another build"), locked_folder(out):
            pass
    assert not out.exists()  # the lock removed, and the folder the build made


def test_files_are_written_in_binary_mode(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Windows' os.open writes text (\\n as \\r\\n) unless told O_BINARY: every .npz written
    through write_atomic would be corrupt."""
    from uavsnn._files import write_atomic

    binary = 1 << 40  # a flag no system has, to see it passed
    opened: list[int] = []
    real_open = os.open

    def spy(path: Any, flags: int, mode: int = 0o777) -> int:
        opened.append(flags)
        return real_open(path, flags & ~binary, mode)

    monkeypatch.setattr(os, "O_BINARY", binary, raising=False)
    monkeypatch.setattr(os, "open", spy)
    write_atomic(tmp_path / "a.bin", lambda handle: handle.write(b"\n\r\n"))
    assert opened and all(flags & binary for flags in opened)
    assert (tmp_path / "a.bin").read_bytes() == b"\n\r\n"


def test_the_memory_limit_on_windows_is_its_physical_memory(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from uavsnn import windows

    monkeypatch.setattr(sys, "platform", "win32")
    monkeypatch.delattr(os, "sysconf")
    monkeypatch.setitem(sys.modules, "resource", None)
    monkeypatch.setattr(windows, "_windows_physical_memory", lambda: 8 << 30)
    assert windows._memory_limit(cgroup_files=()) == 8 << 30


def test_standard_input_heartbeats_are_refused_on_windows(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from uavsnn.sources import StdinSource

    monkeypatch.setattr(sys, "platform", "win32")
    with pytest.raises(ParameterError, match="select"):
        StdinSource(io.BytesIO(b""), heartbeat_s=0.5)
    StdinSource(io.BytesIO(b""))  # without heartbeats it reads as anywhere


def test_a_console_that_cannot_encode_micro_gets_it_escaped(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`uavsnn info` prints µs; a console in cp932 (Japanese Windows) cannot encode it."""
    from uavsnn.cli import main

    events = np.zeros(3, dtype=uavsnn.EVENT_DTYPE)
    events["t"] = [1, 2, 3]
    path = tmp_path / "r.npz"
    uavsnn.io.write_npz(uavsnn.Recording(events, (64, 48)), path)
    raw = io.BytesIO()
    out = io.TextIOWrapper(raw, encoding="cp932")
    monkeypatch.setattr(sys, "stdout", out)
    assert main(["info", str(path)]) == 0
    out.flush()
    assert b"\\xb5s" in raw.getvalue()


def test_images_are_written_to_any_path(tmp_path: Path) -> None:
    import cv2

    from uavsnn._files import write_image

    image = np.arange(12 * 8, dtype=np.uint8).reshape(8, 12)
    path = tmp_path / "vidéo ドローン.png"
    assert write_image(path, image)
    np.testing.assert_array_equal(cv2.imdecode(np.fromfile(path, np.uint8), 0), image)
    assert not write_image(tmp_path / "missing" / "a.png", image)


def _recording(tmp_path: Path) -> Path:
    events = np.zeros(3, dtype=uavsnn.EVENT_DTYPE)
    events["t"] = [1, 2, 3]
    path = tmp_path / "r.npz"
    uavsnn.io.write_npz(uavsnn.Recording(events, (64, 48)), path)
    return path


def test_a_closed_pipe_reported_as_einval_on_windows_ends_quietly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """`uavsnn info F | more` on Windows: the closed pipe raises EINVAL, not BrokenPipeError;
    the command stops quietly with exit 1, as on Linux (it once printed "[Errno 22] Invalid
    argument" and exited 2)."""
    from uavsnn.cli import main

    path = _recording(tmp_path)
    pipe = WindowsClosedPipe()
    out = io.TextIOWrapper(io.BufferedWriter(pipe), encoding="utf-8")
    monkeypatch.setattr(sys, "platform", "win32")
    monkeypatch.setattr(sys, "stdout", out)
    try:
        assert main(["info", str(path)]) == 1
        assert pipe.refused > 0  # the pipe was written to, and refused it
        assert capsys.readouterr().err == ""
        out.flush()  # what was still buffered now goes to the null device
    finally:
        out.close()


def test_einval_of_a_file_on_windows_is_still_an_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """EINVAL is also what Windows raises for a file name it refuses: with standard output
    still writable, that is the user's error, said in one line with exit 2."""
    from uavsnn.cli import info, main, pipe_closed

    def refused(*_: Any, **__: Any) -> None:
        raise OSError(errno.EINVAL, "Invalid argument", "r?.npz")

    monkeypatch.setattr(sys, "platform", "win32")
    monkeypatch.setattr(info.io, "read", refused)
    assert main(["info", str(_recording(tmp_path))]) == 2
    assert "uavsnn info: error: [Errno 22] Invalid argument: 'r?.npz'" in capsys.readouterr().err
    # The rule itself: a broken pipe anywhere; EINVAL only on Windows, only when the stream
    # cannot be flushed.
    healthy = io.StringIO("x")
    assert pipe_closed(BrokenPipeError(), healthy)
    assert not pipe_closed(OSError(errno.EINVAL, "Invalid argument"), healthy)
    assert not pipe_closed(OSError(errno.ENOENT, "No such file"), healthy)
    monkeypatch.setattr(sys, "platform", "linux")
    pipe = WindowsClosedPipe()
    broken = io.TextIOWrapper(io.BufferedWriter(pipe), encoding="utf-8")
    broken.write("x")
    assert not pipe_closed(OSError(errno.EINVAL, "Invalid argument"), broken)
    monkeypatch.setattr(sys, "platform", "win32")
    assert pipe_closed(OSError(errno.EINVAL, "Invalid argument"), broken)
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, pipe.fd)
    os.close(devnull)
    broken.close()
