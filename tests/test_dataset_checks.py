"""Checks of a dataset build's input and output folders: ``--overwrite`` replaces a dataset's
own files and refuses a folder that holds anything else (keeping an interrupted overwrite's old
dataset whole); real clips of one name, or labelled but misnamed, are refused; an unreadable
video is named in one line; a sky scene takes any ``room_m``; and the documents' scene file and
frame-rate notes are what the code does."""

from __future__ import annotations

import builtins
import importlib
import json
import os
import re
import shutil
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import one_line_exit_2

from uavsnn import DatasetError, SimulationError
from uavsnn.cli import main
from uavsnn.dataset import SceneSource, build, find_clips, load
from uavsnn.dataset.footage import plan_clip
from uavsnn.dataset.format import LOCK, MANIFEST
from uavsnn.dataset.splits import WindowCut
from uavsnn.scenes import Background, SceneSpec, render, spec_from_dict, spec_to_dict
from uavsnn.sim import iter_video, probe_video

# The module (``uavsnn.dataset.build`` is also the function the package exports).
dataset_build = importlib.import_module("uavsnn.dataset.build")
DOCS = Path(__file__).resolve().parents[1] / "docs"
# Small recordings so that a build takes seconds (as tests/test_interrupts.py's).
DVS = SceneSource("dvs", (240, 180), 200.0, 0.3)


def _files(root: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(root.iterdir()) if p.is_file()}


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small dvs dataset, copied by each test that changes it."""
    root = tmp_path_factory.mktemp("built") / "set"
    build(root, "dvs", dvs=DVS, n_test=4, n_train=4, seed=3)
    return root


@pytest.fixture
def dataset(built: Path, tmp_path: Path) -> Path:
    root = tmp_path / "set"
    shutil.copytree(built, root)
    return root


# -- 1. --overwrite replaces the dataset's own files, and nothing else ---------------------


def test_overwrite_refuses_a_folder_that_holds_more_than_a_dataset(dataset: Path) -> None:
    old = _files(dataset)
    (dataset / "notes.txt").write_text("mine")
    (dataset / "model").mkdir()
    (dataset / "model" / "net.npz").write_bytes(b"weights")
    with pytest.raises(DatasetError, match=r"notes\.txt, model/\)|model/, notes\.txt\)") as info:
        build(dataset, "dvs", dvs=DVS, n_test=4, n_train=0, seed=4, overwrite=True)
    assert "\n" not in str(info.value)
    assert (dataset / "notes.txt").read_text() == "mine"
    assert (dataset / "model" / "net.npz").read_bytes() == b"weights"
    assert {k: v for k, v in _files(dataset).items() if k != "notes.txt"} == old
    assert len(load(dataset, "test")) == 4 and len(load(dataset, "train")) == 4
    assert not (dataset / LOCK).exists()


def test_the_refusal_comes_before_any_work_and_names_a_few(
    dataset: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    for k in range(5):
        (dataset / f"mine{k}.txt").write_text("mine")

    def no_work(*_args: Any, **_kwargs: Any) -> Any:
        raise AssertionError("the build started")

    monkeypatch.setattr(dataset_build, "_synthetic", no_work)
    with pytest.raises(DatasetError, match=r"mine0\.txt, mine1\.txt, mine2\.txt and 2 more"):
        build(dataset, "dvs", dvs=DVS, n_test=4, n_train=0, overwrite=True)
    assert sorted(p.name for p in dataset.iterdir() if p.name.startswith("mine")) == [
        f"mine{k}.txt" for k in range(5)
    ]


def test_the_command_line_overwrite_refuses_in_one_line(
    dataset: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    old = _files(dataset)
    (dataset / "notes.txt").write_text("mine")
    argv = ["dataset", "build", str(dataset), "--domain", "dvs", "--n-test", "4", "--n-train", "0"]
    assert main([*argv, "--quiet", "--overwrite"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "notes.txt" in err[0] and "overwrite" in err[0]
    assert {k: v for k, v in _files(dataset).items() if k != "notes.txt"} == old


def test_overwrite_keeps_a_file_put_in_the_folder_while_it_builds(
    dataset: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real = dataset_build.save_split

    def save_split(path: Path, data: Any) -> Path:
        (dataset / "notes.txt").write_text("mine")  # written while the build runs
        return real(path, data)

    monkeypatch.setattr(dataset_build, "save_split", save_split)
    build(dataset, "dvs", dvs=DVS, n_test=4, n_train=0, seed=4, overwrite=True)
    assert sorted(p.name for p in dataset.iterdir()) == [MANIFEST, "notes.txt", "test.npz"]
    assert json.loads((dataset / MANIFEST).read_text())["seed"] == 4
    assert len(load(dataset, "test")) == 4


def test_overwrite_still_replaces_a_dataset_and_a_killed_builds_leftovers(dataset: Path) -> None:
    # What a build killed part way leaves inside the folder is the dataset's, and goes with it.
    (dataset / ".building-0123456789ab").mkdir()
    (dataset / ".building-0123456789ab" / "test.npz").write_bytes(b"half")
    (dataset / ".test.npz.0123456789ab.tmp").write_bytes(b"half")
    build(dataset, "dvs", dvs=DVS, n_test=4, n_train=0, seed=4, overwrite=True)
    assert sorted(p.name for p in dataset.iterdir()) == [MANIFEST, "test.npz"]
    assert len(load(dataset, "test")) == 4


def test_an_interrupted_overwrite_leaves_the_old_dataset_and_the_owners_file(
    dataset: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    old = _files(dataset)
    real_save = dataset_build.save_split
    real_replace = os.replace

    def save_split(path: Path, data: Any) -> Path:
        (dataset / "notes.txt").write_text("mine")  # put there while it builds
        return real_save(path, data)

    stopped: list[Any] = []

    def replace(src: Any, dst: Any) -> None:
        # The new manifest's rename into the folder, the swap's last, is interrupted (once:
        # the old one is put back so).
        if Path(src).name == MANIFEST and Path(dst) == dataset / MANIFEST and not stopped:
            stopped.append(src)
            raise KeyboardInterrupt
        real_replace(src, dst)

    monkeypatch.setattr(dataset_build, "save_split", save_split)
    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(KeyboardInterrupt):
        build(dataset, "dvs", dvs=DVS, n_test=4, n_train=0, seed=4, overwrite=True)
    monkeypatch.undo()
    assert stopped and Path(stopped[0]).parent != dataset
    assert _files(dataset) == old | {"notes.txt": b"mine"}
    assert len(load(dataset, "test")) == 4 and len(load(dataset, "train")) == 4
    assert [p.name for p in dataset.parent.iterdir()] == ["set"]  # no staging folder left


# -- 2. and 3. real clips: one name each, and labelled clips named as the pattern says ------


@pytest.fixture
def folder(one_clip: Path) -> Path:
    """One labelled clip, V_DRONE_001.avi (320x256) and .csv, of 6 frames (conftest)."""
    return one_clip


def test_two_videos_of_one_name_are_refused(folder: Path) -> None:
    shutil.copy(folder / "V_DRONE_001.avi", folder / "V_DRONE_001.mp4")
    with pytest.raises(DatasetError, match=r"V_DRONE_001\.avi and V_DRONE_001\.mp4") as info:
        find_clips(folder)
    assert "\n" not in str(info.value)
    assert "V_DRONE_001.csv" in str(info.value)


@pytest.mark.parametrize(
    "stem", ["DRONE_002", "my_flight", "V_DRONE_ü2", "V_DRONE_0 2", "V_DRONE_0-2", "V_DR0NE_002"]
)
def test_a_labelled_video_whose_name_does_not_fit_is_refused(folder: Path, stem: str) -> None:
    shutil.copy(folder / "V_DRONE_001.avi", folder / f"{stem}.avi")
    shutil.copy(folder / "V_DRONE_001.csv", folder / f"{stem}.csv")
    with pytest.raises(DatasetError, match=r"<PREFIX>_<CLASS>_<ID>") as info:
        find_clips(folder)
    message = str(info.value)
    assert f"{stem}.avi" in message and "ASCII" in message and "\n" not in message


def test_a_video_without_a_csv_whose_name_does_not_fit_is_left_alone(folder: Path) -> None:
    # docs/dataset.md §5: other files are ignored.
    for stem in ("DRONE_002", "my_flight", "V_DRONE_ü2"):
        shutil.copy(folder / "V_DRONE_001.avi", folder / f"{stem}.avi")
    (folder / "notes.csv").write_text("frame,x,y,w,h\n")
    assert [c.name for c in find_clips(folder)] == ["V_DRONE_001"]


# -- 4. a video that cannot be opened is named, in one line -----------------------------------


@pytest.mark.skipif(
    not hasattr(os, "geteuid") or os.geteuid() == 0,
    reason="root reads a file of mode 000 (see the next test, which stands in for it)",
)
def test_an_unreadable_video_is_permission_denied(
    folder: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    video = folder / "V_DRONE_001.avi"
    video.chmod(0)
    try:
        with pytest.raises(SimulationError, match="permission denied") as info:
            probe_video(video)
    finally:
        video.chmod(stat.S_IRUSR | stat.S_IWUSR)
    assert "\n" not in str(info.value)
    assert capfd.readouterr().err == ""  # no OpenCV warning before it


@pytest.mark.parametrize("read", [probe_video, lambda p: next(iter_video(p))])
def test_a_video_that_cannot_be_opened_says_permission_denied_before_opencv(
    folder: Path,
    monkeypatch: pytest.MonkeyPatch,
    capfd: pytest.CaptureFixture[str],
    read: Callable[[Path], object],
) -> None:
    # The tests run as root, who reads a file of mode 000: opening it is made to fail as it
    # does for anyone else.
    video = folder / "V_DRONE_001.avi"
    real_open = builtins.open

    def denying_open(file: Any, *args: Any, **kwargs: Any) -> Any:
        if isinstance(file, (str, os.PathLike)) and Path(file) == video:
            raise PermissionError(13, "Permission denied", str(file))
        return real_open(file, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", denying_open)
    with pytest.raises(SimulationError, match=r"V_DRONE_001\.avi.*\(permission denied\)") as info:
        read(video)
    assert "\n" not in str(info.value) and "unknown format" not in str(info.value)
    monkeypatch.undo()
    assert capfd.readouterr().err == ""


# -- 5. a sky takes any room_m; the documented scene file records ----------------------------


def test_a_sky_takes_any_room_and_draws_the_same(tmp_path: Path) -> None:
    sky = Background("sky", room_m=(0.0, 0.0, 0.0))
    assert sky.room_m == (0.0, 0.0, 0.0)
    spec = SceneSpec("dvs", 32, 24, 100.0, 0.03, 30.0, background=sky)
    again = spec_from_dict(json.loads(json.dumps(spec_to_dict(spec))))
    assert again == spec
    default = SceneSpec("dvs", 32, 24, 100.0, 0.03, 30.0, background=Background("sky"))
    frames, _, _ = render(spec, seed=1)
    expected, _, _ = render(default, seed=1)
    np.testing.assert_array_equal(frames, expected)
    # The ground and the hall still check it; a sky's must still be three numbers.
    for kind in ("ground", "hall"):
        with pytest.raises(SimulationError, match=r"room_m must lie in \[2, 500\] m"):
            Background(kind, room_m=(0.0, 0.0, 0.0))
    with pytest.raises(SimulationError, match="room_m"):
        Background("sky", room_m=("25", "15", "8"))  # type: ignore[arg-type]
    with pytest.raises(SimulationError, match="room_m"):
        Background("sky", room_m=(float("nan"), 1.0, 1.0))


def _doc_scene() -> str:
    text = (DOCS / "simulation.md").read_text(encoding="utf-8")
    section = text[text.index("#### The scene file") :]
    m = re.search(r"```json\n(.*?)```", section, re.S)
    assert m is not None, "docs/simulation.md's scene file section has no JSON example"
    return m.group(1)


def test_the_documented_scene_file_records(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = tmp_path / "drone.json"
    scene.write_text(_doc_scene(), encoding="utf-8")
    out = tmp_path / "drone.npz"
    assert main(["simulate", "--scene", str(scene), "-o", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    with np.load(tmp_path / "drone.labels.npz") as labels:
        drone = labels["labels"]["cls"] == "drone"
    # As docs/simulation.md says: 100 frames, the drone labelled in every one (its event count,
    # 7,370 on the machine of the change, is not checked: the C library's exp and log may move
    # it on another).
    assert summary["frames"] == 100 and summary["events"] > 0 and bool(drone.all())


# -- 6. variable frame rates: documented ----------------------------------------------------


@pytest.mark.parametrize("doc", ["simulation.md", "dataset.md"])
def test_the_docs_say_frames_are_timed_at_the_average_rate(doc: str) -> None:
    text = " ".join((DOCS / doc).read_text(encoding="utf-8").split())
    assert "average" in text and "variable-frame-rate" in text
    assert "-fps_mode cfr" in text


# -- 7. label rows past the video, a box file of its header alone ----------------------------


def test_rows_past_the_last_frame_are_ignored_and_a_header_alone_labels_nothing(
    folder: Path,
) -> None:
    # Kept as it was (77 of the 140 svanstrom-dev clips have one row more than frames), and
    # documented in docs/dataset.md §5.
    boxes = folder / "V_DRONE_001.csv"
    rows = boxes.read_text().splitlines()
    boxes.write_text("\n".join([*rows, "7,40,60,12,8", "8,44,60,12,8"]) + "\n")
    (clip,) = find_clips(folder)
    cut = WindowCut(50_000, 0.5, 0.5)
    plan = plan_clip(cut, clip, (240, 180))
    assert len(plan.labelled) == 6 and plan.labelled.all()
    boxes.write_text("frame,x,y,w,h\n")
    plan = plan_clip(cut, clip, (240, 180))
    assert not plan.labelled.any() and not plan.windows.usable.any()
    text = " ".join((DOCS / "dataset.md").read_text(encoding="utf-8").split())
    assert "rows past the video's last frame" in text and "header alone" in text


def test_dataset_info_on_a_split_file_names_its_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A split's file was called a folder that "does not exist", under "uavsnn dataset:".
    split = tmp_path / "data" / "test.npz"
    split.parent.mkdir()
    split.write_bytes(b"")
    line = one_line_exit_2(capsys, ["dataset", "info", str(split)], "is a file")
    assert line.startswith("uavsnn dataset info: error: ")
    assert line.endswith(f"a dataset is a folder (its folder is {split.parent})")
    line = one_line_exit_2(capsys, ["dataset", "info", str(tmp_path / "none")], "does not exist")
    assert line.startswith("uavsnn dataset info: error: dataset folder ")


def _real_manifest(*recordings: dict[str, Any]) -> dict[str, Any]:
    """The manifest of a small real set with these recordings, for `dataset info`'s summary."""
    split = {"windows": 4, "uav": 2, "non_uav": 2, "classes": {"drone": 2}, "recordings": [0]}
    return {
        "domain": "real", "source": "videos", "seed": 0,
        "parameters": {"window_ms": 50.0, "overlap": 0.5, "sensor_size": [240, 180]},
        "splits": {"train": split, "test": split},
        "recordings": list(recordings),
    }  # fmt: skip


def test_a_clip_that_gave_no_usable_window_is_said(capsys: pytest.CaptureFixture[str]) -> None:
    """A clip whose box file labels no window (its header alone) added nothing to the set, and
    only the manifest's `usable` 0 showed it: `dataset build` and `dataset info` name it."""
    from uavsnn.cli.dataset import _print, _summary

    manifest = _real_manifest(
        {"id": 0, "name": "V_DRONE_001", "domain": "real", "usable": 4},
        {"id": 1, "name": "V_BIRD_002", "domain": "real", "usable": 0},
    )
    summary = _summary(Path("set"), manifest)
    assert summary["unusable_clips"] == ["V_BIRD_002"]
    _print(summary, as_json=False)
    assert "1 clip gave no usable window" in capsys.readouterr().out
    manifest["recordings"][1]["usable"] = 3  # type: ignore[index]
    _print(_summary(Path("set"), manifest), as_json=False)
    assert "usable window" not in capsys.readouterr().out


def test_a_clip_labelled_in_part_is_said(capsys: pytest.CaptureFixture[str]) -> None:
    """A box file made for part of a clip (labels that stop short of the video) left the rest of
    its windows unscored without a word: a clip that leaves more than a tenth is named."""
    from uavsnn.cli.dataset import PARTLY_LABELLED, _print, _summary

    manifest = _real_manifest(
        {"id": 0, "name": "V_DRONE_001", "domain": "real", "usable": 398, "windows": 401},
        {"id": 1, "name": "V_BIRD_002", "domain": "real", "usable": 200, "windows": 401},
        {"id": 2, "name": "V_BIRD_003", "domain": "real", "usable": 0, "windows": 401},
    )
    summary = _summary(Path("set"), manifest)
    assert PARTLY_LABELLED == 0.1
    assert summary["partly_labelled_clips"] == [
        {"name": "V_BIRD_002", "usable": 200, "windows": 401}
    ]  # the clip of no usable window is said apart
    _print(summary, as_json=False)
    out = capsys.readouterr().out
    assert "1 clip left more than 10 % of its windows unscored" in out
    assert "V_BIRD_002 (200 of 401)" in out and "V_DRONE_001" not in out
    manifest["recordings"][1]["usable"] = 361  # type: ignore[index]
    _print(_summary(Path("set"), manifest), as_json=False)
    assert "unscored" not in capsys.readouterr().out
