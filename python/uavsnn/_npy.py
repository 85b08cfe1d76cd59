"""Reading NumPy's ``.npy`` headers and ``.npz`` members without reading their data, so that
what an array would take is known (and checked against the memory allowed) before it is read:
a compressed ``.npz`` member may expand a thousandfold, and a header may claim more than its
file holds. Used by :mod:`uavsnn.io` (recordings) and :mod:`uavsnn.dataset.format` (split
files)."""

from __future__ import annotations

import math
import zipfile
from typing import Any

import numpy as np

__all__ = ["npy_header", "npz_arrays", "npz_header", "npz_read"]


class _Counting:
    """A reader that counts the bytes read through it (the length of an .npy header)."""

    def __init__(self, handle: Any) -> None:
        self.handle = handle
        self.count = 0

    def read(self, size: int = -1) -> bytes:
        data: bytes = self.handle.read(size)
        self.count += len(data)
        return data


def npy_header(handle: Any) -> tuple[tuple[int, ...], np.dtype[Any], int]:
    """The shape, dtype and header length (the bytes before the data) of the ``.npy`` array
    that ``handle`` is at, from its header alone (NumPy's limit on a header's length applies).

    Raises:
        ValueError: not an ``.npy`` header, or a malformed one.
    """
    counting = _Counting(handle)
    version = np.lib.format.read_magic(counting)
    if version == (1, 0):
        shape, _, dtype = np.lib.format.read_array_header_1_0(counting)
    elif version in ((2, 0), (3, 0)):
        # 3.0 differs from 2.0 only in its header's encoding (UTF-8 field names): no size.
        shape, _, dtype = np.lib.format.read_array_header_2_0(counting)
    else:
        raise ValueError(f"unknown .npy format version {version}")
    return tuple(int(n) for n in shape), dtype, counting.count


def npz_arrays(archive: zipfile.ZipFile) -> dict[str, zipfile.ZipInfo]:
    """The arrays of an ``.npz`` archive by name (its ``name.npy`` members, named as
    ``np.load`` names them)."""
    return {
        info.filename[:-4]: info for info in archive.infolist() if info.filename.endswith(".npy")
    }


def npz_header(
    archive: zipfile.ZipFile, info: zipfile.ZipInfo
) -> tuple[tuple[int, ...], np.dtype[Any], int]:
    """The shape, dtype and size in bytes of an ``.npz`` member's array, from its header,
    without reading its data (a compressed member may expand to any size: check this size
    against the memory allowed before :func:`npz_read`).

    Raises:
        ValueError: a malformed header, an array of Python objects, or a header that claims
            more data than the member holds.
    """
    with archive.open(info) as member:
        shape, dtype, header = npy_header(member)
    if dtype.hasobject:
        raise ValueError(f"{info.filename!r} holds Python objects (pickles are not read)")
    nbytes = math.prod(shape) * dtype.itemsize
    if nbytes > info.file_size - header:
        raise ValueError(
            f"{info.filename!r} claims {nbytes:,} bytes of data ({shape} of {dtype}), the "
            f"member holds {max(info.file_size - header, 0):,}"
        )
    return shape, dtype, nbytes


def npz_read(archive: zipfile.ZipFile, info: zipfile.ZipInfo) -> np.ndarray:
    """An ``.npz`` member's array (check its header with :func:`npz_header` first)."""
    with archive.open(info) as member:
        array: np.ndarray = np.lib.format.read_array(member, allow_pickle=False)
    return array
