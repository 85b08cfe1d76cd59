"""Windows: equal to a plain NumPy reference, lossless, one spike per pixel, and typed errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import uavsnn
from uavsnn import io
from uavsnn.events import EVENT_DTYPE, Recording
from uavsnn.windows import Windows, add_noise, make_windows, noise_per_window, window_step

OVERLAPS = st.one_of(st.sampled_from([0.0, 0.1, 0.5, 0.9]), st.floats(0.0, 0.95))


def reference_step(length: int, overlap: float) -> int:
    """docs/model.md §1: L·(1 − o) rounded down, at least 1 (near-integers count as integers)."""
    exact = length * (1.0 - overlap)
    step = round(exact) if abs(exact - round(exact)) <= 1e-9 * max(exact, 1.0) else int(exact)
    return max(1, min(step, length))


def median_reference(x: np.ndarray, y: np.ndarray, width: int, height: int) -> np.ndarray:
    """Keep an active pixel iff >= 5 of its 3x3 neighbourhood (zero padding) is active."""
    active = np.zeros((height + 2, width + 2), np.int32)
    active[y.astype(int) + 1, x.astype(int) + 1] = 1
    around = sum(
        active[1 + dy : height + 1 + dy, 1 + dx : width + 1 + dx]
        for dy in (-1, 0, 1)
        for dx in (-1, 0, 1)
    )
    return around[y.astype(int), x.astype(int)] >= 5


def reference(
    rec: Recording,
    length: int,
    overlap: float,
    median: bool = False,
    start: int | None = None,
    end: int | None = None,
) -> dict[str, np.ndarray]:
    """Windows straight from the definition, one window at a time, in NumPy."""
    t = rec.events["t"].astype(np.int64)
    x, y = rec.events["x"], rec.events["y"]
    width, height = rec.sensor_size
    pixel = y.astype(np.int64) * width + x
    out: dict[str, list] = {k: [] for k in ("t0", "counts", "t", "x", "y", "n_preceding")}
    if start is None:
        start = int(t[0]) if len(t) else None
    if start is not None:
        if end is None:
            end = max(int(t[-1]) + 1, start) if len(t) else start
        for t0 in range(start, end, reference_step(length, overlap)):
            inside = np.flatnonzero((t >= t0) & (t < t0 + length) & (t < end))
            _, first = np.unique(pixel[inside], return_index=True)
            chosen = inside[np.sort(first)]  # each pixel's first event, in arrival order
            if median and len(chosen):
                chosen = chosen[median_reference(x[chosen], y[chosen], width, height)]
            before = (t >= t0 - length) & (t < t0)
            out["t0"].append(t0)
            out["counts"].append(len(chosen))
            out["t"].extend(t[chosen])
            out["x"].extend(x[chosen])
            out["y"].extend(y[chosen])
            out["n_preceding"].append(len(np.unique(pixel[before])))
    result = {k: np.asarray(v, np.int64) for k, v in out.items()}
    result["offsets"] = np.concatenate([[0], np.cumsum(result.pop("counts"))])
    return result


def assert_equal_to_reference(w: Windows, ref: dict[str, np.ndarray]) -> None:
    for name, expected in ref.items():
        np.testing.assert_array_equal(getattr(w, name).astype(np.int64), expected, err_msg=name)


@st.composite
def recordings(draw, max_events: int = 150) -> Recording:
    width = draw(st.integers(1, 9))
    height = draw(st.integers(1, 7))
    n = draw(st.integers(0, max_events))
    gaps = draw(st.lists(st.integers(0, 12), min_size=n, max_size=n))
    ev = np.zeros(n, EVENT_DTYPE)
    ev["t"] = draw(st.integers(0, 10**6)) + np.cumsum(gaps, dtype=np.int64)
    ev["x"] = draw(st.lists(st.integers(0, width - 1), min_size=n, max_size=n)) if n else []
    ev["y"] = draw(st.lists(st.integers(0, height - 1), min_size=n, max_size=n)) if n else []
    ev["p"] = draw(st.lists(st.booleans(), min_size=n, max_size=n)) if n else []
    return Recording(ev, (width, height))


@given(recordings(), st.integers(1, 80), OVERLAPS, st.booleans())
def test_windows_equal_the_numpy_reference(rec, length, overlap, median) -> None:
    w = make_windows(rec, length, overlap, median=median)
    assert_equal_to_reference(w, reference(rec, length, overlap, median))
    assert w.length_us == length and w.sensor_size == rec.sensor_size


@given(recordings(), st.integers(1, 80), OVERLAPS, st.integers(-50, 400), st.integers(0, 500))
def test_windows_of_a_range_equal_the_numpy_reference(rec, length, overlap, shift, span) -> None:
    base = int(rec.events["t"][0]) if len(rec) else 1000
    start = max(0, base + shift)
    w = make_windows(rec, length, overlap, start_us=start, end_us=start + span)
    assert_equal_to_reference(w, reference(rec, length, overlap, start=start, end=start + span))


@given(recordings(), st.integers(1, 80), OVERLAPS)
def test_windows_lose_no_event_and_hold_each_pixel_once(rec, length, overlap) -> None:
    w = make_windows(rec, length, overlap)
    for i in range(len(w)):
        t, x, y = w.spikes(i)
        pixels = list(zip(x.tolist(), y.tolist(), strict=True))
        assert len(set(pixels)) == len(pixels)  # at most once
        held = dict(zip(pixels, t.tolist(), strict=True))
        t0 = int(w.t0[i])
        inside = rec.events[(rec.events["t"] >= t0) & (rec.events["t"] < t0 + length)]
        for e in inside:  # every event's pixel is there, at its pixel's first time
            first = inside["t"][(inside["x"] == e["x"]) & (inside["y"] == e["y"])].min()
            assert held[(int(e["x"]), int(e["y"]))] == first
        assert len(held) == len({(int(e["x"]), int(e["y"])) for e in inside})
    # Every event lies in at least one window (the checks above then cover it).
    last_start = np.searchsorted(w.t0, rec.events["t"], side="right") - 1
    assert (last_start >= 0).all()
    assert (rec.events["t"] < w.t0[last_start] + length).all()


def test_windows_on_a_real_recording_equal_the_reference(shared_data: Path) -> None:
    rec = io.read(shared_data / "dvs" / "tonic_dvxplorer_person.aedat4")
    for overlap, median in [(0.5, False), (0.9, True)]:
        w = make_windows(rec, 50_000, overlap, median=median)
        assert_equal_to_reference(w, reference(rec, 50_000, overlap, median))


@given(recordings(max_events=60), st.integers(1, 40), OVERLAPS)
def test_frames_embed_spike_times(rec, length, overlap) -> None:
    w = make_windows(rec, length, overlap)
    frames = w.frames()
    width, height = rec.sensor_size
    assert frames.shape == (len(w), height, width) and frames.dtype == np.float32
    expected = np.full((len(w), height, width), np.inf, np.float32)
    for i in range(len(w)):
        t, x, y = w.spikes(i)
        expected[i, y, x] = (t - w.t0[i]).astype(np.float32)
    np.testing.assert_array_equal(frames, expected)
    if len(w):
        np.testing.assert_array_equal(w.frames([-1, 0]), expected[[-1, 0]])


@given(recordings(max_events=60), st.integers(1, 40), OVERLAPS, st.data())
def test_select_and_concatenate_agree(rec, length, overlap, data) -> None:
    w = make_windows(rec, length, overlap)
    if len(w) == 0:
        return
    a = data.draw(st.lists(st.integers(0, len(w) - 1), max_size=6))
    b = data.draw(st.lists(st.integers(0, len(w) - 1), max_size=6))
    joined = Windows.concatenate([w.select(a), w.select(b)])
    direct = w.select(a + b)
    for name in ("t0", "offsets", "t", "x", "y", "n_preceding"):
        np.testing.assert_array_equal(getattr(joined, name), getattr(direct, name))
    for j, i in enumerate(a + b):
        for got, expected in zip(direct.spikes(j), w.spikes(i), strict=True):
            np.testing.assert_array_equal(got, expected)


@given(recordings(), st.integers(5, 60), st.floats(0.0, 0.3), st.integers(0, 2**32))
def test_noise_adds_uniform_pixels_and_reports_snr(rec, length, fraction, seed) -> None:
    w = make_windows(rec, length)
    noisy, snr = add_noise(w, fraction, seed=seed)
    width, height = rec.sensor_size
    n_noise = math.floor(fraction * width * height + 0.5)  # the engine rounds half up
    again, snr_again = add_noise(w, fraction, seed=seed)
    np.testing.assert_array_equal(noisy.t, again.t)
    np.testing.assert_array_equal(snr, snr_again)
    for i in range(len(w)):
        t, x, y = noisy.spikes(i)
        st_, sx, sy = w.spikes(i)
        pixels = y.astype(int) * width + x
        assert len(np.unique(pixels)) == len(pixels)
        assert len(st_) <= len(t) <= len(st_) + n_noise
        assert (np.diff(t.astype(np.int64)) >= 0).all()
        # A signal pixel keeps its spike unless noise came earlier.
        times = dict(zip(pixels.tolist(), t.tolist(), strict=True))
        for ti, pi in zip(st_.tolist(), (sy.astype(int) * width + sx).tolist(), strict=True):
            assert times[pi] <= ti
        signal = len(st_)
        with np.errstate(divide="ignore"):
            expected = np.inf if n_noise == 0 else 10 * np.log10(signal / n_noise)
        assert snr[i] == pytest.approx(expected)


@given(recordings(), st.integers(5, 60), st.floats(0.0, 0.3), st.integers(0, 2**32), st.data())
def test_noise_added_part_by_part_is_the_noise_added_at_once(
    rec, length, fraction, seed, data
) -> None:
    w = make_windows(rec, length, 0.5)
    whole, snr = add_noise(w, fraction, seed=seed)
    cut = data.draw(st.integers(0, len(w)))
    parts = [
        add_noise(w.select(range(a, b)), fraction, seed=seed, first=a)
        for a, b in ((0, cut), (cut, len(w)))
    ]
    joined = Windows.concatenate([p for p, _ in parts])
    for name in ("t0", "offsets", "t", "x", "y", "n_preceding"):
        np.testing.assert_array_equal(getattr(joined, name), getattr(whole, name))
    np.testing.assert_array_equal(np.concatenate([s for _, s in parts]), snr)


def test_noise_fraction_sets_the_count_exactly() -> None:
    ev = np.zeros(1, EVENT_DTYPE)
    rec = Recording(ev, (240, 180))
    noisy, snr = add_noise(make_windows(rec, 10_000), 0.05, seed=0)
    n_noise = round(0.05 * 240 * 180)
    assert n_noise <= len(noisy.t) <= n_noise + 1  # noise may land on the one signal pixel
    assert snr[0] == pytest.approx(10 * np.log10(1 / 2160))
    t, _, _ = noisy.spikes(0)
    assert (t < 10_000).all()


def test_empty_recording_gives_no_windows_unless_a_range_is_given() -> None:
    rec = Recording(np.zeros(0, EVENT_DTYPE), (8, 8))
    w = make_windows(rec, 1000)
    assert len(w) == 0 and w.frames().shape == (0, 8, 8)
    w = make_windows(rec, 1000, 0.5, start_us=0, end_us=2000)
    np.testing.assert_array_equal(w.t0, [0, 500, 1000, 1500])
    assert len(w.t) == 0


def test_step_follows_the_model() -> None:
    assert window_step(10_000, 0.9) == 1_000
    assert window_step(10_000, 0.1) == 9_000
    assert window_step(3, 0.5) == 1
    assert window_step(1, 0.9) == 1


def small_recording() -> Recording:
    ev = np.zeros(3, EVENT_DTYPE)
    ev["t"] = [0, 5, 9]
    return Recording(ev, (4, 4))


@pytest.mark.parametrize(
    "length", [0, -10, 0.5, 10.5, (1 << 62) + 1, float("nan"), float("inf"), "10", True]
)
def test_bad_window_lengths_are_parameter_errors(length) -> None:
    with pytest.raises(uavsnn.ParameterError, match="length_us"):
        make_windows(small_recording(), length)


def test_the_longest_window_is_accepted() -> None:
    w = make_windows(small_recording(), 1 << 62)
    assert len(w) == 1 and w.length_us == 1 << 62


@pytest.mark.parametrize("overlap", [1.0, 1.5, -0.1, float("nan"), "half"])
def test_overlaps_outside_0_1_are_parameter_errors(overlap) -> None:
    with pytest.raises(uavsnn.ParameterError, match="overlap"):
        make_windows(small_recording(), 10, overlap)


def test_bad_ranges_and_inputs_are_typed_errors() -> None:
    rec = small_recording()
    with pytest.raises(uavsnn.ParameterError, match="end_us"):
        make_windows(rec, 10, start_us=100, end_us=50)
    for end in (-5, 10.5, "50"):
        with pytest.raises(uavsnn.ParameterError, match="end_us"):
            make_windows(rec, 10, end_us=end)  # type: ignore[arg-type]
    with pytest.raises(uavsnn.ParameterError, match="start_us"):
        make_windows(rec, 10, start_us=-1)
    with pytest.raises(uavsnn.ParameterError, match="exceed the limit"):
        make_windows(rec, 1, start_us=0, end_us=10**12)
    with pytest.raises(uavsnn.ParameterError, match="expected a Recording"):
        make_windows(rec.events, 10)  # type: ignore[arg-type]
    w = make_windows(rec, 10)
    for fraction in (-0.1, 1.1, float("nan")):
        with pytest.raises(uavsnn.ParameterError, match="fraction"):
            add_noise(w, fraction, seed=0)
    with pytest.raises(uavsnn.ParameterError, match="seed"):
        add_noise(w, 0.1, seed=-1)
    for first in (-1, 0.5, "0", 2**64):
        with pytest.raises(uavsnn.ParameterError, match="first"):
            add_noise(w, 0.1, seed=0, first=first)  # type: ignore[arg-type]
    with pytest.raises(uavsnn.ParameterError, match="first"):
        add_noise(w, 0.1, seed=0, first=2**64 - 1)  # its windows would pass the last index
    with pytest.raises(uavsnn.ParameterError, match="out of range"):
        w.frames([5])
    with pytest.raises(uavsnn.ParameterError, match="out of range"):
        w.spikes(-3)
    n = len(w)
    assert n > 0
    with pytest.raises(uavsnn.ParameterError, match="out of range"):
        w.select([n])
    assert len(w.select([n - 1, -n])) == 2
    with pytest.raises(uavsnn.ParameterError, match="integers"):
        w.select(np.ones(n, dtype=bool))
    other = make_windows(rec, 20)
    with pytest.raises(uavsnn.ShapeError, match="length"):
        Windows.concatenate([w, other])


WINDOW = {
    "sensor_size": (4, 4),
    "length_us": 10,
    "t0": [0],
    "offsets": [0, 2],
    "t": [1, 2],
    "x": [0, 1],
    "y": [0, 0],
    "n_preceding": [0],
}


@pytest.mark.parametrize("size", [(64.9, 48.2), (True, 4), (4, 4.5), ("4", "4"), 4, None])
def test_a_sensor_size_that_is_no_whole_pixels_is_refused_not_truncated(size: object) -> None:
    with pytest.raises(uavsnn.ParameterError, match="sensor_size"):
        Windows(**{**WINDOW, "sensor_size": size})
    assert Windows(**{**WINDOW, "sensor_size": (4.0, np.int64(4))}).sensor_size == (4, 4)


def test_windows_concatenate_takes_any_iterable_of_windows() -> None:
    w = make_windows(small_recording(), 10)
    twice = Windows.concatenate([w, w])
    for parts in (iter([w, w]), (p for p in (w, w)), (w, w)):
        joined = Windows.concatenate(parts)
        assert len(joined) == 2 * len(w)
        for name in ("t0", "offsets", "t", "x", "y", "n_preceding"):
            assert np.array_equal(getattr(joined, name), getattr(twice, name)), name
    for bad in (w, 3, None):
        with pytest.raises(uavsnn.ParameterError, match="iterable of Windows"):
            Windows.concatenate(bad)  # type: ignore[arg-type]
    with pytest.raises(uavsnn.ParameterError, match=r"parts\[1\]"):
        Windows.concatenate(iter([w, 3]))  # type: ignore[list-item]
    with pytest.raises(uavsnn.ParameterError, match="at least one"):
        Windows.concatenate(iter([]))


@pytest.mark.parametrize("median", ["no", "", 0, 1, None, np.array([True])])
def test_median_must_be_a_bool(median: object) -> None:
    # bool("no") is True: the filter would run.
    with pytest.raises(uavsnn.ParameterError, match="median"):
        make_windows(small_recording(), 10, median=median)  # type: ignore[arg-type]
    assert len(make_windows(small_recording(), 10, median=np.bool_(True))) == 1


def test_noise_per_window_refuses_what_add_noise_refuses() -> None:
    w = make_windows(small_recording(), 10)
    for fraction in (-1, 2, -0.1, 1.1, float("nan"), "half", "0.5", None, True, 2**2000):
        with pytest.raises(uavsnn.ParameterError, match="fraction"):
            noise_per_window(fraction, (64, 48))  # type: ignore[arg-type]
        with pytest.raises(uavsnn.ParameterError, match="fraction"):
            add_noise(w, fraction, seed=0)  # type: ignore[arg-type]
    for size in ((64.5, 48), (0, 48), None):
        with pytest.raises(uavsnn.ParameterError, match="sensor_size"):
            noise_per_window(0.5, size)  # type: ignore[arg-type]
    assert noise_per_window(0.5, (64, 48)) == 1536
    assert noise_per_window(1, (64, 48)) == 64 * 48
    assert noise_per_window(np.float32(0.0), (64, 48)) == 0


def test_inconsistent_windows_are_refused() -> None:
    ok = dict(WINDOW)
    assert len(Windows(**ok)) == 1
    for change, error, message in [
        ({"offsets": [0, 3]}, uavsnn.ShapeError, "offsets"),
        ({"offsets": [0]}, uavsnn.ShapeError, "offsets"),
        ({"offsets": [-1, 2]}, uavsnn.ShapeError, "offsets"),
        ({"x": [0]}, uavsnn.ShapeError, "equal length"),
        ({"x": [0, 4]}, uavsnn.EventError, "outside the 4x4 sensor"),
        ({"t": [1, 10]}, uavsnn.EventError, r"outside \[0, 0 \+ 10\)"),
        ({"t": [2, 1]}, uavsnn.EventError, "before the previous spike"),
        ({"t": [1.0, 2.0]}, uavsnn.ShapeError, "integers"),
        ({"x": [0, 70000]}, uavsnn.ShapeError, "outside"),
        ({"x": [0, -1]}, uavsnn.ShapeError, "outside"),
        ({"n_preceding": [-1]}, uavsnn.ShapeError, "negative"),
        ({"sensor_size": (65536, 4)}, uavsnn.ParameterError, "sensor_size"),
        ({"n_preceding": [0, 1]}, uavsnn.ShapeError, "n_preceding"),
        ({"length_us": 0}, uavsnn.ParameterError, "length_us"),
    ]:
        with pytest.raises(error, match=message):
            Windows(**{**ok, **change})


def test_the_memory_limit_is_the_least_the_process_can_have(tmp_path: Path) -> None:
    import subprocess
    import sys

    from uavsnn.windows import _memory_limit

    physical = _memory_limit(cgroup_files=())
    assert physical is not None and physical > 0
    (tmp_path / "none").write_text("max\n")
    (tmp_path / "small").write_text("123456789\n")
    assert _memory_limit(cgroup_files=[str(tmp_path / "none")]) == physical
    assert _memory_limit(cgroup_files=[str(tmp_path / "small")]) == min(physical, 123456789)
    # The first file found is the hierarchy's: a missing one is skipped, a later one not read.
    found = [str(tmp_path / "missing"), str(tmp_path / "none"), str(tmp_path / "small")]
    assert _memory_limit(cgroup_files=found) == physical
    # ulimit -v: a process allowed less address space than the machine's memory.
    code = (
        "import resource; hard = resource.getrlimit(resource.RLIMIT_AS)[1]; cap = 6 << 30\n"
        "if hard != resource.RLIM_INFINITY: cap = min(cap, hard)\n"
        "resource.setrlimit(resource.RLIMIT_AS, (cap, hard)); import uavsnn.windows as w\n"
        "assert w.MEMORY_LIMIT is not None and w.MEMORY_LIMIT <= cap, w.MEMORY_LIMIT"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)
