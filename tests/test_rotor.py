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
