"""The DVS emulator ("dvs"): exact crossings, noise rates within statistical bounds, refractory
period, low light, determinism, and bad input."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from uavsnn import EVENT_DTYPE, ParameterError, SimulationError
from uavsnn.sim import DvsEmulator, DvsParams, emulate_dvs


def linlog(y: np.ndarray, threshold: float = 20.0) -> np.ndarray:
    """v2e's lin_log, the emulator's response."""
    y = np.asarray(y, dtype=np.float64)
    return np.where(y <= threshold, y * np.log(threshold) / threshold, np.log(np.maximum(y, 1)))


def static(level: float, n: int, shape=(40, 50)) -> np.ndarray:
    return np.full((n, *shape), level, dtype=np.float32)


def poisson_ok(count: int, expected: float, z: float = 5.0) -> bool:
    """|count - expected| within z standard deviations of a Poisson count."""
    return abs(count - expected) <= z * np.sqrt(expected)


@st.composite
def float_videos(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    n = draw(st.integers(2, 5))
    h = draw(st.integers(1, 5))
    w = draw(st.integers(1, 6))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    frames = rng.uniform(0, 255, size=(n, h, w)).astype(np.float32)
    steps = draw(st.lists(st.integers(100, 20_000), min_size=n, max_size=n))
    return frames, np.cumsum(steps).astype(np.uint64)


# ------------------------------------------------------------------------------ signal


@given(float_videos(), st.floats(0.05, 0.5))
def test_ideal_sensor_counts_every_threshold_crossing(video, theta):
    """Each event moves the memorised level by exactly one threshold, so what is left between
    the last and the first response is less than one threshold, at every pixel."""
    frames, times = video
    params = DvsParams.ideal(threshold_on=theta, threshold_off=theta)
    ev = emulate_dvs(frames, times, params=params)
    h, w = frames.shape[1:]
    net = np.zeros((h, w))
    np.add.at(net, (ev["y"], ev["x"]), np.where(ev["p"], 1.0, -1.0))
    residual = linlog(frames[-1]) - linlog(frames[0]) - net * theta
    assert np.all(np.abs(residual) < theta + 1e-3), residual


@given(float_videos(), st.integers(0, 3))
def test_times_lie_between_frames_and_are_ordered(video, seed):
    frames, times = video
    ev = emulate_dvs(frames, times, params=DvsParams(shot_noise_rate_hz=500.0), seed=seed)
    assert ev.dtype == EVENT_DTYPE
    assert np.all(np.diff(ev["t"].astype(np.int64)) >= 0)
    assert np.all((ev["t"] >= times[0]) & (ev["t"] <= times[-1]))


def test_crossing_times_are_interpolated_and_not_capped():
    # One interval, ln(240/30) = 2.08 = 10 thresholds of 0.2: ten ON events in one interval.
    frames = np.array([[[30.0]], [[240.0]]], dtype=np.float32)
    ev = emulate_dvs(frames, [1_000, 101_000], params=DvsParams.ideal())
    slope = np.log(8) / 100_000
    k = np.arange(1, 11)
    assert len(ev) == 10 and ev["p"].all()
    np.testing.assert_allclose(ev["t"], 1_000 + 0.2 * k / slope, atol=1)


@given(st.floats(0, 255), st.integers(1, 4), st.integers(0, 5))
def test_static_scene_without_noise_is_silent(level, n, seed):
    params = DvsParams(leak_rate_hz=0.0, shot_noise_rate_hz=0.0, hot_pixel_fraction=0.0)
    frames = static(level, n + 1, shape=(6, 7))
    assert len(emulate_dvs(frames, np.arange(n + 1) * 1_000, params=params, seed=seed)) == 0


def moving_bar(contrast: float, n: int = 20, size: int = 32) -> tuple[np.ndarray, np.ndarray]:
    frames = np.full((n, size, size), 80.0, dtype=np.float32)
    for k in range(n):
        frames[k, :, k : k + 5] = 80.0 + contrast
    return frames, np.arange(n) * 1_000


def test_more_contrast_and_lower_threshold_give_more_events():
    quiet = DvsParams(leak_rate_hz=0.0, shot_noise_rate_hz=0.0, hot_pixel_fraction=0.0)
    counts = [len(emulate_dvs(*moving_bar(c), params=quiet)) for c in (15, 60, 160)]
    assert counts[0] < counts[1] < counts[2], counts
    frames, times = moving_bar(60)
    by_threshold = [
        len(
            emulate_dvs(
                frames,
                times,
                params=DvsParams.ideal(threshold_on=t, threshold_off=t),
            )
        )
        for t in (0.5, 0.25, 0.1)
    ]
    assert by_threshold[0] < by_threshold[1] < by_threshold[2], by_threshold


def test_refractory_period_spaces_each_pixels_events():
    frames, times = moving_bar(200, n=30)
    params = DvsParams(refractory_us=2_500.0, shot_noise_rate_hz=200.0)
    ev = emulate_dvs(frames, times, params=params, seed=1)
    order = np.lexsort((ev["t"], ev["x"].astype(np.int64) * 1000 + ev["y"]))
    e = ev[order]
    same = (np.diff(e["x"].astype(int)) == 0) & (np.diff(e["y"].astype(int)) == 0)
    gaps = np.diff(e["t"].astype(np.int64))[same]
    assert len(gaps) > 0 and gaps.min() >= 2_500
    free = emulate_dvs(frames, times, params=DvsParams(refractory_us=0.0, shot_noise_rate_hz=200.0))
    assert len(free) > len(ev)


# ------------------------------------------------------------------------------ noise rates

SECONDS = 10
TIMES = np.arange(SECONDS + 1) * 1_000_000


def test_leak_rate_matches_within_poisson_bound():
    params = DvsParams.ideal(leak_rate_hz=1.5, leak_spread_decades=0.05)
    ev = emulate_dvs(static(120, SECONDS + 1), TIMES, params=params, seed=4)
    expected = 1.5 * SECONDS * 40 * 50
    assert poisson_ok(len(ev), expected), (len(ev), expected)
    assert ev["p"].all()  # leak makes ON events


@pytest.mark.parametrize(("level", "factor"), [(0.0, 1.0), (255.0, 0.25)])
def test_shot_noise_rate_and_polarity_split(level, factor):
    params = DvsParams.ideal(shot_noise_rate_hz=2.0, shot_noise_bright_factor=0.25)
    ev = emulate_dvs(static(level, SECONDS + 1), TIMES, params=params, seed=2)
    expected = 2.0 * factor * SECONDS * 40 * 50
    assert poisson_ok(len(ev), expected), (len(ev), expected)
    on = int(ev["p"].sum())
    assert abs(on - len(ev) / 2) <= 5 * np.sqrt(len(ev) / 4), (on, len(ev))


def test_darker_scenes_are_noisier():
    params = DvsParams(leak_rate_hz=0.0, hot_pixel_fraction=0.0, shot_noise_rate_hz=3.0)
    dark = emulate_dvs(static(5, 4), TIMES[:4], params=params)
    bright = emulate_dvs(static(250, 4), TIMES[:4], params=params)
    assert len(dark) > 2 * len(bright)


def test_hot_pixels_fraction_and_rate():
    params = DvsParams.ideal(hot_pixel_fraction=0.01, hot_pixel_rate_hz=50.0)
    emulator = DvsEmulator((50, 40), params=params, seed=9)
    ev = emulator.process(static(100, SECONDS + 1), TIMES)
    hot = emulator.hot_pixels()
    assert len(hot) == round(0.01 * 50 * 40)
    fired = {(int(x), int(y)) for x, y in zip(ev["x"], ev["y"], strict=True)}
    assert fired == {(int(x), int(y)) for x, y in hot}
    assert poisson_ok(len(ev), 50.0 * SECONDS * len(hot))
    assert ev["p"].all()


def test_low_light_slows_the_response():
    """The photoreceptor's cutoff scales with intensity: after the same log step, a dark pixel
    takes longer to report it than a bright one."""
    params = DvsParams.ideal(cutoff_hz=100.0)
    times = np.arange(60) * 1_000

    def first_event_after_step(low: float) -> int:
        frames = np.full((60, 1, 1), low, dtype=np.float32)
        frames[10:] = 2 * low
        ev = emulate_dvs(frames, times, params=params)
        assert len(ev) > 0
        return int(ev["t"][0]) - 9_000

    assert first_event_after_step(30.0) > first_event_after_step(120.0)


# ------------------------------------------------------------------------------ determinism


def test_same_seed_same_events_other_seed_other_noise():
    frames, times = moving_bar(100)
    params = DvsParams(shot_noise_rate_hz=100.0, hot_pixel_fraction=0.01)
    a = emulate_dvs(frames, times, params=params, seed=11)
    np.testing.assert_array_equal(a, emulate_dvs(frames, times, params=params, seed=11))
    b = emulate_dvs(frames, times, params=params, seed=12)
    assert not np.array_equal(a, b)


def test_streaming_in_batches_equals_one_call():
    frames, times = moving_bar(100, n=12)
    params = DvsParams(shot_noise_rate_hz=100.0)
    whole = emulate_dvs(frames, times, params=params, seed=3)
    emulator = DvsEmulator((32, 32), params=params, seed=3)
    parts = [emulator.process(frames[i : i + 5], times[i : i + 5]) for i in range(0, 12, 5)]
    np.testing.assert_array_equal(np.concatenate(parts), whole)


def test_uint8_and_bgr_frames_are_accepted():
    frames, times = moving_bar(100)
    gray8 = frames.astype(np.uint8)
    a = emulate_dvs(gray8, times, params=DvsParams.ideal())
    b = emulate_dvs(np.repeat(gray8[..., None], 3, axis=3), times, params=DvsParams.ideal())
    np.testing.assert_array_equal(a, b)  # equal B, G, R: luma is the grey value


@pytest.mark.parametrize("start", [2**53 + 1, 2**62 - 10_000_000])
def test_timestamps_beyond_double_precision_stay_in_their_interval(start):
    from uavsnn.sim import pix2nvs

    frames, _ = moving_bar(150, n=6)
    times = np.uint64(start) + np.arange(6, dtype=np.uint64) * np.uint64(1_000_001)
    for ev in (
        emulate_dvs(frames, times, params=DvsParams(shot_noise_rate_hz=20.0)),
        pix2nvs(frames, times),
    ):
        assert len(ev) > 0
        assert np.all((ev["t"] >= times[0]) & (ev["t"] <= times[-1]))
        assert np.all(np.diff(ev["t"]) < 2**63)  # non-decreasing as unsigned


# ------------------------------------------------------------------------------ bad input


def test_frames_far_apart_are_refused_before_the_emulator_moves() -> None:
    # Times in ns by mistake, or a clock that jumps by days: the noise of the gap alone would
    # be billions of events (the process aborted on the allocation).
    frames = np.stack([np.full((48, 64), 128, np.uint8)] * 3)
    emulator = DvsEmulator((64, 48), seed=1)
    emulator.process(frames[:1], [0])
    with pytest.raises(SimulationError, match="are the times in microseconds"):
        emulator.process(frames[1:2], [10**12])
    later = emulator.process(frames[1:], [1_000, 2_000])
    np.testing.assert_array_equal(later, emulate_dvs(frames, [0, 1_000, 2_000], seed=1))


def test_frame_times_past_2_64_and_past_the_engines_latest() -> None:
    frames = np.zeros((2, 4, 4), np.uint8)
    with pytest.raises(SimulationError, match="beyond 2\\^64 - 1"):
        emulate_dvs(frames, [0.0, 1e20])
    # Past 2^62 µs, the latest time the engine takes (across 2^63 too: a difference through
    # int64 once wrapped there): refused, not made into events no window can hold.
    for times in ([2**62 - 5, 2**62 + 5], [2**63 - 5, 2**63 + 5]):
        with pytest.raises(SimulationError, match="beyond the latest time"):
            emulate_dvs(frames, np.array(times, dtype=np.uint64))
    assert len(emulate_dvs(frames, np.array([2**62 - 5, 2**62], dtype=np.uint64))) == 0


@pytest.mark.parametrize(
    "kwargs",
    [
        {"threshold_on": 0.0},
        {"threshold_off": -0.2},
        {"threshold_sigma": float("nan")},
        {"refractory_us": -1.0},
        {"leak_rate_hz": float("inf")},
        {"leak_spread_decades": 5.0},
        {"shot_noise_rate_hz": -1.0},
        {"shot_noise_rate_hz": 2e6},
        {"shot_noise_bright_factor": -0.5},
        {"hot_pixel_fraction": 1.5},
        {"hot_pixel_rate_hz": -3.0},
        {"cutoff_hz": float("nan")},
        {"linlog_threshold": 0.0},
        {"threshold_on": "0.2"},
    ],
)
def test_impossible_parameters_raise_parameter_error(kwargs):
    with pytest.raises(ParameterError):
        DvsParams(**kwargs)


def test_bad_frames_seed_and_size():
    with pytest.raises(SimulationError, match="mixed sizes"):
        emulate_dvs([np.zeros((4, 4)), np.zeros((4, 5))], [0, 1])
    with pytest.raises(SimulationError, match="increase strictly"):
        emulate_dvs(np.zeros((3, 4, 4)), [0, 2, 1])
    with pytest.raises(ParameterError, match="seed"):
        emulate_dvs(np.zeros((2, 4, 4)), [0, 1], seed=2**64)
    with pytest.raises(ParameterError, match="sensor_size"):
        DvsEmulator((0, 4))
    emulator = DvsEmulator((4, 4))
    with pytest.raises(SimulationError, match="4x4"):
        emulator.process(np.zeros((1, 4, 5)), [0])


def test_float_frames_past_white_are_taken_and_a_negative_bgr_channel_is_refused() -> None:
    """Float frames are on the 0-255 scale and may go past 255 (light brighter than white, the
    "dvs" renderer's flickering light): taken, not clipped. A BGR pixel with a negative
    channel under a luma >= 0 (-100 blue, 200 red: luma 48.4) was taken; NaN was refused."""
    from uavsnn.sim import pix2nvs

    times = [0, 1_000]
    white = np.full((2, 4, 4), 100.0, np.float32)
    white[1] = 255.0
    brighter = np.where(white > 200.0, np.float32(400.0), white)
    ideal = DvsParams.ideal()
    to_white = len(emulate_dvs(white, times, params=ideal))
    assert len(emulate_dvs(brighter, times, params=ideal)) > to_white > 0
    bgr = np.full((2, 4, 4, 3), 100.0)
    bgr[1, 2, 3] = (-100.0, 0.0, 200.0)
    nan = np.full((2, 4, 4), 100.0, np.float32)
    nan[1, 0, 0] = np.nan
    for frames, said in (
        (bgr, r"frame 1: pixel \(x=3, y=2\) has intensity \(B, G, R\) \(-100.0, 0.0, 200.0\)"),
        (nan, r"frame 1: pixel \(x=0, y=0\) has intensity nan, expected a finite value >= 0"),
    ):
        for simulate in (emulate_dvs, pix2nvs):
            with pytest.raises(SimulationError, match=said):
                simulate(frames, times)


def test_process_frame_with_sub_frame_samples_and_bad_patches() -> None:
    """A patch's sub-frame samples reach its pixels (a flash between two equal frames makes
    events there and nowhere else); patches off the sensor, overlapping, with times outside the
    interval or values of the wrong shape are refused with nothing consumed."""
    emu = DvsEmulator((8, 6), params=DvsParams.ideal())
    flat = np.full((6, 8), 50.0, np.float32)
    assert len(emu.process_frame(flat, 0)) == 0
    flash = np.full((2, 3, 2), 50.0, np.float32)
    flash[0] = 200.0
    times = np.array([300, 600], np.uint64)
    ev = emu.process_frame(flat, 1000, [(4, 2, times, flash)])
    assert len(ev) > 0
    assert set(ev["x"].tolist()) <= {4, 5} and set(ev["y"].tolist()) <= {2, 3, 4}
    assert ev["t"].min() < 300 and ev["t"].max() <= 600
    bad = [
        [(7, 0, times, flash)],
        [(0, 0, np.array([1000, 1500], np.uint64), flash)],
        [(0, 0, times[:1], flash)],
        [(0, 0, times, flash), (1, 1, times, flash)],
        [(0, 0, times, flash[0])],
    ]
    for patches in bad:
        with pytest.raises(SimulationError):
            emu.process_frame(flat, 2000, patches)
    assert emu.frames_seen == 2
    with pytest.raises(SimulationError):
        emu.process_frame(np.zeros((5, 8), np.float32), 2000)


@pytest.mark.parametrize("params", [3, "ideal", {"threshold_on": 0.2}])
def test_params_of_another_type_are_a_parameter_error(params: object) -> None:
    # It was a bare TypeError, outside uavsnn's errors (and a command's exit 2).
    with pytest.raises(ParameterError, match="params must be DvsParams, got"):
        DvsEmulator((4, 4), params=params)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="params must be DvsParams"):
        emulate_dvs(np.zeros((2, 4, 4)), [0, 1], params=params)  # type: ignore[arg-type]


def test_process_frame_refuses_frames_patches_and_patch_times_it_cannot_take() -> None:
    """A frame of text was NumPy's ValueError, a patch time of -1 Python's OverflowError (and
    -1 in an int64 array wrapped to 2^64 - 1), a time of 4000.7 µs was truncated to 4000: each is
    a SimulationError naming what is wrong, and the emulator is left as it was."""
    emu = DvsEmulator((4, 4), params=DvsParams.ideal())
    flat = np.full((4, 4), 10.0, np.float32)
    for frame, match in (
        ("abc", "a frame must be real intensities"),
        (np.full((4, 4), 10 + 1j), "a frame must be real intensities"),
        (np.ones((4, 4), bool), "a frame must be real intensities"),
        ([[1.0] * 4, [1.0] * 3], "a frame must be an array of intensities"),
    ):
        with pytest.raises(SimulationError, match=match):
            emu.process_frame(frame, 0)
    assert emu.frames_seen == 0
    assert len(emu.process_frame(flat, 0)) == 0
    v = np.full((1, 2, 2), 200.0, np.float32)
    for patches, match in (
        ([(0, 0, [-1], v)], r"times_us: -1 is negative"),
        ([(0, 0, np.array([-1]), v)], r"times_us: -1 is negative"),
        ([(0, 0, [4000.7], v)], r"times_us: 4000.7 is not a whole number of microseconds"),
        ([(0, 0, [float("nan")], v)], "not a whole number"),
        ([(0, 0, [2.0**64], v)], "beyond 2\\^64 - 1"),
        ([(0, 0, [2**64], v)], "whole microseconds, got dtype object"),
        ([(0, 0, [True], v)], "whole microseconds, got dtype bool"),
        ([(0, 0, "ab", v)], "must be 1-D"),
        ([(0, 0, [[5]], v)], "must be 1-D"),
        ([(0, 0, [5], "x")], "patch 0's values must be real intensities"),
        ([(0, 0, [5])], "patch 0 is"),
        ([None], "patch 0 is None"),
        (5, "patches must be a sequence"),
        ("abcd", "patches must be a sequence"),
    ):
        with pytest.raises(SimulationError, match=match):
            emu.process_frame(flat, 10_000, patches)  # type: ignore[arg-type]
        assert emu.frames_seen == 1
    # A whole time given as a float is taken.
    assert len(emu.process_frame(flat, 10_000, [(0, 0, [4000.0], v)])) > 0
    assert emu.frames_seen == 2


def test_the_gen3_preset_fires_about_1_88_on_events_per_off_event() -> None:
    # A slow rise and fall of the same size: a Gen3-like pixel's ON threshold is its OFF
    # threshold over 1.88, so it makes about 1.88 times as many ON as OFF events.
    params = DvsParams.gen3(
        threshold_sigma=0.0, leak_rate_hz=0.0, shot_noise_rate_hz=0.0, hot_pixel_fraction=0.0
    )
    assert params.refractory_us == 1.0 and params.threshold_on < params.threshold_off
    ramp = np.geomspace(30.0, 250.0, 200)
    levels = np.concatenate([ramp, ramp[::-1][1:]])
    frames = np.repeat(levels[:, None, None], 4, axis=1).repeat(4, axis=2).astype(np.float32)
    times = np.arange(len(frames), dtype=np.uint64) * 2_000
    ev = emulate_dvs(frames, times, params=params)
    on, off = int(ev["p"].sum()), int((~ev["p"].astype(bool)).sum())
    assert off > 0 and 1.7 < on / off < 2.1, (on, off)
    ratio = DvsParams().threshold_on / params.threshold_on
    assert ratio == pytest.approx(1.88)
