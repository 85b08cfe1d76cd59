"""A rotor alone, rendered and emulated: its pixels' event-rate spectrum peaks at the blade
pass (two blades × the rotation rate) within 2 % when fast parts are sampled between frames,
and not when the rotor is rendered at the old 500 fps only. The full grid of rates and sizes
is ``benches/python/rotor_grid.py`` (docs/simulation.md)."""

from __future__ import annotations

import numpy as np
import pytest

from uavsnn.sim import SCENE_PARAMS, DvsParams
from uavsnn.sim.checks import dominant_frequency, pixel_rate_spectrum, rotor_events


def _peak(rev_hz: float, size_px: float, **kw: object) -> tuple[float, int]:
    ev, _ = rotor_events(rev_hz, size_px, duration_s=0.2, **kw)  # type: ignore[arg-type]
    return dominant_frequency(*pixel_rate_spectrum(ev)), len(ev)


@pytest.mark.parametrize(("rev_hz", "size_px"), [(150.0, 6.0), (600.0, 6.0), (300.0, 12.0)])
def test_rotor_spectrum_peaks_at_the_blade_pass(rev_hz: float, size_px: float) -> None:
    peak, n = _peak(rev_hz, size_px)
    blade_pass = 2 * rev_hz
    assert n > 100
    assert abs(peak - blade_pass) <= 0.02 * blade_pass, (peak, blade_pass)


@pytest.mark.parametrize("rev_hz", [150.0, 600.0])
def test_the_old_500_fps_rendering_aliases(rev_hz: float) -> None:
    """Frames at 500 fps alone sample a 300 Hz or 1200 Hz blade pass below Nyquist's two
    samples per passage: the peak lands elsewhere. This is what the sub-frame samples fix."""
    peak, n = _peak(rev_hz, 12.0, samples_per_pass=0)
    blade_pass = 2 * rev_hz
    assert n > 100
    assert abs(peak - blade_pass) > 0.02 * blade_pass, (
        f"at 500 fps without sub-frame samples the peak ({peak:.0f} Hz) should miss the "
        f"{blade_pass:.0f} Hz blade pass"
    )


def test_the_rotor_blurs_in_the_dark() -> None:
    """The photoreceptor's bandwidth follows the light (SCENE_PARAMS: proportional to it): the
    blade pass a noon sky shows fades at dusk (light level 0.05), as on a real sensor. Without
    the low-pass the dusk rotor still flickers (so it is the bandwidth, not the lin-log
    response), and with v2e's 20-luma offset it fades much less."""
    kw = {"duration_s": 0.2, "rev_hz": 300.0, "size_px": 12.0}

    def run(params: DvsParams, level: float) -> np.ndarray:
        ev, _ = rotor_events(
            kw["rev_hz"], kw["size_px"], duration_s=kw["duration_s"], params=params, level=level
        )
        return ev

    noon, dusk = run(SCENE_PARAMS, 1.0), run(SCENE_PARAMS, 0.05)
    unfiltered = run(DvsParams.ideal(), 0.05)
    v2e_offset = run(DvsParams(cutoff_hz=3000.0), 0.05)
    assert len(dusk) < 0.02 * len(noon), (len(dusk), len(noon))
    assert len(unfiltered) > 0.5 * len(noon), (len(unfiltered), len(noon))
    assert len(v2e_offset) > 5 * len(dusk), (len(v2e_offset), len(dusk))
    assert abs(dominant_frequency(*pixel_rate_spectrum(noon)) - 600.0) <= 12.0


def test_spectrum_of_a_known_pulse_train() -> None:
    """The spectrum helpers on a synthetic pulse train: one pixel firing ON at 437 Hz."""
    t = np.round(np.arange(400) * 1e6 / 437.0).astype(np.uint64)
    ev = np.zeros(len(t), dtype=[("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("p", "u1")])
    ev["t"], ev["p"] = t, 1
    f, pw = pixel_rate_spectrum(ev)
    assert abs(dominant_frequency(f, pw) - 437.0) < 0.01 * 437.0
    assert np.isnan(dominant_frequency(f, np.zeros_like(pw)))


def test_spectra_and_rotation_refuse_what_would_not_fit_before_allocating() -> None:
    """A span of 10^12 µs asked for 149 GiB of bins, a search of ±10^9 Hz in 10^-3 Hz steps
    for 298 GiB, and a NaN max_hz was NumPy's ValueError: refused by name, before any array."""
    from uavsnn import EVENT_DTYPE, EventError, ParameterError
    from uavsnn.sim.checks import (
        MAX_ROTATION_GRID,
        MAX_SPECTRUM_POINTS,
        estimate_rotation,
        event_rate_spectrum,
    )

    far = np.array([0, 10**12])
    with pytest.raises(ParameterError, match="MAX_SPECTRUM_POINTS"):
        event_rate_spectrum(far)
    ev = np.zeros(2, dtype=EVENT_DTYPE)
    ev["t"] = far
    with pytest.raises(ParameterError, match="MAX_SPECTRUM_POINTS"):
        pixel_rate_spectrum(ev)
    with pytest.raises(ParameterError, match="MAX_SPECTRUM_POINTS"):
        pixel_rate_spectrum(ev[:1], start_us=0, end_us=10**12)
    # At the bound, a spectrum is made; a bin more is refused.
    bins = MAX_SPECTRUM_POINTS // 8
    f, p = event_rate_spectrum(np.array([0, 50 * bins - 1]), bin_us=50, pad=8)
    assert len(f) == MAX_SPECTRUM_POINTS // 2 + 1 == len(p)
    with pytest.raises(ParameterError, match="bin_us=50 us, padded pad=8 times"):
        event_rate_spectrum(np.array([0, 50 * bins + 49]), bin_us=50, pad=8)
    for bad in (["a"], [1.5], [-1, 3], np.zeros((2, 2), np.int64)):
        with pytest.raises(ParameterError, match="t_us"):
            event_rate_spectrum(bad)
    with pytest.raises(ParameterError, match="box"):
        pixel_rate_spectrum(ev, box=(1.0, 2.0))
    # (x, y, width, height), the rotor estimators' form, read as corners: empty, refused (it
    # gave a spectrum of NaN).
    with pytest.raises(ParameterError, match="x1 > x0 and y1 > y0"):
        pixel_rate_spectrum(ev, box=(30, 20, 12, 10))
    with pytest.raises(ParameterError, match="chunk"):
        pixel_rate_spectrum(ev[:1], chunk=0)
    with pytest.raises(EventError, match="fields t, x, y, p"):
        pixel_rate_spectrum(np.arange(5))

    spun = np.zeros(5, dtype=EVENT_DTYPE)
    spun["t"], spun["x"], spun["y"] = np.arange(5), [1, 2, 3, 2, 1], [2, 3, 2, 1, 2]
    with pytest.raises(ParameterError, match="MAX_ROTATION_GRID"):
        estimate_rotation(spun, max_hz=1e9, step_hz=1e-3)
    with pytest.raises(ParameterError, match="MAX_ROTATION_GRID"):
        estimate_rotation(spun, max_hz=1e308, step_hz=1e-300)
    for name, kw in (
        ("max_hz", {"max_hz": float("nan")}),
        ("max_hz", {"max_hz": 0.0}),
        ("step_hz", {"step_hz": -1.0}),
        ("step_hz", {"step_hz": float("inf")}),
        ("max_hz", {"max_hz": "200"}),
    ):
        with pytest.raises(ParameterError, match=name):
            estimate_rotation(spun, **kw)  # type: ignore[arg-type]
    with pytest.raises(EventError, match="fields t, x, y"):
        estimate_rotation(np.arange(5))
    # The largest search the bound allows runs; the default's 801 rates are far below it.
    step = 2 * 200.0 / (50 * (MAX_ROTATION_GRID - 2))
    assert np.isfinite(estimate_rotation(spun, max_hz=200.0, step_hz=step)[0])


def test_a_rendered_drone_shows_its_blade_pass_not_a_beat_with_the_frame_rate() -> None:
    """A scene's drone, its blades drawn at frames on a coarser coverage grid than between
    them: the frames' coverage differed from the sub-frame samples' by the blades' phase, and a
    blade pass of 0.8 times the frame rate (400 Hz at 500 fps) repeats its phase at frames
    every fifth, 100 Hz, which both rotor estimators found instead (a new user's walk). Drawn
    alike at frames and between, the blade pass comes back. (At 6 m: at 8 m the rotor sampled
    24 times a passage lights one or two pixels, too few for either to call it.)"""
    from uavsnn.scenes import record, spec_from_dict
    from uavsnn.signature import rotor_signature, rotor_spectrum

    drone = {"kind": "phantom", "size_m": 0.29, "rate_hz": 200.0,
             "path": {"kind": "hover", "start": [0.0, -0.3, 6.0]}}  # fmt: skip
    scene = {"domain": "dvs", "width": 240, "height": 180, "fps": 500, "duration_s": 0.2,
             "focal_px": 220, "tilt_deg": 15, "background": {"kind": "sky", "cloud_cover": 0.0},
             "objects": [drone]}  # fmt: skip
    spec = spec_from_dict(scene)
    rec = record(spec, sensor=(240, 180), seed=1)
    held = (rec.timestamps_us >= 50_000) & (rec.timestamps_us <= 150_000)
    box = [rec.labels[k][held] for k in ("x0", "y0", "x1", "y1")]
    x0, y0 = int(box[0].min()), int(box[1].min())
    x1, y1 = int(np.ceil(box[2].max())), int(np.ceil(box[3].max()))
    t = rec.recording.events["t"]
    window = rec.recording.events[(t >= 50_000) & (t < 150_000)]
    edges = rotor_signature(window, (x0, y0, x1 - x0, y1 - y0))
    spectrum = rotor_spectrum(window, (x0, y0, x1 - x0, y1 - y0))
    assert spectrum.detected and abs(spectrum.frequency_hz - 400) <= 8, spectrum
    assert edges.detected and abs(edges.frequency_hz - 400) <= 8, edges
