"""Box files and class names of real clips (docs/dataset.md §5): a box wholly outside the video's
frame, or rows far past its last frame, are labels made for another video and refused (a box
that only reaches past the edge, and fewer rows than frames, are kept); a class that holds DRONE
or UAV but is not the UAV class is refused; a byte-order mark and blank rows are accepted."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import one_line_exit_2

from uavsnn import DatasetError
from uavsnn.dataset import clip_labels, find_clips, read_boxes
from uavsnn.dataset.footage import plan_clip
from uavsnn.dataset.real import MAX_ROWS_PAST_END
from uavsnn.dataset.splits import WindowCut

CUT = WindowCut(50_000, 0.5, 0.5)
SIZE = (320, 256)  # the clips' video size (write_clip's default)
HEADER = "frame,x,y,w,h"


@pytest.fixture
def folder(one_clip: Path) -> Path:
    """One labelled clip, V_DRONE_001.avi (320x256) and .csv, of 6 frames (conftest)."""
    return one_clip


def _rows(folder: Path, *rows: str) -> Path:
    boxes = folder / "V_DRONE_001.csv"
    boxes.write_text("\n".join([HEADER, *rows]) + "\n")
    return boxes


# -- 1. a box wholly outside the video's frame ------------------------------------------------


@pytest.mark.parametrize(
    "box",
    [
        "320,60,12,8",  # right of the 320-px-wide frame (its left edge on the frame's)
        "2124.9,22.9,75.8,39.2",  # far right (the walk's shifted labels)
        "40,256,12,8",  # below
        "-12,60,12,8",  # left: it ends where the frame starts
        "40,-30.5,12,8",  # above
    ],
)
def test_a_box_wholly_outside_the_frame_is_refused_by_file_and_line(folder: Path, box: str) -> None:
    boxes = _rows(folder, "1,40,60,12,8", "2,,,,", f"3,{box}", "4,44,60,12,8")
    (clip,) = find_clips(folder)
    with pytest.raises(DatasetError, match="lies wholly outside the video's 320x256 frame") as e:
        plan_clip(CUT, clip, (240, 180))
    message = str(e.value)
    assert message.startswith(f"{boxes}:4: box ") and "\n" not in message
    # Without the video's size, the rows alone are read as before.
    frames, _ = read_boxes(boxes)
    assert frames.tolist() == [1, 2, 3, 4]


def test_a_box_reaching_past_the_edge_is_kept_and_clipped(folder: Path) -> None:
    # 320x256 crops to the centred 320x240 (8 rows off the top), then scales by 3/4.
    _rows(folder, "1,310,60,20,8", "2,-5,100,10,6", "3,40,240,12,20")
    (clip,) = find_clips(folder)
    labels, labelled = clip_labels(clip, 6, SIZE, (240, 180))
    assert labelled[:3].all() and not labelled[3:].any()
    assert labels["uav"][:3].all()
    assert labels["x0"][0] == pytest.approx(310 * 0.75) and labels["x1"][0] == 240.0
    assert labels["x0"][1] == 0.0 and labels["x1"][1] == pytest.approx(5 * 0.75)
    assert labels["y1"][2] == 180.0


# -- 2. rows far past the video's last frame; fewer rows than frames --------------------------


def test_rows_far_past_the_last_frame_are_refused(folder: Path) -> None:
    rows = [f"{k},{40 + 2 * k},60,12,8" for k in range(1, 8 + MAX_ROWS_PAST_END)]
    boxes = _rows(folder, *rows)  # rows for 9 frames of a 6-frame video
    (clip,) = find_clips(folder)
    with pytest.raises(DatasetError, match=r"has 9 rows, to frame 9, but video") as e:
        plan_clip(CUT, clip, (240, 180))
    message = str(e.value)
    assert str(boxes) in message and "V_DRONE_001.avi has 6 frames" in message
    assert "3 of the rows past its end" in message and "\n" not in message
    # As many as 2 past are ignored (svanstrom-dev: 77 clips have one).
    _rows(folder, *rows[:-1])
    plan = plan_clip(CUT, clip, (240, 180))
    assert len(plan.labelled) == 6 and plan.labelled.all()


def test_fewer_rows_than_frames_and_the_first_frames_alone_are_accepted(folder: Path) -> None:
    _rows(folder, "1,40,60,12,8", "2,44,60,12,8", "3,48,60,12,8")
    (clip,) = find_clips(folder)
    plan = plan_clip(CUT, clip, (240, 180))
    assert plan.labelled.tolist() == [True] * 3 + [False] * 3
    # A caller may label the first frames alone: checked against the whole video.
    _rows(folder, *[f"{k},40,60,12,8" for k in range(1, 8)])
    _, labelled = clip_labels(clip, 2, SIZE, (240, 180))
    assert labelled.tolist() == [True, True]
    # A container that does not count its frames (0) is not checked.
    _rows(folder, *[f"{k},40,60,12,8" for k in range(1, 20)])
    _, labelled = clip_labels(clip, 6, SIZE, (240, 180), video_frames=0)
    assert labelled.all()
    with pytest.raises(DatasetError, match="has 19 rows"):
        clip_labels(clip, 6, SIZE, (240, 180))


# -- 3. a class that holds DRONE or UAV must be the UAV class ---------------------------------


@pytest.mark.parametrize("stem", ["LAB_DRONES_1", "IR_ANTIUAV_4", "V_NoDrone_1", "V_uavs_2"])
def test_a_class_holding_drone_or_uav_but_not_the_uav_class_is_refused(
    folder: Path, stem: str
) -> None:
    shutil.copy(folder / "V_DRONE_001.avi", folder / f"{stem}.avi")
    shutil.copy(folder / "V_DRONE_001.csv", folder / f"{stem}.csv")
    with pytest.raises(DatasetError, match=r"<PREFIX>_DRONE_<ID>") as e:
        find_clips(folder)
    message = str(e.value)
    cls = stem.split("_")[1]
    assert f"{stem}.avi" in message and f"class {cls}," in message and "\n" not in message


@pytest.mark.parametrize("stem", ["V_drone_2", "IR_Uav_7", "V_UAV_3"])
def test_the_uav_class_in_any_case_is_a_uav(folder: Path, stem: str) -> None:
    shutil.copy(folder / "V_DRONE_001.avi", folder / f"{stem}.avi")
    shutil.copy(folder / "V_DRONE_001.csv", folder / f"{stem}.csv")
    clips = {c.name: c for c in find_clips(folder)}
    assert clips[stem].uav and clips[stem].cls == "drone"


def test_the_command_line_build_refuses_a_misnamed_drone_clip_in_one_line(
    folder: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for ext in ("avi", "csv"):
        (folder / f"V_DRONE_001.{ext}").rename(folder / f"LAB_DRONES_1.{ext}")
    argv = ["dataset", "build", str(tmp_path / "set"), "--domain", "real"]
    one_line_exit_2(capsys, [*argv, "--videos", str(folder), "--quiet"], "LAB_DRONES_1.avi")
    assert not (tmp_path / "set").exists()


# -- 4. a byte-order mark, blank rows ---------------------------------------------------------


def test_a_byte_order_mark_and_blank_rows_are_accepted(folder: Path) -> None:
    boxes = folder / "V_DRONE_001.csv"
    expected = read_boxes(boxes)
    text = boxes.read_text()
    # Excel's "CSV UTF-8": a byte-order mark and CRLF line ends.
    boxes.write_bytes(b"\xef\xbb\xbf" + text.replace("\n", "\r\n").encode())
    for got, want in zip(read_boxes(boxes), expected, strict=True):
        np.testing.assert_array_equal(got, want)
    # Trailing blank lines, one in the middle and a row of empty cells.
    lines = text.splitlines()
    boxes.write_text("\n".join([*lines[:3], "", *lines[3:], ",,,,", "", "  ", ""]) + "\n\n")
    for got, want in zip(read_boxes(boxes), expected, strict=True):
        np.testing.assert_array_equal(got, want)
    (clip,) = find_clips(folder)
    assert plan_clip(CUT, clip, (240, 180)).labelled.all()


def test_a_bad_row_after_a_blank_line_is_named_by_its_own_line(folder: Path) -> None:
    boxes = _rows(folder, "1,40,60,12,8", "", "", "2,44,60,0,8")
    with pytest.raises(DatasetError, match=rf"^{boxes}:5: box "):
        read_boxes(boxes)
    boxes.write_bytes(b"\xef\xbb\xbf\n" + f"{HEADER}\n1,40,60,12\n".encode())
    with pytest.raises(DatasetError, match=rf"^{boxes}:3: expected 5 fields"):
        read_boxes(boxes)
