"""Writing files: atomically (readers see the old file or the whole new one, never a part), and
into folders checked before any work."""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO

from uavsnn.errors import ParameterError

__all__ = ["check_output_dir", "output_dir", "output_file", "write_atomic", "write_image"]


def check_output_dir(path: Path, flag: str) -> None:
    """Refuse, before any work, an output folder ``path`` (given by ``flag``, an option or a
    parameter) that could not be made or written, without making it: a command makes it (with
    :func:`output_dir`) when it first writes there, so that a run refused after this check
    leaves no empty folder behind.

    Raises:
        ParameterError: ``path`` is an existing file or a link to nothing, is a folder that is
            not writable, or would be made under a file, under a link to nothing or in a folder
            that is not writable.
    """
    where = f"{flag} {path}"
    if path.exists():
        if not path.is_dir():
            raise ParameterError(f"{where}: exists and is not a folder")
        if not os.access(path, os.W_OK | os.X_OK):
            raise ParameterError(f"{where}: the folder is not writable")
        return
    # The nearest folder above it that exists: the new folders are made in it.
    target = path.absolute()
    for base in (target, *target.parents):
        if base.exists():
            break
        if base.is_symlink():
            link = "it" if base == target else str(base)
            raise ParameterError(f"{where}: cannot create the folder: {link} is a link to nothing")
    if not base.is_dir():
        raise ParameterError(f"{where}: cannot create the folder: {base} is not a folder")
    if not os.access(base, os.W_OK | os.X_OK):
        raise ParameterError(f"{where}: cannot create the folder: {base} is not writable")


def output_dir(path: Path, flag: str) -> Path:
    """Create the output folder ``path`` (given by ``flag``, an option or a parameter), after
    the checks of :func:`check_output_dir`.

    Raises:
        ParameterError: ``path`` is an existing file, cannot be created, or is not writable.
    """
    check_output_dir(path, flag)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ParameterError(f"{flag} {path}: cannot create the folder: {exc.strerror}") from exc
    if not os.access(path, os.W_OK | os.X_OK):
        raise ParameterError(f"{flag} {path}: the folder is not writable")
    return path


def output_file(path: Path, flag: str) -> Path:
    """Check that the file ``path`` (given by ``flag``) can be written where it is asked for,
    before any work is done: its folder exists and is writable, and it is not a folder.

    Raises:
        ParameterError: it cannot be.
    """
    folder = path.parent
    if path.is_dir():
        raise ParameterError(f"{flag} {path}: is a folder, not a file")
    if not folder.is_dir():
        raise ParameterError(f"{flag} {path}: the folder {folder} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ParameterError(f"{flag} {path}: the folder {folder} is not writable")
    return path


def temporary_beside(target: Path) -> Path:
    """A fresh hidden name beside ``target`` for a file written before it is renamed over
    ``target`` (on the same file system, so that the rename is atomic)."""
    return target.with_name(f".{target.name}.{secrets.token_hex(6)}.tmp")


def write_atomic(path: str | os.PathLike[str], write: Callable[[BinaryIO], object]) -> None:
    """Write ``path`` through ``write(handle)``: into a new temporary file beside it (created
    exclusively, under a random name), flushed to disk, then renamed over ``path``. On any
    error, the temporary file is removed, ``path`` is left as it was, and the error is raised
    again."""
    target = Path(path)
    tmp = temporary_beside(target)
    try:
        # O_BINARY: on Windows os.open is in text mode otherwise, and writes each \n as \r\n.
        flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0)
        fd = os.open(tmp, flags, 0o666)
        with os.fdopen(fd, "wb") as handle:
            write(handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_image(path: str | os.PathLike[str], image: Any) -> bool:
    """Write ``image`` (a NumPy array OpenCV takes) to ``path`` in the format its suffix names
    (``.png``), encoded by OpenCV and written by Python: OpenCV's own writer cannot open a path
    that is not ASCII on Windows. ``False`` when OpenCV cannot encode it or the file cannot be
    written (as ``cv2.imwrite`` says)."""
    import cv2

    target = Path(path)
    ok, data = cv2.imencode(target.suffix, image)
    if not ok:
        return False
    try:
        target.write_bytes(data.tobytes())
    except OSError:
        return False
    return True
