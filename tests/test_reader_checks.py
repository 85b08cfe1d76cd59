"""What the readers and simulators refuse where data enters, found by a new user: a first CSV
line that is neither events nor a header (file and standard input), times past the engine's
2^62 µs (a Recording, the simulators' frame times), measure_box's time order and ``rate``, a
video path that is not a path, frames a video read could not hold in memory, and frame dtypes
the simulators would take on the wrong scale."""

from __future__ import annotations

import io as pyio
import re
from pathlib import Path

import cv2
import numpy as np
import pytest

from uavsnn import io as uio
from uavsnn import windows
from uavsnn.errors import (
    EventError,
    ParameterError,
    RecordingFileError,
    SimulationError,
    StreamError,
)
from uavsnn.events import EVENT_DTYPE, Recording, convert
from uavsnn.signature import measure_box
from uavsnn.sim import (
    DvsEmulator,
    emulate_dvs,
    iter_video,
    pix2nvs,
    probe_video,
    read_video,
    video_to_recording,
)
from uavsnn.sources import StdinSource

MAX_TIME_US = 1 << 62

# -- 1. a first CSV line that is neither an event line nor a header ------------------------------


@pytest.mark.parametrize(
    ("text", "line", "field"),
    [
        ("1\t2\t3\t1\n", 1, "'1\\t2\\t3\\t1'"),  # tab-separated: read as a header, 0 events
        ("1\t2\t3\t1\n2\t3\t4\t0\n", 1, "'1\\t2\\t3\\t1'"),  # was refused at line 2
        ("1;2;3;1\n2;3;4;0\n", 1, "'1;2;3;1'"),
        ('"1","2","3","1"\n', 1, "'1'"),  # quoted numbers
        ("nan,2,3,1\n2,3,4,0\n", 1, "'nan'"),  # the nan line was dropped as a "header"
        ("\n# a comment\n1\t2\t3\t1\n", 3, "'1\\t2\\t3\\t1'"),  # the first line with text
    ],
)
def test_a_first_csv_line_that_is_no_header_is_refused_naming_its_line(
    tmp_path: Path, text: str, line: int, field: str
) -> None:
    path = tmp_path / "rec.csv"
    path.write_text(text)
    with pytest.raises(RecordingFileError, match=rf"rec\.csv: line {line}: .* is neither an event"):
        uio.read(path, sensor_size=(10, 10))
    with pytest.raises(RecordingFileError, match=re.escape(f"field 1 ({field}) is not a column")):
        uio.read(path, sensor_size=(10, 10))


@pytest.mark.parametrize(
    "text", ["1\t2\t3\t1\n2\t3\t4\t0\n", '"1","2","3","1"\n', "nan,2,3,1\n2,3,4,0\n"]
)
def test_standard_input_refuses_the_same_first_lines(text: str) -> None:
    # The nan stream gave one event, its first line dropped as a header.
    source = StdinSource(pyio.BytesIO(text.encode()), fmt="csv", sensor_size=(10, 10))
    with pytest.raises(StreamError, match=r"^standard input: .* is neither an event line"):
        list(source)


@pytest.mark.parametrize(
    "header",
    ['"t","x","y","p"', "Timestamp, X, Y, Polarity", "t,x,y,p,", "foo,bar,baz,qux", "µs,x"],
)
def test_headers_that_name_their_columns_still_read(tmp_path: Path, header: str) -> None:
    path = tmp_path / "rec.csv"
    path.write_text(f"{header}\n5,2,3,1\n6,4,5,0\n", encoding="utf-8")
    events = [(5, 2, 3, True), (6, 4, 5, False)]
    assert uio.read(path, sensor_size=(10, 10)).events.tolist() == events
    source = StdinSource(pyio.BytesIO(path.read_bytes()), fmt="csv", sensor_size=(10, 10))
    assert [e for chunk in source for e in chunk.tolist()] == events


# -- 2. times past the engine's 2^62 µs -----------------------------------------------------------


def test_a_recording_past_the_engines_latest_time_is_refused() -> None:
    late = convert(np.array([[2**64 - 1, 1, 1, 1]], np.uint64), layout="canonical")
    with pytest.raises(EventError, match=r"^event 0: t=18446744073709551615 is beyond the latest"):
        Recording(late, (10, 10))
    events = convert(
        np.array([[1, 1, 1, 1], [MAX_TIME_US, 1, 1, 1], [MAX_TIME_US + 1, 1, 1, 0]], np.uint64),
        layout="canonical",
    )
    with pytest.raises(EventError, match=rf"^event 2: t={MAX_TIME_US + 1} is beyond"):
        Recording(events, (10, 10))
    assert len(Recording(events[:2], (10, 10))) == 2  # 2^62 itself is taken


def test_a_file_past_the_engines_latest_time_is_a_file_error(tmp_path: Path) -> None:
    events = np.zeros(2, EVENT_DTYPE)
    events["t"] = [5, MAX_TIME_US + 5]
    np.save(tmp_path / "late.npy", events)
    with pytest.raises(RecordingFileError, match=r"late\.npy: .*event 1: .* is beyond the latest"):
        uio.read(tmp_path / "late.npy", sensor_size=(10, 10))


@pytest.mark.parametrize("simulate", [emulate_dvs, pix2nvs])
def test_frame_times_past_the_engines_latest_time_are_refused(simulate) -> None:  # type: ignore[no-untyped-def]
    frames = np.zeros((3, 4, 4), np.uint8)
    frames[1:] = 200
    ts = np.arange(3) * 1000
    for times in (ts + 2**62, np.array([2**63, 2**63 + 1, 2**63 + 2], np.uint64)):
        with pytest.raises(SimulationError, match=r"timestamp \d .* is beyond the latest time"):
            simulate(frames, times)
    # Up to 2^62 itself: events, none past it.
    events = simulate(frames, ts + (MAX_TIME_US - 2000))
    assert len(events) and int(events["t"].max()) <= MAX_TIME_US


def test_a_frame_time_past_the_engines_latest_time_is_refused_frame_by_frame() -> None:
    emulator = DvsEmulator((4, 4))
    emulator.process_frame(np.zeros((4, 4), np.float32), MAX_TIME_US - 10)
    with pytest.raises(SimulationError, match=r"frame time of \d+ µs is beyond the latest time"):
        emulator.process_frame(np.zeros((4, 4), np.float32), MAX_TIME_US + 1)
    assert emulator.frames_seen == 1


# -- 3. measure_box: time order and the form of rate ---------------------------------------------


def _box_events() -> np.ndarray:
    events = np.zeros(60, EVENT_DTYPE)
    events["t"] = np.arange(60) * 100
    events["x"] = np.arange(60) % 10
    events["y"] = 3
    events["p"] = np.arange(60) % 3 == 0
    return events


@pytest.mark.parametrize("rate", [(0, 5000), (0, 5000, 4, 1), "abc", 5])
def test_measure_box_refuses_a_rate_that_is_not_three_numbers(rate: object) -> None:
    with pytest.raises(ParameterError, match=r"rate must be \(start_us, bin_us, bins\)"):
        measure_box(_box_events(), (0, 0, 10, 10), rate=rate)  # type: ignore[arg-type]


# -- 4. and 5. videos: a path that is not one, frames beyond the memory allowed ------------------


def _write_video(path: Path, n: int = 12) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 25.0, (80, 60))
    assert writer.isOpened()
    for k in range(n):
        frame = np.full((60, 80, 3), 60, dtype=np.uint8)
        frame[20:40, 4 * k : 4 * k + 20] = 220
        writer.write(frame)
    writer.release()
    return path


@pytest.mark.parametrize(
    "call",
    [
        lambda: video_to_recording(5),  # type: ignore[arg-type]
        lambda: read_video(5),  # type: ignore[arg-type]
        lambda: list(iter_video(b"clip.mp4")),  # type: ignore[arg-type]
        lambda: probe_video(None),  # type: ignore[arg-type]
    ],
)
def test_a_video_path_that_is_not_a_path_is_a_parameter_error(call) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ParameterError, match=r"path must be a str or os\.PathLike"):
        call()


def test_frames_that_would_not_fit_in_memory_are_refused_before_reading(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A 64x48 frame read as gray takes 64*48*3 bytes (BGR) and 64*48 (gray): 12,288.
    monkeypatch.setattr(windows, "MEMORY_LIMIT", 64 * 48 * 4 - 1)
    missing = tmp_path / "missing.mp4"
    with pytest.raises(ParameterError, match=r"size=64x48: a frame .*MEMORY_LIMIT"):
        read_video(missing, size=(64, 48))  # refused before the file is opened
    with pytest.raises(ParameterError, match="size=64x48"):
        list(iter_video(missing, size=(64, 48)))
    # In BGR the frame alone fits: the file is looked at.
    with pytest.raises(SimulationError, match="does not exist"):
        read_video(missing, size=(64, 48), color="bgr")


def test_read_video_refuses_more_frames_than_fit_in_memory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    video = _write_video(tmp_path / "clip.avi")
    frames, _ = read_video(video, size=(64, 48))
    assert frames.shape == (12, 48, 64)
    # Room for 4 gray frames held twice (read, then stacked): 4 * 2 * 3,072 bytes.
    monkeypatch.setattr(windows, "MEMORY_LIMIT", 4 * 2 * 64 * 48)
    few, _ = read_video(video, size=(64, 48), max_frames=4)
    np.testing.assert_array_equal(few, frames[:4])
    with pytest.raises(ParameterError, match=r"read_video holds every frame: 5 frames of 64x48"):
        read_video(video, size=(64, 48))


# -- 6. frame dtypes the simulators would take on the wrong scale --------------------------------


@pytest.mark.parametrize("simulate", [emulate_dvs, pix2nvs])
@pytest.mark.parametrize("dtype", [np.uint16, np.int64, np.int32])
def test_integer_frames_above_255_are_refused(simulate, dtype) -> None:  # type: ignore[no-untyped-def]
    # A 16-bit sensor's frames were taken as 0-255 unscaled: 1000 as four times white.
    frames = np.full((2, 4, 4), 100, dtype)
    frames[1, 0, 0] = 1000
    with pytest.raises(SimulationError, match=f"dtype {frames.dtype} must be on the 0-255 scale"):
        simulate(frames, [0, 1000])


@pytest.mark.parametrize("simulate", [emulate_dvs, pix2nvs])
@pytest.mark.parametrize("dtype", [np.uint16, np.int64, np.int8])
def test_integer_frames_on_the_0_255_scale_are_taken_as_uint8(simulate, dtype) -> None:  # type: ignore[no-untyped-def]
    frames = np.full((2, 4, 4), 20, np.uint8)
    frames[1] = 120  # within int8's range
    want = simulate(frames, [0, 1000])
    assert len(want) and np.array_equal(simulate(frames.astype(dtype), [0, 1000]), want)


@pytest.mark.parametrize("simulate", [emulate_dvs, pix2nvs])
def test_uint8_and_float_frames_are_still_taken(simulate) -> None:  # type: ignore[no-untyped-def]
    frames = np.full((2, 4, 4), 100, np.uint8)
    frames[1] = 200
    want = simulate(frames, [0, 1000])
    assert len(want)
    for dtype in (np.float16, np.float32, np.float64):
        assert len(simulate(frames.astype(dtype), [0, 1000]))
    # Floats above 255 are taken: the "dvs" renderer's flickering light goes past 255.
    assert len(simulate(frames.astype(np.float32) * 1.3, [0, 1000]))


# -- 7. a DAT header giving another record size ---------------------------------------------------


def test_a_dat_header_giving_records_of_another_size_is_no_dat(tmp_path: Path) -> None:
    # The header's size byte read as 216: "truncated ... 216-byte DAT records" (or faery's own
    # refusal when the bytes happened to divide): the file is no DAT, or its header is corrupt.
    path = tmp_path / "g.dat"
    path.write_bytes(b"% Height 180\n% Width 240\n" + bytes([0, 216]) + bytes(432))
    with pytest.raises(RecordingFileError, match=r"not a DAT recording.*records of 216 bytes"):
        uio.read(path)
