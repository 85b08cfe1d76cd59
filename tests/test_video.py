"""Video through OpenCV: reading, cropping, the video-to-recording path, the ``simulate``
command and its preview, and typed errors for unusable videos."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import uavsnn.io
from uavsnn import ParameterError, Recording, SimulationError
from uavsnn.cli import main
from uavsnn.sim import (
    DvsParams,
    Pix2NvsParams,
    crop_to_aspect,
    event_strip,
    iter_video,
    read_video,
    video_to_recording,
)

FPS = 25.0
W, H = 320, 200  # wider than 4:3: the crop takes the centre 267x200


def square_position(k: int) -> tuple[int, int]:
    """Top-left of the moving square in frame ``k`` (source pixels)."""
    return 60 + 8 * k, 70


def write_video(path: Path, n: int = 12, fourcc: str = "MJPG", size=(W, H)) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), FPS, size)
    assert writer.isOpened()
    for k in range(n):
        frame = np.full((size[1], size[0], 3), 60, dtype=np.uint8)
        x, y = square_position(k)
        frame[y : y + 40, x : x + 40] = (200, 220, 240)
        writer.write(frame)
    writer.release()
    return path


@pytest.fixture(scope="module")
def video(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_video(tmp_path_factory.mktemp("video") / "square.avi")


# ------------------------------------------------------------------------------ reading


@given(st.integers(1, 400), st.integers(1, 400), st.sampled_from([4 / 3, 16 / 9, 1.0, 0.5]))
def test_crop_is_centred_and_has_the_aspect_ratio(h, w, aspect):
    frame = np.arange(h * w).reshape(h, w)
    crop = crop_to_aspect(frame, aspect)
    ch, cw = crop.shape
    assert (ch == h) or (cw == w)  # the largest crop keeps one full dimension
    assert abs(cw / ch - aspect) <= max(1 / ch, aspect / ch) + 1e-9 or min(ch, cw) == 1
    y0, x0 = divmod(int(crop[0, 0]), w)
    assert abs((w - cw) - 2 * x0) <= 1 and abs((h - ch) - 2 * y0) <= 1


def test_read_video_crops_resizes_and_times_frames(video):
    frames, times = read_video(video)
    assert frames.shape == (12, 180, 240) and frames.dtype == np.uint8
    np.testing.assert_array_equal(times, np.round(np.arange(12) * 1e6 / FPS))
    bgr, _ = read_video(video, size=(64, 48), max_frames=3, color="bgr")
    assert bgr.shape == (3, 48, 64, 3)
    native, _ = read_video(video, size=None, max_frames=2)
    assert native.shape == (2, H, W)
    # The square moves right: the bright column's centre grows with the frame index.
    centres = [np.argwhere(f > 150)[:, 1].mean() for f in frames]
    assert np.all(np.diff(centres) > 0)


@pytest.mark.parametrize(("fourcc", "ext"), [("mp4v", "mp4"), ("FFV1", "mkv")])
def test_other_formats(tmp_path, fourcc, ext):
    path = write_video(tmp_path / f"clip.{ext}", n=4, fourcc=fourcc)
    frames, _ = read_video(path, size=(40, 30))
    assert frames.shape == (4, 30, 40)


def test_unreadable_missing_and_empty_videos_raise_simulation_error(tmp_path):
    with pytest.raises(SimulationError, match="does not exist"):
        read_video(tmp_path / "nope.mp4")
    with pytest.raises(SimulationError, match="not a file"):
        read_video(tmp_path)
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"this is not a video" * 50)
    with pytest.raises(SimulationError):
        read_video(junk)
    empty = tmp_path / "empty.avi"
    cv2.VideoWriter(str(empty), cv2.VideoWriter_fourcc(*"MJPG"), FPS, (32, 24)).release()
    with pytest.raises(SimulationError):
        read_video(empty)
    with pytest.raises(SimulationError):
        video_to_recording(empty)


def test_bad_reading_parameters(video):
    with pytest.raises(ParameterError):
        read_video(video, size=(0, 10))
    with pytest.raises(ParameterError):
        read_video(video, max_frames=0)
    with pytest.raises(ParameterError):
        read_video(video, color="rgb")  # type: ignore[arg-type]
    with pytest.raises(ParameterError):
        read_video(video, fps=-1.0)
    times = [t for _, t in iter_video(video, fps=50.0, max_frames=3)]
    assert times == [0, 20_000, 40_000]  # fps= overrides the container's 25


# ------------------------------------------------------------------------------ recordings


def square_box(k: int, scale: float, x_crop: float) -> tuple[float, float, float, float]:
    x, y = square_position(k)
    return (x - x_crop) * scale, y * scale, (x + 40 - x_crop) * scale, (y + 40) * scale


@pytest.mark.parametrize(
    ("mode", "downsample"), [("sim", "events"), ("sim", "frames"), ("dvs", "frames")]
)
def test_video_to_recording_puts_events_on_the_moving_square(video, mode, downsample):
    # Without noise, every event should come from the square.
    quiet = DvsParams(leak_rate_hz=0.0, shot_noise_rate_hz=0.0, hot_pixel_fraction=0.0)
    params = quiet if mode == "dvs" else None
    rec = video_to_recording(video, mode, (120, 90), 1, params=params, downsample=downsample)
    assert isinstance(rec, Recording) and rec.sensor_size == (120, 90)
    assert rec.metadata["mode"] == mode and rec.metadata["frames"] == 12
    assert rec.metadata["downsample"] == downsample and rec.metadata["seed"] == 1
    assert len(rec) > 0
    crop_w = round(H * 4 / 3)
    scale, x_crop = 120 / crop_w, (W - crop_w) // 2
    ev = rec.events
    # Every event of the square's interval k lies near the square in frames k-1 and k.
    k = np.ceil(ev["t"] / (1e6 / FPS)).astype(int)
    x0 = np.array([square_box(i - 1, scale, x_crop)[0] for i in k]) - 2
    x1 = np.array([square_box(i, scale, x_crop)[2] for i in k]) + 2
    y0, y1 = 70 * scale - 2, 110 * scale + 2
    near = (ev["x"] >= x0) & (ev["x"] <= x1) & (ev["y"] >= y0) & (ev["y"] <= y1)
    assert near.mean() > 0.99, near.mean()


def test_events_downsampling_follows_the_paper_and_is_denser(video):
    by_events = video_to_recording(video, "sim", (120, 90), downsample="events")
    by_frames = video_to_recording(video, "sim", (120, 90), downsample="frames")
    assert len(by_events) > len(by_frames)
    every = video_to_recording(video, "sim", (120, 90), pooling="all")
    assert len(every) > len(by_events)


def test_recording_parameters_are_checked(video):
    with pytest.raises(ParameterError, match="downsample"):
        video_to_recording(video, "dvs", downsample="events")
    with pytest.raises(ParameterError, match="Pix2NvsParams"):
        video_to_recording(video, "sim", params=DvsParams())
    with pytest.raises(ParameterError, match="mode"):
        video_to_recording(video, "aps")  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="smaller"):
        video_to_recording(video, "sim", (640, 480))
    rec = video_to_recording(video, "sim", (640, 480), downsample="frames", max_frames=3)
    assert rec.sensor_size == (640, 480)
    params = Pix2NvsParams(threshold=0.2)
    assert video_to_recording(video, params=params, max_frames=2).metadata["params"][
        "threshold"
    ] == pytest.approx(0.2)


@pytest.mark.parametrize(("mode", "size"), [("dvs", (30000, 30000)), ("sim", (65535, 65535))])
def test_a_sensor_over_the_engines_cap_is_refused_before_a_frame_is_resized(
    video, monkeypatch, mode, size
):
    # Each frame was resized to the sensor first: OpenCV raised its own error (2.7 GB a frame)
    # before the engine's cap was checked.
    import uavsnn.sim.video as sim_video

    def no_frames(*args, **kwargs):
        raise AssertionError("a frame was decoded before the sensor size was checked")

    monkeypatch.setattr(sim_video, "iter_video", no_frames)
    with pytest.raises(ParameterError, match="MAX_ALLOC_BYTES"):
        video_to_recording(video, mode, size, downsample="frames")


def test_progress_callback_counts_frames(video):
    seen: list[int] = []
    video_to_recording(video, "dvs", (60, 45), progress=seen.append)
    assert seen[-1] == 12 and seen == sorted(seen)


# ------------------------------------------------------------------------------ command line


def test_simulate_command_writes_recording_and_preview(video, tmp_path, capsys):
    out, png = tmp_path / "out.npz", tmp_path / "out.png"
    code = main(
        [
            *("simulate", str(video), "-o", str(out), "--size", "120x90"),
            *("--preview", str(png), "--mode", "dvs", "--seed", "5", "--json"),
        ]
    )
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    with np.load(out, allow_pickle=False) as data:
        events, sensor = data["events"], data["sensor_size"]
    assert tuple(sensor) == (120, 90) and len(events) == summary["events"] > 0
    assert np.all(np.diff(events["t"].astype(np.int64)) >= 0)
    image = cv2.imread(str(png))
    assert image is not None and image.shape[0] == 2 * 90
    # The preview shows events: some panels hold coloured pixels, not only background.
    assert (image.reshape(-1, 3).max(axis=1) > 100).mean() > 0.001


def test_simulate_command_reports_errors(tmp_path, capsys):
    out = tmp_path / "x.npz"
    assert main(["simulate", str(tmp_path / "missing.mp4"), "-o", str(out)]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["simulate", str(tmp_path), "-o", str(out), "--size", "0x4"]) == 2
    assert not out.exists()


@pytest.mark.parametrize(
    ("flag", "said"), [("--fps", "fps must be"), ("--max-frames", "max_frames")]
)
def test_simulate_refuses_a_frame_count_or_rate_before_it_starts(
    video, tmp_path, capsys, flag, said
):
    """Refused before the progress line: it said "done" and then the error."""
    out = tmp_path / "x.npz"
    assert main(["simulate", str(video), "-o", str(out), flag, "0"]) == 2
    err = capsys.readouterr().err
    assert said in err and "done" not in err and "frames" not in err.split("error:")[0], err
    assert not out.exists()


def test_a_container_frame_rate_is_held_to_the_range_a_given_one_is(tmp_path: Path) -> None:
    """A video whose container said 0.5 fps was taken (its frames two seconds apart) where
    --fps 0.5 was refused: the container's rate is held to FPS_RANGE too, and --fps still
    gives the rate its frames were taken at."""
    slow = tmp_path / "slow.avi"
    writer = cv2.VideoWriter(str(slow), cv2.VideoWriter_fourcc(*"MJPG"), 0.5, (W, H))
    for k in range(3):
        writer.write(np.full((H, W, 3), 60 + 40 * k, dtype=np.uint8))
    writer.release()
    with pytest.raises(SimulationError, match=r"0\.5 fps; a frame rate is from 1 to 1,000,000"):
        next(iter_video(slow))
    assert [t for _, t in iter_video(slow, fps=25.0)] == [0, 40_000, 80_000]


@pytest.mark.parametrize("fps", ["1e-6", "0.5", "0", "-5", "nan", "inf", "2e6"])
def test_simulate_refuses_an_absurd_frame_rate_naming_the_range(video, tmp_path, capsys, fps):
    """--fps 1e-6 was taken (a frame every 11.6 days; PIX2NVS wrote its events, the DVS
    emulator refused only after decoding); the others said "fps", not the option or its range."""
    out = tmp_path / "x.npz"
    assert main(["simulate", str(video), "-o", str(out), "--fps", fps]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "uavsnn simulate: error: --fps must be" in err[0], err
    assert "from 1 to 1,000,000 frames per second" in err[0], err
    assert not out.exists()
    with pytest.raises(ParameterError, match=r"fps must be .* from 1 to 1,000,000"):
        video_to_recording(video, fps=float(fps))
    with pytest.raises(ParameterError, match="fps must be"):
        next(iter_video(video, fps=float(fps)))


def test_start_begins_partway_in_the_videos_time(video):
    """A long video could only be simulated from its first frame. Frame i keeps its time
    i/fps: the events from frame 5 on (0.2 s at 25 fps) are those of the whole video there."""
    whole = video_to_recording(video, "sim", (120, 90), downsample="frames")
    part = video_to_recording(video, "sim", (120, 90), downsample="frames", start=0.2)
    assert part.metadata["start_s"] == 0.2 and part.metadata["start_frame"] == 5
    assert part.metadata["frames"] == 7 and "start_s" not in whole.metadata
    np.testing.assert_array_equal(part.events, whole.events[whole.events["t"] > 200_000])
    # Between frames: the next frame (0.21 s: frame 6 at 240 ms); with --max-frames, N frames
    # from the start.
    short = video_to_recording(video, "sim", (120, 90), start=0.21, max_frames=3)
    assert short.metadata["start_frame"] == 6 and short.metadata["frames"] == 3
    assert 240_000 < short.events["t"].min() and short.events["t"].max() <= 320_000
    # The start is on the time the frames are given: fps=50 puts frame 5 at 0.1 s.
    times = [t for _, t in iter_video(video, start=0.1, fps=50.0)]
    assert times == list(range(100_000, 240_000, 20_000))
    frames, times = read_video(video, start=0.2, max_frames=2)
    whole, _ = read_video(video, max_frames=7)
    np.testing.assert_array_equal(frames, whole[5:])
    assert times.tolist() == [200_000, 240_000]


def test_a_start_at_or_past_the_end_is_refused_before_any_output(video, tmp_path, capsys):
    # The 12 frames at 25 fps end at 0.48 s; a start at frame 11 leaves one frame, no events.
    for start in (0.48, 0.5, 3600.0):
        with pytest.raises(ParameterError, match=r"start=.* is at or past the end of .*12 frames"):
            video_to_recording(video, start=start)
    with pytest.raises(SimulationError, match=r"gave 1 frame from start=0\.44 s"):
        video_to_recording(video, start=0.44)
    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ParameterError, match="start must be"):
            video_to_recording(video, start=bad)
    out = tmp_path / "x.npz"
    for start, said in (("0.48", "is at or past the end"), ("-1", "--start must be >= 0")):
        assert main(["simulate", str(video), "-o", str(out), "--start", start]) == 2
        err = capsys.readouterr().err
        assert said in err and "done" not in err and "frames" not in err.split("error:")[0], err
        assert not out.exists()
    scene = ["simulate", "--scene", "uav", "-o", str(out), "--start", "1"]
    assert main(scene) == 2
    assert "--start: for a video" in capsys.readouterr().err
    assert main(["simulate", str(video), "-o", str(out), "--start", "0.2", "--quiet"]) == 0
    assert uavsnn.io.read(out).metadata["start_frame"] == 5


def test_simulate_command_sets_the_pix2nvs_model(video, tmp_path, capsys):
    out = tmp_path / "compat.npz"
    argv = ["simulate", str(video), "-o", str(out), "--size", "120x90", "--json"]
    assert main([*argv, "--pix2nvs-compat", "--threshold", "0.3", "--reference", "frame"]) == 0
    params = json.loads(capsys.readouterr().out)["params"]
    assert params["compat"] is True and params["threshold"] == 0.3 and params["adaptive"] == 0.05
    with np.load(out, allow_pickle=False) as data:
        compat = data["events"]
    assert main([*argv, "--threshold", "0.3", "--adaptive", "0.05"]) == 0
    params = json.loads(capsys.readouterr().out)["params"]
    assert params["compat"] is False and params["log_offset"] == 1.0
    with np.load(out, allow_pickle=False) as data:
        assert not np.array_equal(data["events"], compat)
    # Model options are for PIX2NVS: an error in one line with dvs, and for impossible values.
    for bad in (["--mode", "dvs", "--threshold", "0.3"], ["--n-max", "0"]):
        assert main([*argv, *bad]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1, err


def test_event_strip_of_an_empty_recording():
    from uavsnn.events import EVENT_DTYPE

    img = event_strip(Recording(np.zeros(0, EVENT_DTYPE), (20, 10)), panels=3, scale=1)
    assert img.shape == (10, 3 * 20 + 2 * 2, 3)


def test_a_single_frame_or_an_image_is_refused_not_an_empty_recording(tmp_path: Path) -> None:
    """One frame (an image, max_frames=1) made an empty recording, exit 0, with a frame rate
    OpenCV makes up for images (a new user's walk)."""
    from uavsnn import SimulationError

    one = write_video(tmp_path / "one.avi", n=1)
    image = tmp_path / "still.png"
    cv2.imwrite(str(image), np.full((H, W, 3), 90, dtype=np.uint8))
    for path, limit in ((one, None), (write_video(tmp_path / "two.avi", n=3), 1), (image, None)):
        with pytest.raises(SimulationError, match="a recording needs at least 2"):
            video_to_recording(path, "dvs", (W // 2, H // 2), max_frames=limit)
    assert len(video_to_recording(tmp_path / "two.avi", "dvs", (W // 2, H // 2), max_frames=2))


def test_frames_scaled_up_are_said(video: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A sensor larger than the video's crop (frames resized up) gave events of the crop's
    size spread over the sensor, every pixel block alike, without a word."""
    from uavsnn.cli import main

    rec = video_to_recording(video, "dvs", (640, 480), max_frames=4)
    assert rec.metadata["upscaled_from"] == [267, 200] and rec.sensor_size == (640, 480)
    own = video_to_recording(video, "dvs", (240, 180), max_frames=4)
    assert "upscaled_from" not in own.metadata
    out = video.parent / "up.npz"
    argv = ["simulate", str(video), "-o", str(out), "--mode", "dvs", "--size", "640x480"]
    assert main([*argv, "--max-frames", "4"]) == 0
    err = capsys.readouterr().err
    assert "note: the video's 267x200 crop is smaller than the 640x480 sensor" in err


def test_a_stopped_progress_bar_says_no_done(capsys: pytest.CaptureFixture[str]) -> None:
    """simulate's progress line said "done" just before "interrupted"."""
    import sys

    from uavsnn.progress import LineProgress, stop

    line = LineProgress(10, "clip", " frame", stream=sys.stderr)
    line.update(3)
    stop(line)
    line.close()  # closed already: nothing more
    assert "done" not in capsys.readouterr().err


def test_the_dvs_model_is_set_from_the_command_line(
    video: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A video through --mode dvs took DvsParams() and a scene SCENE_PARAMS, with no way to
    change either from the command line (a new user's walk)."""
    from dataclasses import asdict, replace

    from uavsnn.cli import main
    from uavsnn.io import read
    from uavsnn.sim import SCENE_PARAMS, DvsParams

    out = tmp_path / "d.npz"
    base = ["simulate", str(video), "-o", str(out), "--mode", "dvs", "--max-frames", "4"]
    cases = [
        ([], DvsParams()),
        (["--dvs-preset", "ideal"], DvsParams.ideal()),
        (["--dvs-set", "cutoff_hz=3000", "--dvs-set", "threshold_on=0.3"],
         DvsParams(cutoff_hz=3000.0, threshold_on=0.3)),
        (["--dvs-preset", "scene", "--dvs-set", "leak_rate_hz=0"],
         replace(SCENE_PARAMS, leak_rate_hz=0.0)),
    ]  # fmt: skip
    for extra, want in cases:
        assert main([*base, *extra, "--quiet"]) == 0
        capsys.readouterr()
        assert read(out).metadata["params"] == asdict(want)
    scene = ["simulate", "--scene", "uav", "-o", str(out), "--duration", "0.02", "--quiet"]
    for extra, want in (([], SCENE_PARAMS), (["--dvs-preset", "default"], DvsParams())):
        assert main([*scene, *extra]) == 0
        assert read(out).metadata["params"] == asdict(want)
    for extra, match in (
        (["--dvs-set", "bogus=1"], "expected NAME=VALUE with NAME one of cutoff_dark_luma"),
        (["--dvs-set", "cutoff_hz"], "expected NAME=VALUE"),
        (["--dvs-set", "cutoff_hz=abc"], "'abc' is not a number"),
        (["--dvs-set", "cutoff_hz=-1"], "cutoff_hz must be >= 0"),
    ):
        assert main([*base, *extra]) == 2
        assert match in capsys.readouterr().err
    sim = ["simulate", str(video), "-o", str(out), "--dvs-preset", "gen3"]
    assert main(sim) == 2
    assert "which --mode sim does not use" in capsys.readouterr().err


def test_a_slow_video_through_the_dvs_emulator_is_said(
    video: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """30 fps video went into --mode dvs without a word, though the emulator wants frames at a
    high rate (a new user's walk): a note below SLOW_FPS, which PIX2NVS (sim) does not need."""
    from uavsnn.cli import main
    from uavsnn.cli.simulate import SLOW_FPS

    out = tmp_path / "d.npz"
    base = ["simulate", str(video), "-o", str(out), "--max-frames", "3", "--quiet"]
    for mode, fps, said in (("dvs", None, True), ("dvs", "500", False), ("sim", None, False)):
        assert main([*base, "--mode", mode, *(["--fps", fps] if fps else [])]) == 0
        err = capsys.readouterr().err
        assert ("note: the video's 25 fps frames hold nothing faster than 12.5 Hz" in err) == said
    assert FPS < SLOW_FPS <= 500
