"""Filters: the denoise filter gives tonic's events; downsample equals a NumPy reference."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import uavsnn
from uavsnn import io
from uavsnn.events import EVENT_DTYPE, Recording
from uavsnn.filters import denoise, downsample

tonic_denoise = pytest.importorskip("tonic.functional").denoise_numpy


@st.composite
def streams(draw, max_side: int = 12, max_events: int = 200) -> np.ndarray:
    n = draw(st.integers(1, max_events))
    width = draw(st.integers(1, max_side))
    height = draw(st.integers(1, max_side))
    ev = np.zeros(n, EVENT_DTYPE)
    start = draw(st.sampled_from([0, 3, 10**9]))  # near 0, tonic's unfired pixels matter
    ev["t"] = start + np.cumsum(draw(st.lists(st.integers(0, 40), min_size=n, max_size=n)))
    ev["x"] = draw(st.lists(st.integers(0, width - 1), min_size=n, max_size=n))
    ev["y"] = draw(st.lists(st.integers(0, height - 1), min_size=n, max_size=n))
    ev["p"] = draw(st.lists(st.booleans(), min_size=n, max_size=n))
    return ev


@given(streams(), st.integers(1, 100))
def test_denoise_equals_tonic(ev, dt) -> None:
    # tonic sizes its grid from the events' bounding box; give the recording that sensor.
    sensor = (int(ev["x"].max()) + 1, int(ev["y"].max()) + 1)
    ours = denoise(Recording(ev, sensor), dt)
    np.testing.assert_array_equal(ours.events, tonic_denoise(ev.copy(), filter_time=dt))
    assert ours.metadata["denoise_dt_us"] == dt


@given(streams(), st.integers(1, 100), st.integers(0, 5), st.integers(0, 5))
def test_denoise_on_a_larger_sensor_equals_tonic_once_t_exceeds_dt(ev, dt, extra_w, extra_h):
    ev = ev.copy()
    ev["t"] += dt  # every t >= dt: the documented condition for equality on any sensor
    sensor = (int(ev["x"].max()) + 1 + extra_w, int(ev["y"].max()) + 1 + extra_h)
    ours = denoise(Recording(ev, sensor), dt)
    np.testing.assert_array_equal(ours.events, tonic_denoise(ev.copy(), filter_time=dt))


def test_denoise_equals_tonic_on_real_events(shared_data: Path) -> None:
    rec = io.read(shared_data / "dvs" / "tonic_dvxplorer_person.aedat4")
    part = Recording(rec.events[:20_000], rec.sensor_size)
    ours = denoise(part, 5_000)
    expected = tonic_denoise(part.events.copy(), filter_time=5_000)
    assert 0 < len(expected) < len(part)  # the filter does something on this input
    np.testing.assert_array_equal(ours.events, expected)


@pytest.mark.parametrize("dt", [0, -1, 0.5, float("nan"), None])
def test_denoise_refuses_bad_filter_times(dt) -> None:
    rec = Recording(np.zeros(1, EVENT_DTYPE), (4, 4))
    with pytest.raises(uavsnn.ParameterError, match="dt_us"):
        denoise(rec, dt)


def downsample_reference(ev: np.ndarray, source, target) -> np.ndarray:
    (sw, sh), (tw, th) = source, target
    if sw * th > tw * sh:
        cw, ch = max(sh * tw // th, 1), sh
    else:
        cw, ch = sw, max(sw * th // tw, 1)
    x0, y0 = (sw - cw) // 2, (sh - ch) // 2
    x = ev["x"].astype(np.int64) - x0
    y = ev["y"].astype(np.int64) - y0
    keep = (x >= 0) & (x < cw) & (y >= 0) & (y < ch)
    out = ev[keep].copy()
    out["x"] = x[keep] * tw // cw
    out["y"] = y[keep] * th // ch
    return out


@given(
    streams(max_side=60),
    st.tuples(st.integers(1, 30), st.integers(1, 30)),
    st.integers(0, 20),
    st.integers(0, 20),
)
def test_downsample_equals_the_reference(ev, target, extra_w, extra_h) -> None:
    source = (int(ev["x"].max()) + 1 + extra_w, int(ev["y"].max()) + 1 + extra_h)
    # downsample only reduces (a larger target is refused: tests/test_cli_help.py).
    target = (min(target[0], source[0]), min(target[1], source[1]))
    out = downsample(Recording(ev, source), target)
    assert out.sensor_size == target
    np.testing.assert_array_equal(out.events, downsample_reference(ev, source, target))
    assert out.metadata["downsampled_from"] == list(source)


def test_downsample_of_a_real_recording_keeps_every_event_of_the_crop(shared_data: Path) -> None:
    rec = io.read(shared_data / "dvs" / "prophesee_gen4_driving_evt3.raw")
    out = downsample(rec)
    assert out.sensor_size == (240, 180)
    np.testing.assert_array_equal(
        out.events, downsample_reference(rec.events, (1280, 720), (240, 180))
    )
    # 1280x720 -> 4:3 crop of 960x720 starting at x=160.
    inside = (rec.events["x"] >= 160) & (rec.events["x"] < 1120)
    assert len(out) == int(inside.sum())


@pytest.mark.parametrize("target", [(0, 180), (240, -1), (240,), "240x180", (70000, 10)])
def test_downsample_refuses_bad_targets(target) -> None:
    rec = Recording(np.zeros(1, EVENT_DTYPE), (4, 4))
    with pytest.raises(uavsnn.ParameterError, match="sensor_size"):
        downsample(rec, target)


def test_filters_refuse_non_recordings() -> None:
    with pytest.raises(uavsnn.ParameterError, match="expected a Recording"):
        denoise(np.zeros(1, EVENT_DTYPE), 10)  # type: ignore[arg-type]
    with pytest.raises(uavsnn.ParameterError, match="expected a Recording"):
        downsample(np.zeros(1, EVENT_DTYPE))  # type: ignore[arg-type]
