"""The motion-compensated rotor (uavsnn.signature.estimate_motion, compensate_motion,
compensated_rotor, motion_line): a still source gives the same answer as without compensation,
a moving emulated propeller's blade pass comes back within 2 % where the plain estimators lose
it, uniform noise raises no peak, the motion's own pixel-crossing line is recognised, typed
errors.

The generators are those of benches/python/rotor_noise.py (its ``--estimator compensated``
table uses seeds 0..199 and 20000 on); the tests here use seeds from 2400 on.
"""

from __future__ import annotations

import numpy as np
import pytest

from uavsnn import EventError, ParameterError
from uavsnn.events import EVENT_DTYPE
from uavsnn.signature import (
    MOTION_DEFAULTS,
    MotionEstimate,
    compensate_motion,
    compensated_rotor,
    estimate_motion,
    motion_line,
    rotor_signature,
    rotor_spectrum,
)


@pytest.fixture(scope="module")
def gen(bench_script):
    return bench_script("rotor_noise")


@pytest.mark.parametrize("f", [80.0, 240.0, 520.0])
def test_a_still_source_gives_the_same_answer(gen, f):
    rng = np.random.default_rng(2400 + int(f))
    events = gen.flicker(f, 12, 100_000, 3, 0.02, rng)
    box = (0, 0, 12, 12)
    est = compensated_rotor(events, box)
    assert est.motion.vx == 0.0 and est.motion.vy == 0.0, est.motion
    assert est.kept == len(events)
    assert est.edges == rotor_signature(events, box)
    assert est.spectrum == rotor_spectrum(events, box)
    assert est.edges.detected and abs(est.edges.frequency_hz - f) <= 0.02 * f


@pytest.mark.parametrize(("size", "speed", "seed"), [(8, 300.0, 2401), (24, 1000.0, 2402)])
def test_a_moving_propeller_comes_back_within_two_percent(gen, size, speed, seed):
    # 120 rev/s, two blades: 240 Hz, through the dvs sensor model, carried across its box.
    events, box = gen.moving_propeller(120.0, speed, size=size, seed=seed)
    est = compensated_rotor(events, box)
    assert abs(est.motion.vx - speed) <= 0.05 * speed and abs(est.motion.vy) <= 0.05 * speed
    for found in (est.edges, est.spectrum):
        assert found.detected and abs(found.frequency_hz - 240.0) <= 0.02 * 240.0, found
        assert not motion_line(found.frequency_hz, est.motion)
    # Without compensation the edge estimator loses it (nothing, or a wrong line).
    plain = rotor_signature(events, box)
    assert not plain.detected or abs(plain.frequency_hz - 240.0) > 0.05 * 240.0, plain


def test_the_velocity_of_moving_events_is_found(gen):
    # A 12x12 patch in one phase at 240 Hz carried at (300, 100) px/s, then at (-500, 200).
    for v in ((300.0, 100.0), (-500.0, 200.0)):
        rng = np.random.default_rng(2410)
        events = gen.moving(gen.flicker(240.0, 12, 50_000, 2, 0.02, rng, coherent=True), *v)
        box = (0, 0, int(events["x"].max()) + 3, int(events["y"].max()) + 3)
        m = estimate_motion(events, box)
        assert abs(m.vx - v[0]) <= 0.05 * abs(v[0]) and abs(m.vy - v[1]) <= 0.1 * abs(v[1]), m
        assert m.events == len(events) and m.gain > 0.5
        warped = compensate_motion(events, box, m)
        assert len(warped) > 0.95 * len(events)
        assert np.all(np.diff(warped["t"].astype(np.int64)) >= 0)


def test_uniform_noise_raises_no_peak(gen):
    runs = 0
    for seed in range(2420, 2425):
        rng = np.random.default_rng(seed)
        for side in (16, 64):
            for rate in gen.RATES:
                events = gen.noise(rate, side, 100_000, rng)
                est = compensated_rotor(events, (0, 0, side, side))
                assert not est.detected, (seed, side, rate, est)
                runs += 1
    assert runs == 5 * 2 * len(gen.RATES)


@pytest.mark.parametrize("speed", [300.0, 500.0])
def test_a_moving_shape_without_flicker_gives_its_pixel_crossing_line(gen, speed):
    # The propeller standing still (a dark two-blade shape), carried at `speed` px/s through
    # the sensor model: in the object's frame its edges fire once per pixel crossed, a line at
    # `speed` Hz that the plain estimators do not see and motion_line recognises.
    events, box = gen.moving_propeller(0.0, speed, size=8, seed=2450)
    est = compensated_rotor(events, box)
    assert est.spectrum.detected, est
    assert abs(est.spectrum.frequency_hz - speed) <= 0.05 * speed, est
    assert motion_line(est.spectrum.frequency_hz, est.motion)
    assert not est.edges.detected or motion_line(est.edges.frequency_hz, est.motion)
    assert not rotor_spectrum(events, box).detected and not rotor_signature(events, box).detected


def test_an_edge_crossing_pixels_is_a_motion_line():
    m = MotionEstimate(240.0, -60.0, 0.0, 1.0, 100)
    assert motion_line(240.0, m) and motion_line(480.0 * 1.03, m) and motion_line(60.0, m)
    assert motion_line(180.0, m) and motion_line(120.0, m) and motion_line(30.0, m)
    assert not motion_line(300.0, m) and not motion_line(0.0, m) and not motion_line(200.0, m)
    assert not motion_line(240.0, MotionEstimate(0.0, 0.0, 0.0, 0.0, 0))


def test_the_motion_search_reads_a_bounded_subset(gen):
    rng = np.random.default_rng(2440)
    events = gen.moving(gen.flicker(240.0, 12, 50_000, 2, 0.02, rng, coherent=True), 200.0, 0.0)
    box = (0, 0, int(events["x"].max()) + 3, 16)
    cap = 1000
    assert len(events) > 6 * cap
    m = estimate_motion(events, box, max_events=cap)
    assert m.events == len(events) and abs(m.vx - 200.0) <= 10.0, m


def test_few_or_no_events_give_no_motion():
    empty = np.zeros(0, dtype=EVENT_DTYPE)
    assert estimate_motion(empty, (0, 0, 8, 8)) == MotionEstimate(0.0, 0.0, 0.0, 0.0, 0)
    est = compensated_rotor(empty, (0, 0, 8, 8))
    assert not est.detected and est.kept == 0
    few = np.zeros(int(MOTION_DEFAULTS["min_events"]) - 1, dtype=EVENT_DTYPE)
    few["t"] = np.arange(len(few)) * 100
    few["x"] = np.arange(len(few)) % 8
    assert estimate_motion(few, (0, 0, 8, 8)).vx == 0.0


@pytest.mark.parametrize(
    "kwargs",
    [
        {"min_events": 1},
        {"min_gain": -0.1},
        {"min_gain": float("nan")},
        {"coarse_steps": 0},
        {"finest_px": 0.0},
        {"finest_px": 2.0},
        {"max_events": 4},
    ],
)
def test_bad_parameters_are_parameter_errors(kwargs):
    with pytest.raises(ParameterError):
        estimate_motion(np.zeros(0, dtype=EVENT_DTYPE), (0, 0, 4, 4), **kwargs)


def test_unknown_parameters_are_parameter_errors():
    empty = np.zeros(0, dtype=EVENT_DTYPE)
    with pytest.raises(ParameterError, match="min_gian"):
        compensated_rotor(empty, (0, 0, 4, 4), min_gian=0.1)
    with pytest.raises(ParameterError):
        compensated_rotor(empty, (0, 0, 4, 4), spectrum_params={"bins": 3})


@pytest.mark.parametrize("box", [(0, 0, 0, 4), (0, 0, 4, -1), "box", (1, 2, 3)])
def test_bad_boxes_are_parameter_errors(box):
    with pytest.raises(ParameterError):
        compensated_rotor(np.zeros(0, dtype=EVENT_DTYPE), box)


def test_bad_events_are_event_errors():
    with pytest.raises(EventError):
        estimate_motion(np.zeros(3, dtype=np.int64), (0, 0, 4, 4))
    with pytest.raises(EventError):
        compensated_rotor(np.zeros((2, 2), dtype=EVENT_DTYPE), (0, 0, 4, 4))


def test_script_reports(gen, capsys):
    gen.main(["--estimator", "compensated", "--seeds", "1", "--first-seed", "3000"])
    out = capsys.readouterr().out
    assert "| 16×16 | 1e+03 |" in out and "| one | 240 | 300, 100 |" in out
    assert "| 8 | 1000 |" in out
