"""``uavsnn reproduce``: every argument is checked before any work and before --out is made, so
that a refused run leaves nothing behind and loses no time. The long steps are replaced by ones
that fail when called: a refusal that reaches them comes too late."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from conftest import one_line_exit_2

import uavsnn.cli.reproduce as reproduce
from uavsnn.cli import main


class Started(Exception):
    """The first dataset build was reached: every check had passed."""


@pytest.fixture
def no_work(monkeypatch: pytest.MonkeyPatch) -> list[Path]:
    """The dataset builder replaced by one that records its folder and stops the run."""
    calls: list[Path] = []

    def build(root: Path, *_args: Any, **_kwargs: Any) -> None:
        calls.append(root)
        raise Started

    monkeypatch.setattr(reproduce, "build", build)
    return calls


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--n-train", "1"], "--n-train must be an even number of windows from 2 to 1,000,000"),
        (["--n-train", "2000000"], "--n-train must be an even number"),
        (["--n-tune", "1000002"], "--n-tune must be an even number of windows from 2 to 1,000,000"),
        # odd: a build would refuse it only after the datasets before it (half UAV)
        (["--n-train", "3"], "--n-train must be an even number"),
        (["--n-tune", "5"], "--n-tune must be an even number"),
        (["--n-test", "7"], "--n-test must be an even number of windows from 2 to 1,000,000"),
        (["--n-test", "0"], "--n-test must be an even number"),
        (["--n-test", "-2"], "--n-test must be an even number"),
        (["--seed", "-1"], "--seed must be an integer >= 0, got -1"),
        (["--windows-per-layer", "0"], "--windows-per-layer must be in [1, 10000000], got 0"),
        (["--windows-per-layer", "100000000"], "--windows-per-layer must be in"),
        # A Ray address refused without a cluster (nothing listens, nothing is started).
        (["--ray", "nonsense"], "a Ray address is HOST:PORT"),
    ],
)
def test_bad_arguments_are_refused_before_any_work(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    no_work: list[Path],
    extra: list[str],
    message: str,
) -> None:
    out = tmp_path / "a" / "b" / "repro"
    argv = ["reproduce", "--out", str(out), "--no-real", "--quiet", *extra]
    one_line_exit_2(capsys, argv, message)
    assert not no_work
    assert not (tmp_path / "a").exists()  # neither --out nor the folders above it


def test_an_out_that_cannot_be_made_is_refused_before_any_work(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], no_work: list[Path]
) -> None:
    afile = tmp_path / "afile"
    afile.write_text("x")
    argv = ["reproduce", "--no-real", "--quiet", "--out"]
    line = one_line_exit_2(
        capsys, [*argv, str(afile / "sub")], f"--out {afile / 'sub'}: cannot create the folder"
    )
    assert "Errno" not in line
    one_line_exit_2(capsys, [*argv, str(afile)], f"--out {afile}: exists and is not a folder")
    assert not no_work and afile.read_text() == "x"


def test_videos_are_checked_before_any_work(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], no_work: list[Path], clips: Path
) -> None:
    out = tmp_path / "a" / "repro"
    argv = ["reproduce", "--out", str(out), "--quiet", "--videos"]
    missing = tmp_path / "nowhere"
    one_line_exit_2(capsys, [*argv, str(missing)], f"--videos {missing} at 240x180: video folder")
    empty = tmp_path / "empty"
    empty.mkdir()
    one_line_exit_2(capsys, [*argv, str(empty)], "no labelled videos in")
    # Clips of 320x256 are too small for the larger real sensor of the default (640x480).
    at_640 = [*argv, str(clips), "--n-test", "20"]
    one_line_exit_2(capsys, at_640, "at 640x480: video V_AIRPLANE_005.avi is 320x256")
    # Five short clips cannot fill a balanced real test split of 2000 windows.
    small = ["--real-sensors", "240x180", "--n-test", "2000"]
    one_line_exit_2(capsys, [*argv, str(clips), *small], "cannot balance the real test pool")
    # A box file the build would refuse.
    (clips / "V_BIRD_003.csv").write_text("frame,x,y\n")
    one_line_exit_2(capsys, [*argv, str(clips), "--real-sensors", "240x180"], "V_BIRD_003.csv")
    assert not no_work
    assert not (tmp_path / "a").exists()


def test_good_arguments_reach_the_first_build_with_out_made_after_the_cluster(
    tmp_path: Path,
    no_work: list[Path],
    clips: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    out = tmp_path / "a" / "repro"
    joined: list[str | None] = []

    def runner_for(address: str | None) -> Any:
        assert not out.exists()  # the cluster is joined before --out is made
        joined.append(address)
        return reproduce.SERIAL

    monkeypatch.setattr(reproduce, "runner_for", runner_for)
    argv = ["reproduce", "--out", str(out), "--quiet", "--n-test", "20"]
    with pytest.raises(Started):
        main([*argv, "--videos", str(clips), "--real-sensors", "240x180,320x240"])
    assert joined == [None] and no_work == [out / "data/dvs"] and out.is_dir()
    # With --no-real, no video is read (--videos beside it is refused: tests/test_cli_checks.py).
    out.rmdir()
    with pytest.raises(Started):
        main([*argv, "--no-real"])
    assert out.is_dir()


def test_a_missing_default_video_folder_is_said_before_any_work(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    no_work: list[Path],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Outside the checkout the default folder is absent: the run goes on without real footage,
    # and says so at once rather than leaving its section out of RESULTS.md unexplained.
    monkeypatch.setattr(reproduce, "_DEFAULT_VIDEOS", tmp_path / "absent")
    argv = ["reproduce", "--out", str(tmp_path / "repro"), "--quiet", "--n-test", "20"]
    with pytest.raises(Started):
        main(argv)
    err = capsys.readouterr().err
    assert f"no real footage: no --videos was given, and the default folder {tmp_path}" in err
    assert no_work == [tmp_path / "repro/data/dvs"]
    # Left out on purpose, it is not a surprise to warn about.
    with pytest.raises(Started):
        main([*argv, "--no-real"])
    assert "no real footage" not in capsys.readouterr().err
