"""Atomic writes (uavsnn._files): a reader sees the old file or the whole new one; output
folders: checked before any work, with or without being made."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from conftest import symlink, unwritable_folder

from uavsnn._files import check_output_dir, output_dir, write_atomic
from uavsnn.errors import ParameterError


def test_a_write_replaces_the_file_whole_and_leaves_nothing_beside_it(tmp_path: Path) -> None:
    path = tmp_path / "out.bin"
    write_atomic(path, lambda f: f.write(b"first"))
    write_atomic(path, lambda f: f.write(b"second"))
    assert path.read_bytes() == b"second"
    assert [p.name for p in tmp_path.iterdir()] == ["out.bin"]


def test_a_failed_write_keeps_the_old_file_and_removes_its_temporary(tmp_path: Path) -> None:
    path = tmp_path / "out.bin"
    path.write_bytes(b"old")

    def half(f) -> None:
        f.write(b"half of the new")
        raise KeyboardInterrupt  # any exception, an interrupt included

    with pytest.raises(KeyboardInterrupt):
        write_atomic(path, half)
    assert path.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["out.bin"]


def test_a_folder_that_does_not_exist_is_an_os_error(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        write_atomic(tmp_path / "missing" / "out.bin", lambda f: f.write(b"x"))
    assert list(tmp_path.iterdir()) == []


def test_an_output_folder_is_checked_without_being_made(tmp_path: Path) -> None:
    new = tmp_path / "a" / "b"
    check_output_dir(new, "--out")
    check_output_dir(tmp_path, "--out")  # an existing folder
    assert list(tmp_path.iterdir()) == []
    assert output_dir(new, "--out") == new and new.is_dir()


@pytest.mark.parametrize("make", [False, True])
def test_both_refuse_the_same_folders_with_the_same_words(
    make: bool, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``output_dir`` checks with ``check_output_dir`` before it makes anything."""
    check = output_dir if make else check_output_dir
    afile = tmp_path / "afile"
    afile.write_text("x")
    symlink(tmp_path / "link", tmp_path / "nowhere")
    locked = unwritable_folder(monkeypatch, tmp_path / "locked")
    for path, words in [
        (afile, f"--out {afile}: exists and is not a folder"),
        (afile / "sub", f"cannot create the folder: {afile} is not a folder"),
        (tmp_path / "link", "cannot create the folder: it is a link to nothing"),
        (tmp_path / "link" / "sub", f"cannot create the folder: {tmp_path / 'link'} is a link"),
        (locked, f"--out {locked}: the folder is not writable"),
        (locked / "new", f"cannot create the folder: {locked} is not writable"),
    ]:
        with pytest.raises(ParameterError, match=re.escape(words)):
            check(path, "--out")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "link", "locked"]
    assert list(locked.iterdir()) == [] and afile.read_text() == "x"
