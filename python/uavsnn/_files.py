"""Writing files: atomically (readers see the old file or the whole new one, never a part), and
into folders checked before any work."""

from __future__ import annotations

import os
import secrets
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

from uavsnn.errors import ParameterError

__all__ = ["output_dir", "output_file", "write_atomic"]


def output_dir(path: Path, flag: str) -> Path:
    """Create the output folder ``path`` (given by ``flag``, an option or a parameter) and
    check that it can be written, before any work is done.

    Raises:
        ParameterError: ``path`` is an existing file, cannot be created, or is not writable.
    """
    if path.exists() and not path.is_dir():
        raise ParameterError(f"{flag} {path}: exists and is not a folder")
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


def write_atomic(path: str | os.PathLike[str], write: Callable[[BinaryIO], object]) -> None:
    """Write ``path`` through ``write(handle)``: into a new temporary file beside it (created
    exclusively, under a random name), flushed to disk, then renamed over ``path``. On any
    error, the temporary file is removed, ``path`` is left as it was, and the error is raised
    again."""
    target = Path(path)
    tmp = target.with_name(f".{target.name}.{secrets.token_hex(6)}.tmp")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        with os.fdopen(fd, "wb") as handle:
            write(handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
