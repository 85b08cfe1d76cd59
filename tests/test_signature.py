"""The rotor signature (uavsnn.signature, rust/signature.rs): synthetic flicker and an emulated
propeller come back within 2 %, uniform noise raises no peak above the documented threshold, the
real spinner recording's rotation, bounded state, and typed errors.

The synthetic generators are those of benches/python/rotor_noise.py (which chose the threshold on
seeds 0..199); the tests here use seeds from 2000 on.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import uavsnn
from uavsnn import EventError, ParameterError
from uavsnn.boxes import in_box
from uavsnn.events import EVENT_DTYPE
from uavsnn.features import rate_swing
from uavsnn.signature import (
    DEFAULTS,
    MAX_PIXELS,
    MAX_SPECTRUM_BYTES,
    SPECTRUM_DEFAULTS,
    RotorSignature,
    RotorSpectrum,
    estimate_motion,
    measure_box,
    rotor_signature,
    rotor_spectrum,
)


@pytest.fixture(scope="module")
def gen(bench_script):
    return bench_script("rotor_noise")


@pytest.mark.parametrize("f", [50.0, 73.0, 150.0, 260.0, 410.0, 520.0, 777.0, 1000.0])
def test_flicker_frequency_comes_back_within_two_percent(gen, f):
    rng = np.random.default_rng(2000 + int(f))
    events = gen.flicker(f, 12, 100_000, 3, 0.02, rng)
    est = rotor_signature(events, (0, 0, 12, 12))
    assert abs(est.frequency_hz - f) <= 0.02 * f, est
    assert est.detected and est.strength >= 0.5 and est.pixels >= 100, est


@given(
    f=st.floats(50.0, 1000.0),
    jitter=st.floats(0.0, 0.03),
    run=st.integers(1, 5),
    seed=st.integers(2000, 2**32),
)
def test_any_flicker_in_the_band_comes_back(gen, f, jitter, run, seed):
    events = gen.flicker(f, 4, 200_000, run, jitter, np.random.default_rng(seed))
    est = rotor_signature(events, (0, 0, 4, 4))
    assert abs(est.frequency_hz - f) <= 0.02 * f, est
    assert est.detected, est


def test_flicker_in_part_of_a_noisy_box_is_found(gen):
    # A 6x6 patch flickering at 400 Hz in a 32x32 box of uniform noise at 10^4 events/s.
    rng = np.random.default_rng(2100)
    patch = gen.flicker(400.0, 6, 100_000, 3, 0.02, rng)
    patch["x"] += 13
    patch["y"] += 13
    events = np.concatenate([patch, gen.noise(1e4, 32, 100_000, rng)])
    events = events[np.argsort(events["t"], kind="stable")]
    est = rotor_signature(events, (0, 0, 32, 32))
    assert abs(est.frequency_hz - 400.0) <= 8.0, est
    assert est.detected and 30 <= est.pixels <= 36 + 5, est


@pytest.mark.parametrize("estimate", [rotor_signature, rotor_spectrum])
@pytest.mark.parametrize(("rev_s", "seed"), [(100.0, 2001), (240.0, 2002)])
def test_emulated_propeller_gives_its_blade_pass(gen, estimate, rev_s, seed):
    # A two-blade propeller through the dvs sensor model (noise, mismatch, refractory period),
    # read by the edge estimator and by the rate spectrum.
    events = gen.propeller(rev_s, duration_s=0.06, seed=seed)
    est = estimate(events, (0, 0, 24, 24))
    assert abs(est.frequency_hz - 2 * rev_s) <= 0.02 * 2 * rev_s, est
    assert est.detected, est


@pytest.mark.parametrize("estimate", [rotor_signature, rotor_spectrum])
def test_a_wing_beat_is_not_a_rotor(gen, estimate):
    # The same propeller at 6 rev/s: a 12 Hz "beat", a bird's, below the band.
    events = gen.propeller(6.0, duration_s=0.1, seed=2003)
    assert events.size > 1000
    est = estimate(events, (0, 0, 24, 24))
    assert not est.detected, est


def test_uniform_noise_raises_no_peak(gen):
    threshold = float(DEFAULTS["threshold"])
    worst = 0.0
    runs = 0
    for seed in range(2000, 2025):
        rng = np.random.default_rng(seed)
        for side in (16, 64):
            for rate in gen.RATES:
                est = rotor_signature(gen.noise(rate, side, 100_000, rng), (0, 0, side, side))
                assert not est.detected, (seed, side, rate, est)
                worst = max(worst, est.strength)
                runs += 1
    assert runs == 25 * 2 * len(gen.RATES)
    # Far below the threshold, not just below it.
    assert worst < threshold / 3, worst


def test_script_reports(gen, capsys):
    gen.main(["--seeds", "2", "--first-seed", "3000", "--window-ms", "20", "--propeller-ms", "5"])
    out = capsys.readouterr().out
    assert "| 16×16 | 1e+03 |" in out and "| 1000 |" in out and "| 250 | 500 |" in out


def test_state_is_fixed_and_events_are_counted(gen):
    s = RotorSignature((10, 20, 8, 8))
    assert s.box == (10, 20, 8, 8)
    size = s.state_bytes
    assert size == 8 * 8 * 32 + int(DEFAULTS["bins"]) * 12
    events = gen.noise(1e5, 40, 50_000, np.random.default_rng(2200))
    s.update(events)
    inside = (
        (events["x"] >= 10) & (events["x"] < 18) & (events["y"] >= 20) & (events["y"] < 28)
    ).sum()
    on = int(
        (
            events["p"]
            & (events["x"] >= 10)
            & (events["x"] < 18)
            & (events["y"] >= 20)
            & (events["y"] < 28)
        ).sum()
    )
    assert s.stats == {
        "events": int(inside),
        "outside": len(events) - int(inside),
        "late": 0,
        "on": on,
    }
    assert s.state_bytes == size
    late = events[:5].copy()
    late["x"], late["y"] = 12, 22
    late["p"] = [True, False, True, False, False]
    s.update(late)
    assert s.stats["late"] == 5 and s.stats["on"] == on + 2
    s.clear()
    assert s.stats == {"events": 0, "outside": 0, "late": 0, "on": 0}
    assert s.estimate() == uavsnn.RotorEstimate(0.0, 0.0, 0, 0, 0, 0, False)


def test_streaming_in_chunks_equals_one_call(gen):
    events = gen.flicker(300.0, 6, 60_000, 2, 0.02, np.random.default_rng(2300))
    whole = rotor_signature(events, (0, 0, 6, 6))
    s = RotorSignature.for_sensor((6, 6))
    for chunk in np.array_split(events, 7):
        s.update(chunk)
    assert s.estimate() == whole


def test_measure_box_is_the_rotor_and_counts_of_the_events_in_the_box(gen):
    """One pass over a window's events, unselected, gives what selecting the box's events first
    gives: their rotor signature, their number and their ON events (chunks as one array)."""
    rng = np.random.default_rng(2310)
    flicker = gen.flicker(400.0, 6, 60_000, 2, 0.02, rng)
    flicker["x"] += 20
    flicker["y"] += 10
    events = np.concatenate([flicker, gen.noise(3e4, 40, 60_000, rng)])
    events = events[np.argsort(events["t"], kind="stable")]
    for box in [(18, 9, 10, 8), (0, 0, 40, 40), (30, 30, 5, 5)]:
        x0, y0, w, h = box
        inside = in_box(events, (x0, y0, x0 + w, y0 + h))
        expected = (rotor_signature(inside, box), len(inside), int(inside["p"].sum()))
        assert measure_box(events, box)[:3] == expected
        assert measure_box(np.array_split(events, 5), box)[:3] == expected
        assert measure_box([], box)[:3] == (rotor_signature(events[:0], box), 0, 0)
        assert measure_box(events, box).rate_swing == 0.0
        # The rate: the box's events per 7 ms bin from 3 ms on, as a NumPy histogram counts
        # them, and its swing.
        rate, _ = np.histogram(inside["t"].astype(np.int64), bins=3000 + 7000 * np.arange(9))
        for part in (events, np.array_split(events, 5)):
            estimator = RotorSignature(box)
            estimator.count_rate(3000, 7000, 8)
            for chunk in (part,) if isinstance(part, np.ndarray) else part:
                estimator.update(chunk)
            np.testing.assert_array_equal(estimator.rate, rate)
            measured = measure_box(part, box, rate=(3000, 7000, 8))
            assert measured[:3] == expected
            assert measured.rate_swing == rate_swing(rate) == estimator.rate_swing
            estimator.clear()
            assert estimator.rate.tolist() == [0] * 8 and estimator.rate_swing == 0.0
        assert measure_box([], box, rate=(3000, 7000, 8)).rate_swing == 0.0
    assert measure_box(events, (18, 9, 10, 8))[0].detected
    with pytest.raises(ParameterError, match="bin_us"):
        measure_box(events, (18, 9, 10, 8), rate=(0, 0, 8))
    with pytest.raises(ParameterError, match="bins"):
        measure_box(events, (18, 9, 10, 8), rate=(0, 10, 5000))
    # Events out of time order are ignored by the estimator, as a stream's late events are,
    # and still counted; rotor_signature, given one array, refuses them.
    shuffled = events[rng.permutation(len(events))]
    inside = in_box(shuffled, (18, 9, 28, 17))
    streamed = RotorSignature((18, 9, 10, 8))
    streamed.update(inside)
    expected = (streamed.estimate(), len(inside), int(inside["p"].sum()))
    assert measure_box(shuffled, (18, 9, 10, 8))[:3] == expected
    with pytest.raises(EventError, match="in time order"):
        rotor_signature(inside, (18, 9, 10, 8))
    with pytest.raises(EventError):
        measure_box([events, np.zeros(3)], (0, 0, 4, 4))
    with pytest.raises(ParameterError, match="box"):
        measure_box(events, (0, 0, 0, 4))


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"f_min_hz": 0.0}, "f_min_hz"),
        ({"f_min_hz": float("nan")}, "f_min_hz"),
        ({"f_max_hz": 40.0}, "f_min_hz"),
        ({"f_max_hz": 1e7}, "f_max_hz"),
        ({"bins": 2}, "bins"),
        ({"bins": -1}, "bins"),
        ({"consistency": 1.5}, "consistency"),
        ({"agree": -0.1}, "agree"),
        ({"threshold": float("inf")}, "threshold"),
        ({"min_pixels": -1}, "min_pixels"),
    ],
)
def test_bad_parameters_are_parameter_errors(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        RotorSignature((0, 0, 4, 4), **kwargs)


@pytest.mark.parametrize(
    "box",
    [(0, 0, 0, 4), (-1, 0, 4, 4), (65_535, 0, 2, 2), (0, 0, 4097, 1024), (0, 0, 4), "abcd", None],
)
def test_bad_boxes_are_parameter_errors(box):
    with pytest.raises(ParameterError, match="box"):
        RotorSignature(box)


@pytest.mark.parametrize(
    ("make", "name"),
    [
        (lambda: RotorSignature((0, 0, 4, 4), bins=64.9), "bins"),
        (lambda: RotorSignature((0, 0, 4, 4), min_pixels=2.9), "min_pixels"),
        (lambda: RotorSignature((0, 0, 4, 4), bins=True), "bins"),
        (lambda: RotorSignature((10.9, 0, 4, 4)), "box"),
        (lambda: RotorSignature((0, 0, 4, 4.5)), "box"),
        (lambda: RotorSignature((True, 0, 4, 4)), "box"),
        (lambda: RotorSignature((2**64, 10, 8, 8)), "box"),
        (lambda: rotor_signature(np.zeros(0, EVENT_DTYPE), (2**64, 10, 8, 8)), "box"),
        (lambda: RotorSignature((0, 0, 4, 4)).count_rate(0.7, 5000, 40), "start_us"),
        (lambda: RotorSignature((0, 0, 4, 4)).count_rate(0, 5000.9, 40), "bin_us"),
        (lambda: RotorSignature((0, 0, 4, 4)).count_rate(0, 5000, 40.2), "bins"),
        (lambda: RotorSignature((0, 0, 4, 4)).count_rate(2**64, 5000, 40), "start_us"),
        (lambda: RotorSignature((0, 0, 4, 4)).count_rate(0, "5000", 40), "bin_us"),
        (lambda: rotor_spectrum(np.zeros(0, EVENT_DTYPE), (0, 0, 4, 4), bin_us=250.9), "bin_us"),
        (lambda: rotor_spectrum(np.zeros(0, EVENT_DTYPE), (0, 0, 4, 4), span_us=2**64), "span_us"),
        (lambda: RotorSpectrum((0, 0, 4, 4), min_events=3.5), "min_events"),
        (lambda: estimate_motion(np.zeros(0, EVENT_DTYPE), (0, 0, 4, 4), min_events=2.5), "min_e"),
        (lambda: estimate_motion(np.zeros(0, EVENT_DTYPE), (0, 0, 4, 4), min_gain="x"), "min_gain"),
        # Numeric strings and bools were converted by float().
        (lambda: RotorSignature((0, 0, 4, 4), f_min_hz="60"), "f_min_hz"),
        (lambda: RotorSignature((0, 0, 4, 4), threshold=True), "threshold"),
        (lambda: RotorSpectrum((0, 0, 4, 4), agree="0.05"), "agree"),
    ],
)
def test_fractions_and_huge_integers_are_refused_not_truncated(make, name):
    with pytest.raises(ParameterError, match=name):
        make()


def test_whole_floats_and_numpy_integers_are_the_integers_they_hold():
    events = np.zeros(0, EVENT_DTYPE)
    box = (np.uint16(2), np.int64(3), 4.0, 5)
    assert RotorSignature(box, bins=64.0).box == (2, 3, 4, 5)
    assert rotor_spectrum(events, box, bin_us=np.int64(250)) == rotor_spectrum(events, (2, 3, 4, 5))
    s = RotorSignature((0, 0, 4, 4))
    s.count_rate(np.uint64(0), 5000.0, np.int32(4))
    assert s.rate.tolist() == [0] * 4


def test_the_cap_is_the_documented_one():
    RotorSignature((0, 0, 2048, 2048)).clear()  # exactly MAX_PIXELS
    assert MAX_PIXELS == 2048 * 2048


def test_bad_events_are_event_errors():
    s = RotorSignature((0, 0, 4, 4))
    with pytest.raises(EventError):
        s.update(np.zeros(3, dtype=np.int64))
    with pytest.raises(EventError):
        s.update(np.zeros((2, 2), dtype=EVENT_DTYPE))
    with pytest.raises(ParameterError):
        RotorSignature.for_sensor((0, 5))
    assert s.stats["events"] == 0


# --- the rate spectrum ---------------------------------------------------------------------


@pytest.mark.parametrize("f", [50.0, 73.0, 150.0, 240.0, 410.0, 520.0, 777.0, 1000.0])
def test_pulses_come_back_within_two_percent(gen, f):
    # One event per cycle per pixel, one polarity: what the edge estimator cannot use.
    rng = np.random.default_rng(2200 + int(f))
    events = gen.pulses(f, 8, 100_000, 0.02, rng)
    est = rotor_spectrum(events, (0, 0, 8, 1))
    assert abs(est.frequency_hz - f) <= 0.02 * f, est
    # Below about 100 Hz the harmonics of a 100 ms window fill the band (documented): each
    # pixel's own peak may sit on any of them, and the median lies on the comb.
    assert (est.detected and est.pixels >= 7) or f < 100.0, est
    assert not rotor_signature(events, (0, 0, 8, 1)).detected


@given(f=st.floats(55.0, 1000.0), jitter=st.floats(0.0, 0.03), seed=st.integers(2000, 2**32))
def test_any_pulse_rate_in_the_band_comes_back(gen, f, jitter, seed):
    # From 55 Hz: just above 50 Hz, over four pixels with jitter, the second harmonic can win
    # (docs/identification.md, "Rotor spectrum").
    events = gen.pulses(f, 4, 100_000, jitter, np.random.default_rng(seed))
    est = rotor_spectrum(events, (0, 0, 4, 1))
    assert abs(est.frequency_hz - f) <= 0.02 * f, est


def test_uniform_noise_raises_no_spectral_peak(gen):
    threshold = float(SPECTRUM_DEFAULTS["threshold"])
    worst, runs = 0.0, 0
    for seed in range(2000, 2025):
        rng = np.random.default_rng(seed)
        for side in gen.SPECTRUM_SIDES:
            for rate in gen.SPECTRUM_RATES:
                est = rotor_spectrum(gen.noise(rate, side, 100_000, rng), (0, 0, side, side))
                assert not est.detected, (seed, side, rate, est)
                if est.pixels >= SPECTRUM_DEFAULTS["min_pixels"]:
                    worst = max(worst, est.prominence)
                runs += 1
    assert runs == 25 * len(gen.SPECTRUM_SIDES) * len(gen.SPECTRUM_RATES)
    # Well below the threshold, not just below it.
    assert worst < threshold / 2, worst


def test_spectrum_script_reports(gen, capsys):
    gen.main(["--estimator", "spectrum", "--seeds", "2", "--first-seed", "3000",
              "--window-ms", "20", "--propeller-ms", "5"])  # fmt: skip
    out = capsys.readouterr().out
    assert "| 2×2 | 1e+02 |" in out and "| 1000 |" in out and "| 250 | 500 |" in out


def test_spectrum_state_is_fixed_and_events_are_counted(gen):
    s = RotorSpectrum((10, 20, 8, 8), span_us=20_000)
    before = s.state_bytes
    events = gen.noise(1e5, 40, 50_000, np.random.default_rng(2300))
    s.update(events)
    s.estimate()
    st = s.stats
    assert s.state_bytes == before
    assert st["events"] + st["outside"] + st["late"] + st["beyond"] == len(events)
    assert st["beyond"] > 0 and st["outside"] > 0
    chunks = RotorSpectrum((10, 20, 8, 8), span_us=20_000)
    for part in np.array_split(events, 7):
        chunks.update(part)
    assert chunks.estimate() == s.estimate()
    s.clear()
    assert s.stats == {"events": 0, "outside": 0, "late": 0, "beyond": 0}
    f, p = s.power()
    # The band's grid and two points beyond each end.
    assert len(f) == len(p) == SPECTRUM_DEFAULTS["freqs"] + 4 and not p.any()
    assert f[2] == pytest.approx(SPECTRUM_DEFAULTS["f_min_hz"])
    assert f[-3] == pytest.approx(SPECTRUM_DEFAULTS["f_max_hz"])


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"bin_us": 0}, "bin_us"),
        ({"span_us": 100}, "span_us"),
        ({"f_min_hz": float("nan")}, "f_min_hz"),
        ({"f_max_hz": 5000.0}, "f_max_hz"),
        ({"freqs": 2}, "freqs"),
        ({"min_events": 0}, "min_events"),
        ({"agree": 2.0}, "agree"),
        ({"threshold": -1.0}, "threshold"),
        ({"min_pixels": -1}, "min_pixels"),
        ({"bins": 3}, "bins"),
        ({"freqs": "many"}, "numbers"),
    ],
)
def test_bad_spectrum_parameters_are_parameter_errors(kwargs, name):
    with pytest.raises(ParameterError, match=name):
        RotorSpectrum((0, 0, 4, 4), **kwargs)


def test_an_oversized_spectrum_is_refused_before_allocating():
    with pytest.raises(ParameterError, match=str(MAX_SPECTRUM_BYTES)):
        RotorSpectrum((0, 0, 2048, 2048))
    with pytest.raises(EventError):
        RotorSpectrum((0, 0, 4, 4)).update(np.zeros(3, dtype=np.int64))


# --- the real spinner ----------------------------------------------------------------------


def _spinner(shared_data):
    from uavsnn import io

    path = shared_data / "dvs" / "prophesee_gen3_spinner_evt2.raw"
    if not path.exists():
        pytest.skip(f"{path.name} not in the shared data")
    return io.read(path, sensor_size=(640, 480)).events


def _ring(events):
    """Events of the rotating arc: the ring around the densest region, hot pixels left out."""
    idx = events["y"].astype(np.int64) * 640 + events["x"]
    counts = np.bincount(idx, minlength=640 * 480)
    keep = counts[idx] < 200  # a pixel the arc passes fires tens of events, a hot one thousands
    x = events["x"][keep].astype(float)
    y = events["y"][keep].astype(float)
    t = (events["t"][keep] - events["t"][0]).astype(float)
    cx, cy = np.median(x), np.median(y)
    r = np.hypot(x - cx, y - cy)
    near = r < 2 * np.median(r)
    return t[near], x[near], y[near]


def rotation_from_arc_angle(t, x, y):
    """Method 1: the arc's circular-mean angle (about the events' centroid) in 1 ms slices,
    unwrapped, and a straight line through it: revolutions per second."""
    cx, cy = x.mean(), y.mean()
    z = np.exp(1j * np.arctan2(y - cy, x - cx))
    edges = np.arange(0, t.max(), 1000.0)
    slot = np.searchsorted(edges, t, side="right") - 1
    sums = np.bincount(slot, weights=z.real) + 1j * np.bincount(slot, weights=z.imag)
    angles = np.unwrap(np.angle(sums))
    slope = np.polyfit(edges + 500.0, angles, 1)[0]  # rad / µs
    return slope * 1e6 / (2 * np.pi)


def rotation_from_passage_times(t, x, y):
    """Method 2: when the arc first reaches each pixel. The ring's centre from a circle fitted
    to the pixels that fire (algebraic least squares), each pixel's angle about it measured from
    the direction the arc never covers at the start, the median first-event time per 5° sector,
    and a straight line through time against angle: revolutions per second."""
    pix = y.astype(np.int64) * 640 + x.astype(np.int64)
    _, first, counts = np.unique(pix, return_index=True, return_counts=True)
    busy = counts >= 5  # pixels the arc passes, not stray noise
    px, py, pt = x[first][busy], y[first][busy], t[first][busy]
    a = np.column_stack([px, py, np.ones_like(px)])
    c = np.linalg.lstsq(a, px**2 + py**2, rcond=None)[0]
    angle = np.arctan2(py - c[1] / 2, px - c[0] / 2)
    sector = ((angle + np.pi) // np.radians(5)).astype(int) % 72
    pixels = np.bincount(sector, minlength=72)
    gap = int(np.argmin(pixels))  # the sector with fewest pixels: between the arc's ends
    rel = (sector - gap) % 72
    times, centres = [], []
    for k in range(72):
        here = rel == k
        if here.sum() >= 5:
            m = float(np.median(pt[here]))
            if 2_000.0 < m < t.max() - 2_000.0:  # the arc was not already there, nor still there
                times.append(m)
                centres.append(k * 5.0)
    slope = np.polyfit(centres, times, 1)[0]  # µs per degree
    return 1e6 / (slope * 360.0)


def test_spinner_rotation_by_two_methods_and_no_false_rotor(shared_data):
    events = _spinner(shared_data)
    t, x, y = _ring(events)
    rate_a = abs(rotation_from_arc_angle(t, x, y))
    rate_b = abs(rotation_from_passage_times(t, x, y))
    # The two independent measurements agree within 2 %, near 19.4 rev/s.
    assert abs(rate_a - rate_b) <= 0.02 * rate_a, (rate_a, rate_b)
    assert 15.0 < rate_a < 25.0, rate_a
    # The recording spans less than one revolution, so no pixel sees the arc twice: the
    # estimator must report no periodicity, in its band or below it, rather than invent one.
    span_s = float(events["t"][-1] - events["t"][0]) * 1e-6
    assert span_s * rate_a < 1.0
    for band in ((50.0, 1000.0), (5.0, 1000.0)):
        est = rotor_signature(events, (0, 0, 640, 480), f_min_hz=band[0], f_max_hz=band[1])
        assert not est.detected and est.votes == 0, (band, est)
    # Nor does the rate spectrum over the ring's bounding box: each pixel sees one passage.
    box = (int(x.min()), int(y.min()), int(x.max() - x.min()) + 1, int(y.max() - y.min()) + 1)
    est = rotor_spectrum(events, box)
    assert est.channels > 1000 and not est.detected, est


def test_a_misspelt_parameter_passed_on_is_refused_by_name() -> None:
    # The functions that pass ``**params`` on to an estimator refuse an unknown name as the
    # spectrum estimator does (a ParameterError naming it), not with Python's bare TypeError.
    none = np.zeros(0, dtype=EVENT_DTYPE)
    calls = [
        lambda: rotor_signature(none, (0, 0, 4, 4), fmin_hz=3.0),
        lambda: RotorSignature.for_sensor((10, 10), thresold=1.0),
        lambda: measure_box(none, (0, 0, 4, 4), bin=3),
        lambda: rotor_spectrum(none, (0, 0, 4, 4), bins=3),
    ]
    for call, name in zip(calls, ("fmin_hz", "thresold", "bin", "bins"), strict=True):
        with pytest.raises(ParameterError, match=f"unknown rotor .* parameters \\['{name}'\\]"):
            call()
    # The right names still pass.
    assert not rotor_signature(none, (0, 0, 4, 4), f_min_hz=60.0).detected
