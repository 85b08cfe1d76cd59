"""PIX2NVS ("sim"): behaviour, agreement with a direct transcription of PIX2NVS's loop, bad
input, and events around the drone on a real labelled clip."""

from __future__ import annotations

import csv
import ctypes
import ctypes.util
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uavsnn import EVENT_DTYPE, ParameterError, SimulationError
from uavsnn.sim import Pix2NvsParams, Pix2NvsSimulator, pix2nvs, video_to_recording

# ------------------------------------------------------------------------------ reference


def reference_pix2nvs(frames: np.ndarray, times: np.ndarray, p: Pix2NvsParams) -> set[tuple]:
    """PIX2NVS's ``generate_events`` + ``print_event`` loop written out pixel by pixel in
    float32, with this project's documented departures (update at the competing pixel, every
    mode starting from the first frame, clipped edge blocks, top-left origin, log offset)."""
    f32 = np.float32
    lut = np.log(np.arange(256, dtype=np.float64) + p.log_offset).astype(f32)
    n, h, w = frames.shape
    ref = lut[frames[0]].copy()
    thr = np.full((h, w), f32(p.threshold), dtype=f32)
    up, down = f32(1) + f32(p.adaptive), f32(1) - f32(p.adaptive)
    b = p.block_size
    out = set()
    for k in range(1, n):
        inp = lut[frames[k]]
        dt = float(times[k] - times[k - 1])
        for x0 in range(0, w, b):
            for y0 in range(0, h, b):
                best, wx, wy = f32(0), x0, y0
                for x in range(x0, min(x0 + b, w)):  # PIX2NVS: x outer, y inner
                    for y in range(y0, min(y0 + b, h)):
                        d = abs(f32(inp[y, x] - ref[y, x]))
                        if d > best:
                            best, wx, wy = d, x, y
                delta = f32(inp[wy, wx] - ref[wy, wx])
                theta = thr[wy, wx]
                if abs(delta) > theta:
                    count = min(int(f32(abs(delta) / theta)), p.n_max)
                    step = f32(theta / abs(delta))
                    for e in range(1, count + 1):
                        frac = min(e * float(step), 1.0)
                        t = int(times[k - 1]) + int(np.floor(frac * dt + 0.5))
                        out.add((t, wx, wy, bool(delta > 0)))
                    if p.reference == "event_copy":
                        ref[wy, wx] = inp[wy, wx]
                    elif p.reference == "event_increment":
                        ref[wy, wx] = f32(ref[wy, wx] + f32(np.sign(delta) * count) * theta)
                    thr[wy, wx] = min(f32(theta * up), f32(p.threshold_max or np.inf))
                else:
                    thr[wy, wx] = max(f32(theta * down), f32(p.threshold_min))
                if p.reference == "frame":
                    ys, xs = slice(y0, min(y0 + b, h)), slice(x0, min(x0 + b, w))
                    ref[ys, xs] = inp[ys, xs]
    return out


def as_set(events: np.ndarray) -> set[tuple]:
    return {(int(e["t"]), int(e["x"]), int(e["y"]), bool(e["p"])) for e in events}


params_strategy = st.builds(
    Pix2NvsParams,
    threshold=st.floats(0.1, 0.7),
    n_max=st.integers(1, 6),
    reference=st.sampled_from(["frame", "event_copy", "event_increment"]),
    block_size=st.integers(1, 3),
    adaptive=st.sampled_from([0.0, 0.05, 0.3]),
)


@st.composite
def videos(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    n = draw(st.integers(2, 4))
    h = draw(st.integers(1, 6))
    w = draw(st.integers(1, 7))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if draw(st.booleans()):
        frames = rng.integers(0, 256, size=(n, h, w), dtype=np.uint8)
    else:  # a few grey levels: equal changes, so PIX2NVS's tie-breaking matters
        levels = np.array(draw(st.lists(st.integers(0, 255), min_size=2, max_size=3)))
        frames = levels[rng.integers(0, len(levels), size=(n, h, w))].astype(np.uint8)
    steps = draw(st.lists(st.integers(1_000, 50_000), min_size=n, max_size=n))
    return frames, np.cumsum(steps).astype(np.uint64)


# ------------------------------------------------------------------------------ behaviour


@given(videos(), params_strategy)
def test_matches_a_transcription_of_pix2nvs(video, params):
    frames, times = video
    events = pix2nvs(frames, times, params=params)
    assert events.dtype == EVENT_DTYPE
    assert len(as_set(events)) == len(events)  # no duplicates: each (t, x, y, p) once
    assert as_set(events) == reference_pix2nvs(frames, times, params)


@given(videos(), params_strategy)
def test_times_ordered_between_frames_and_n_max_respected(video, params):
    frames, times = video
    ev = pix2nvs(frames, times, params=params)
    assert np.all(np.diff(ev["t"].astype(np.int64)) >= 0)
    assert np.all((ev["t"] > times[0]) & (ev["t"] <= times[-1]))
    # Interval k is (times[k-1], times[k]]; count events per pixel and interval.
    interval = np.searchsorted(times, ev["t"], side="left")
    keys, counts = np.unique(
        np.stack([interval, ev["x"], ev["y"]], axis=1), axis=0, return_counts=True
    )
    assert counts.size == 0 or counts.max() <= params.n_max
    # With inhibition, one pixel per block and interval at most.
    b = params.block_size
    blocks = np.unique(keys[:, 0] * 10**6 + (keys[:, 1] // b) * 1000 + keys[:, 2] // b)
    assert len(blocks) == len(keys)


@given(
    st.integers(0, 255),
    st.integers(1, 5),
    st.sampled_from(["frame", "event_copy", "event_increment"]),
)
def test_static_scene_makes_no_events(level, n, reference):
    frames = np.full((n + 1, 5, 6), level, dtype=np.uint8)
    times = np.arange(n + 1) * 33_333
    assert len(pix2nvs(frames, times, params=Pix2NvsParams(reference=reference))) == 0


def moving_bar(contrast: int, n: int = 6, size: int = 32) -> tuple[np.ndarray, np.ndarray]:
    frames = np.full((n, size, size), 100, dtype=np.uint8)
    for k in range(n):
        frames[k, :, 3 * k : 3 * k + 6] = 100 + contrast
    return frames, np.arange(n) * 33_333


def test_more_contrast_and_lower_threshold_give_more_events():
    counts = [len(pix2nvs(*moving_bar(c))) for c in (20, 60, 150)]
    assert counts[0] < counts[1] < counts[2], counts
    frames, times = moving_bar(60)
    by_threshold = [
        len(pix2nvs(frames, times, params=Pix2NvsParams(threshold=t))) for t in (0.6, 0.3, 0.1)
    ]
    assert by_threshold[0] < by_threshold[1] < by_threshold[2], by_threshold


def test_event_times_follow_a_linear_change_of_log_luma():
    frames = np.array([[[50]], [[200]]], dtype=np.uint8)
    ev = pix2nvs(frames, [0, 30_000], params=Pix2NvsParams(threshold=0.4))
    delta = np.log(201 / 51)
    k = np.arange(1, int(delta / 0.4) + 1)
    np.testing.assert_allclose(ev["t"], 30_000 * k * 0.4 / delta, atol=1)
    assert ev["p"].all()


def test_bgr_uses_bt601_luma_like_float_input():
    rng = np.random.default_rng(5)
    bgr = rng.integers(0, 256, size=(3, 9, 11, 3), dtype=np.uint8)
    luma = bgr.astype(np.float64) @ np.array([0.114, 0.587, 0.299])
    times = [0, 20_000, 40_000]
    a = pix2nvs(bgr, times)
    b = pix2nvs(luma.astype(np.float32), times)
    assert len(a) > 0
    # Same model; float rounding of luma may move a borderline pixel at most.
    assert len(as_set(a) ^ as_set(b)) <= 0.01 * len(a) + 2


def test_deterministic_and_seed_does_not_matter():
    frames, times = moving_bar(80)
    a = pix2nvs(frames, times, seed=0)
    np.testing.assert_array_equal(a, pix2nvs(frames, times, seed=0))
    np.testing.assert_array_equal(a, pix2nvs(frames, times, seed=99))


def test_streaming_in_batches_equals_one_call():
    frames, times = moving_bar(90, n=9)
    whole = pix2nvs(frames, times)
    sim = Pix2NvsSimulator((32, 32))
    parts = [sim.process(frames[i : i + 4], times[i : i + 4]) for i in range(0, 9, 4)]
    np.testing.assert_array_equal(np.concatenate(parts), whole)
    assert sim.frames_seen == 9


def test_pooling_onto_a_smaller_sensor():
    frames, times = moving_bar(120, n=5, size=36)
    full = pix2nvs(frames, times)
    pooled_all = Pix2NvsSimulator((36, 36), output_size=(12, 12), pooling="all")
    every = pooled_all.process(frames, times)
    scaled = full.copy()
    scaled["x"] //= 3
    scaled["y"] //= 3
    np.testing.assert_array_equal(
        np.sort(every, order=list("txyp")), np.sort(scaled, order=list("txyp"))
    )
    strongest = Pix2NvsSimulator((36, 36), output_size=(12, 12)).process(frames, times)
    assert 0 < len(strongest) < len(full)
    assert strongest["x"].max() < 12 and strongest["y"].max() < 12
    interval = np.searchsorted(times, strongest["t"], side="left")
    _, counts = np.unique(
        np.stack([interval, strongest["x"], strongest["y"]], axis=1), axis=0, return_counts=True
    )
    assert counts.max() <= Pix2NvsParams().n_max


# ------------------------------------------------------------------------------ bad input


@pytest.mark.parametrize(
    ("frames", "times", "match"),
    [
        (np.zeros((0, 4, 4), np.uint8), [], "no frames"),
        ([np.zeros((4, 4), np.uint8), np.zeros((5, 4), np.uint8)], [0, 1], "mixed sizes"),
        (np.zeros((4, 4), np.uint8), [0], "shape"),
        (np.zeros((2, 4, 4, 2), np.uint8), [0, 1], "shape"),
        (np.full((2, 3, 3), np.nan, np.float32), [0, 1], "finite"),
        (np.full((2, 3, 3), -1.0), [0, 1], "finite value >= 0"),
        (np.zeros((2, 3, 3), np.uint8), [0], "2 timestamps"),
        (np.zeros((2, 3, 3), np.uint8), [5, 5], "increase strictly"),
        (np.zeros((2, 3, 3), np.uint8), [-5, 5], "negative"),
        (np.zeros((2, 3, 3), np.uint8), [0.0, 1.5], "whole number"),
        (np.zeros((2, 3, 3), dtype=object), [0, 1], "numeric"),
        ("frames.mp4", [0, 1], "NumPy array"),
    ],
)
def test_bad_frames_and_timestamps_raise_simulation_error(frames, times, match):
    with pytest.raises(SimulationError, match=match):
        pix2nvs(frames, times)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"threshold": 0.0},
        {"threshold": float("nan")},
        {"n_max": 0},
        {"n_max": 128},
        {"n_max": 2.5},
        {"reference": "previous"},
        {"block_size": 0},
        {"adaptive": 1.0},
        {"adaptive": -0.1},
        {"log_offset": 0.0},
        {"threshold_min": 0.5},
        {"threshold_max": 0.3},
    ],
)
def test_impossible_parameters_raise_parameter_error(kwargs):
    with pytest.raises(ParameterError):
        Pix2NvsParams(**kwargs)


def test_bad_seed_sizes_and_mismatched_frames():
    frames = np.zeros((2, 4, 4), np.uint8)
    with pytest.raises(ParameterError, match="seed"):
        pix2nvs(frames, [0, 1], seed=-1)
    with pytest.raises(ParameterError):
        Pix2NvsSimulator((4, 4), output_size=(8, 2))
    with pytest.raises(ParameterError, match="pooling"):
        Pix2NvsSimulator((4, 4), output_size=(2, 2), pooling="max")
    sim = Pix2NvsSimulator((4, 4))
    with pytest.raises(SimulationError, match="4x4"):
        sim.process(np.zeros((1, 3, 4), np.uint8), [0])
    sim.process(frames, [10, 20])
    with pytest.raises(SimulationError, match="not after"):
        sim.process(frames, [20, 30])


@pytest.mark.parametrize("params", [3, "defaults", {"threshold": 0.4}])
def test_params_of_another_type_are_a_parameter_error(params: object) -> None:
    # It was a bare TypeError, outside uavsnn's errors (and a command's exit 2).
    with pytest.raises(ParameterError, match="params must be Pix2NvsParams, got"):
        Pix2NvsSimulator((4, 4), params=params)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="params must be Pix2NvsParams"):
        pix2nvs(np.zeros((2, 4, 4), np.uint8), [0, 1], params=params)  # type: ignore[arg-type]


# ------------------------------------------------------------------------------ real clip


def read_boxes(path: Path) -> dict[int, tuple[float, float, float, float]]:
    boxes = {}
    with path.open() as fh:
        for row in csv.DictReader(fh):
            if row["x"]:
                boxes[int(row["frame"]) - 1] = tuple(float(row[k]) for k in "xywh")
    return boxes


def test_events_concentrate_on_the_labelled_drone(shared_data):
    clip = shared_data / "svanstrom-dev" / "V_DRONE_001"
    boxes = read_boxes(clip.with_suffix(".csv"))
    n_frames = 30
    rec = video_to_recording(clip.with_suffix(".mp4"), "sim", (240, 180), max_frames=n_frames)
    w, h = rec.metadata["video_size"]
    # Crop to 4:3, centred, then scale to 240x180 (what the sim path did).
    crop_w, crop_h = (round(h * 4 / 3), h) if w / h > 4 / 3 else (w, round(w * 3 / 4))
    x_off, y_off, s = (w - crop_w) / 2, (h - crop_h) / 2, 240 / crop_w
    ev = rec.events
    frame_of = np.ceil(ev["t"] / (1e6 / rec.metadata["fps"])).astype(int)
    inside = area = 0.0
    total = 0
    for k in range(1, n_frames):
        if k not in boxes:
            continue
        x, y, bw, bh = boxes[k]
        margin = 4  # pixels of the source video: boxes are tight, edges blur
        x0, x1 = (x - margin - x_off) * s, (x + bw + margin - x_off) * s
        y0, y1 = (y - margin - y_off) * s, (y + bh + margin - y_off) * s
        e = ev[frame_of == k]
        inside += np.count_nonzero((e["x"] >= x0) & (e["x"] < x1) & (e["y"] >= y0) & (e["y"] < y1))
        total += len(e)
        area += (x1 - x0) * (y1 - y0) / (240 * 180)
    assert total > 100
    frames_used = sum(1 for k in range(1, n_frames) if k in boxes)
    density_ratio = (inside / total) / (area / frames_used)
    # Events per unit area inside the box against the average over the frame.
    assert density_ratio > 10, density_ratio


# ------------------------------------------------------------------------------ the original


class _FileHeader(ctypes.Structure):
    """``BITMAPFILEHEADER`` as PIX2NVS's ``bmp.h`` declares it: not packed."""

    _fields_ = (
        ("bfType", ctypes.c_uint16),
        ("bfSize", ctypes.c_uint32),
        ("bfReserved1", ctypes.c_uint16),
        ("bfReserved2", ctypes.c_uint16),
        ("bfOffBits", ctypes.c_uint32),
    )


class _InfoHeader(ctypes.Structure):
    _fields_ = tuple(
        (name, kind)
        for name, kind in (
            ("biSize", ctypes.c_uint32),
            ("biWidth", ctypes.c_int32),
            ("biHeight", ctypes.c_int32),
            ("biPlanes", ctypes.c_uint16),
            ("biBitCount", ctypes.c_uint16),
            ("biCompression", ctypes.c_uint32),
            ("biSizeImage", ctypes.c_uint32),
            ("biXPelsPerMeter", ctypes.c_int32),
            ("biYPelsPerMeter", ctypes.c_int32),
            ("biClrUsed", ctypes.c_uint32),
            ("biClrImportant", ctypes.c_uint32),
        )
    )


_LIBM = ctypes.CDLL(ctypes.util.find_library("m"))
_LIBM.logf.restype = ctypes.c_float
_LIBM.logf.argtypes = (ctypes.c_float,)


def bmp_file(frame: np.ndarray) -> bytes:
    """A BGR frame as ffmpeg writes a 24-bit BMP: a 54-byte header, rows bottom up, each padded
    to a multiple of 4 bytes."""
    h, w, _ = frame.shape
    stride = (3 * w + 3) // 4 * 4
    rows = np.zeros((h, stride), dtype=np.uint8)
    rows[:, : 3 * w] = frame[::-1].reshape(h, 3 * w)
    return bytes(54) + rows.tobytes()


def original_readframe(buffer: bytes, w: int, h: int) -> list[list[np.float32]]:
    """``readframe.cpp`` then ``log_frame.cpp``: ``frame[x][y]``, y from the top."""
    header = ctypes.sizeof(_FileHeader) + ctypes.sizeof(_InfoHeader)
    frame = [[np.float32(0)] * h for _ in range(w)]
    for i in range(h - 1, -1, -1):
        for j in range(w):
            k = header + 3 * (w * i + j)
            blue, green, red = (buffer[k + c] if k + c < len(buffer) else 0 for c in range(3))
            luma = np.float32(0.299 * red + 0.587 * green + 0.114 * blue)
            frame[j][h - i - 1] = np.float32(_LIBM.logf(luma))  # log of a float: logf
    return frame


def x86_int(v: np.float32) -> int:
    """C's ``(int)`` of a float on x86-64: INT_MIN when not representable."""
    return int(v) if np.isfinite(v) and -(2.0**31) < v < 2.0**31 else -(2**31)


def original_pix2nvs(
    frames: np.ndarray, time_gap: int, threshold: float, n_max: int, d: int, b: int, a: float
) -> list[tuple[int, int, int, bool]]:
    """``generate_events.cpp`` and ``print_event.cpp`` written out: events ``(t, x, y, p)``
    with ``y`` from the top, in the program's own time (frame ``id`` at ``(id - 1)·gap``)."""
    f32 = np.float32
    n, h, w, _ = frames.shape
    with np.errstate(all="ignore"):
        reference = [[f32(0)] * h for _ in range(w)]
        thr = [[f32(threshold)] * h for _ in range(w)]
        adapt = f32(a)
        if d != 3:
            reference = original_readframe(bmp_file(frames[0]), w, h)
        out = []
        for ident in range(2, n + 1):
            inp = original_readframe(bmp_file(frames[ident - 1]), w, h)
            for i in range(0, w, b):
                for j in range(0, h, b):
                    diff_, si, sj = f32(0), 0, 0
                    for ii in range(b):
                        for jj in range(b):
                            diff = abs(f32(inp[i + ii][j + jj] - reference[i + ii][j + jj]))
                            if diff > diff_:
                                diff_, si, sj = diff, ii, jj
                    delta = f32(inp[i + si][j + sj] - reference[i + si][j + sj])
                    theta = thr[i + si][j + sj]
                    if delta > theta or delta < -theta:
                        on = bool(delta > theta)
                        delta = delta if on else f32(-delta)
                        evenum = min(x86_int(f32(delta / theta)), n_max)
                        for e in range(evenum):
                            t = (time_gap * (e + 1) * float(theta)) / float(delta)
                            t += time_gap * (ident - 1)
                            out.append((math.floor(t + 0.5), i + si, j + sj, on))
                        if d == 2:
                            reference[i][j] = inp[i][j]
                        if d == 3:
                            moved = f32(f32(evenum) * thr[i][j])
                            reference[i][j] = f32(reference[i][j] + (moved if on else -moved))
                        thr[i][j] = f32(f32(1 + adapt) * thr[i][j])
                    else:
                        thr[i][j] = f32(f32(1 - adapt) * thr[i][j])
                    if d == 1:
                        for m in range(b):
                            for q in range(b):
                                reference[i + m][j + q] = inp[i + m][j + q]
    return sorted(out)


def test_the_original_header_structs_put_its_pixels_two_bytes_late():
    # The pixels of a 24-bit BMP start at byte 14 + 40 = 54; the unpacked struct is 16 bytes.
    assert ctypes.sizeof(_FileHeader) + ctypes.sizeof(_InfoHeader) == 56


@st.composite
def colour_videos(draw: st.DrawFn) -> tuple[np.ndarray, int, int]:
    b = draw(st.sampled_from([1, 1, 2]))
    n = draw(st.integers(2, 4))
    h = b * draw(st.integers(1, 3))
    w = b * draw(st.integers(1, 4))  # widths whose BMP rows are padded, and not
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if draw(st.booleans()):
        frames = rng.integers(0, 256, size=(n, h, w, 3), dtype=np.uint8)
    else:  # few levels, black among them: ties, and log(0) = -inf
        levels = np.array(draw(st.lists(st.sampled_from([0, 1, 40, 200]), min_size=2)))
        frames = levels[rng.integers(0, len(levels), size=(n, h, w, 3))].astype(np.uint8)
    return frames, b, draw(st.sampled_from([1_000, 33_000, 40_000]))


@settings(max_examples=150, deadline=None)
@given(
    colour_videos(),
    st.sampled_from([1, 2, 3]),
    st.floats(0.2, 0.7),
    st.integers(1, 5),
    st.sampled_from([0.0, 0.05, 0.1]),
)
def test_compat_reproduces_the_original_program(video, d, threshold, n_max, adaptive):
    frames, b, gap = video
    mode = ("frame", "event_copy", "event_increment")[d - 1]
    params = Pix2NvsParams.original(
        threshold=threshold, n_max=n_max, reference=mode, block_size=b, adaptive=adaptive
    )
    times = np.arange(len(frames), dtype=np.uint64) * gap
    ours = pix2nvs(frames, times, params=params)
    want = original_pix2nvs(frames, gap, threshold, n_max, d, b, adaptive)
    # The program's clock is one frame ahead: frame `id` at (id - 1)·gap, its events after it.
    got = sorted((int(e["t"]) + gap, int(e["x"]), int(e["y"]), bool(e["p"])) for e in ours)
    assert got == want


def test_compat_luma_is_read_two_bytes_late():
    # Only the blue and green of pixel (2, 0) change: the documented model answers at x = 2,
    # the original's luma at x = 1 (blue and green of x + 1 weighed as green and red) — and
    # nowhere else.
    frames = np.full((2, 1, 4, 3), 100, dtype=np.uint8)
    frames[1, 0, 2, :2] = 250
    times = [0, 10_000]
    documented = pix2nvs(frames, times)
    compat = pix2nvs(frames, times, params=Pix2NvsParams.original(adaptive=0.0))
    assert set(documented["x"].tolist()) == {2}
    assert set(compat["x"].tolist()) == {1}


def test_compat_mode_3_starts_from_zero_and_black_never_fires():
    frames = np.full((3, 2, 4, 3), 90, dtype=np.uint8)
    times = [0, 1000, 2000]
    # From a zero reference every pixel's log luma (ln 90 = 4.5) is 11 thresholds of 0.4: the
    # second frame floods, capped at n_max; the first frame is never read.
    ev = pix2nvs(frames, times, params=Pix2NvsParams.original(reference="event_increment"))
    first = ev[ev["t"] <= 1000]
    assert len(first) == 8 * 5 and first["p"].all()
    black = np.zeros((3, 2, 4, 3), dtype=np.uint8)
    black[1] = 120
    assert len(pix2nvs(black, times, params=Pix2NvsParams.original())) == 0


def test_compat_refuses_what_the_original_cannot_do():
    with pytest.raises(ParameterError, match="bounds"):
        Pix2NvsParams.original(threshold_max=1.0)
    with pytest.raises(ParameterError, match="compat"):
        Pix2NvsParams(compat=1)
    with pytest.raises(ParameterError, match="whole number"):
        Pix2NvsSimulator((5, 4), params=Pix2NvsParams.original(block_size=2))
    with pytest.raises(SimulationError, match="8-bit"):
        pix2nvs(np.zeros((2, 4, 4), np.float32), [0, 1], params=Pix2NvsParams.original())
    assert Pix2NvsParams.original().adaptive == 0.05
    assert Pix2NvsParams.original(adaptive=0.0).compat
