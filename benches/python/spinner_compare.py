"""The emulator against a real event camera: the Prophesee Gen3 spinner recording.

Reads ``dvs/prophesee_gen3_spinner_evt2.raw`` from the shared data folder (a rotating dark arc,
640x480, 50 ms), estimates its centre and rotation rate from the events alone
(``uavsnn.sim.checks.estimate_rotation``) and the arc's extent (radii holding 90 % of the
events, the angle between the OFF front and the ON back), renders a matching arc rotating at
that rate — frames every 50 us, so the arc's rim moves under a pixel per frame — through the
emulator (``uavsnn.sim.SCENE_PARAMS``; then with a 1 us refractory period; then also with the
ON threshold lowered by the real ON/OFF ratio per pixel), and compares events per revolution,
events per pixel, the ON fraction and the event-rate spectrum. The arc's contrast is set once
from the real OFF events per pixel (the leading edge: ``exp(θ · median OFF per pixel)``);
everything else is compared.

    python benches/python/spinner_compare.py DATA_DIR [--png docs/spinner_spectra.png]

Prints a Markdown table; docs/simulation.md keeps its output and the picture.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from uavsnn import io
from uavsnn.sim import SCENE_PARAMS, DvsEmulator, DvsParams
from uavsnn.sim.checks import estimate_rotation, event_rate_spectrum, plot_spectra

FRAME_US = 50


def per_pixel(ev: np.ndarray, width: int) -> tuple[float, float]:
    """Median ON and OFF events per pixel that has any."""
    out = []
    for p in (True, False):
        e = ev[ev["p"] == p]
        pix = e["y"].astype(np.int64) * width + e["x"]
        out.append(float(np.median(np.unique(pix, return_counts=True)[1])) if len(e) else 0.0)
    return out[0], out[1]


def arc_events(
    rev_hz: float,
    centre: tuple[float, float],
    radii: tuple[float, float],
    width_rad: float,
    arc_luma: float,
    bg_luma: float,
    duration_us: int,
    params: DvsParams,
) -> np.ndarray:
    """A dark annular sector turning at ``rev_hz`` over a bright background, emulated on a
    crop around it (events moved back to sensor coordinates)."""
    r0, r1 = radii
    half = int(r1) + 4
    x0, y0 = int(centre[0]) - half, int(centre[1]) - half
    side = 2 * half
    yy, xx = np.mgrid[0:side, 0:side].astype(np.float64) + 0.5
    dx, dy = xx + x0 - centre[0], yy + y0 - centre[1]
    r = np.hypot(dx, dy)
    theta = np.arctan2(dy, dx)
    # Coverage, anti-aliased over about a pixel across each edge.
    radial = np.clip(r - r0 + 0.5, 0, 1) * np.clip(r1 - r + 0.5, 0, 1)
    emu = DvsEmulator((side, side), params=params, seed=1)
    chunks = []
    times = np.arange(0, duration_us + 1, FRAME_US, dtype=np.uint64)
    for start in range(0, len(times), 100):
        ts = times[start : start + 100]
        frames = np.empty((len(ts), side, side), np.float32)
        for k, t in enumerate(ts.tolist()):
            phase = 2 * np.pi * rev_hz * t * 1e-6
            d = np.angle(np.exp(1j * (theta - phase)))
            across = np.clip((width_rad / 2 - np.abs(d)) * r + 0.5, 0, 1)
            cover = radial * across
            frames[k] = bg_luma + (arc_luma - bg_luma) * cover
        chunks.append(emu.process(frames, ts))
    ev = np.concatenate(chunks)
    ev["x"] += x0
    ev["y"] += y0
    return ev


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", type=Path, help="the shared data folder (holds dvs/)")
    ap.add_argument("--png", type=Path, default=None)
    args = ap.parse_args()
    rec = io.read(args.data / "dvs" / "prophesee_gen3_spinner_evt2.raw", sensor_size=(640, 480))
    real = rec.events
    span_us = int(real["t"][-1] - real["t"][0]) + 1
    rev_hz, cx, cy, conc = estimate_rotation(real)
    x, y = real["x"] - cx, real["y"] - cy
    rr = np.hypot(x, y)
    r0, r1 = np.percentile(rr, [5, 95])
    t = (real["t"].astype(np.int64) - int(real["t"][0])) * 1e-6
    rel = np.angle(np.exp(1j * (np.arctan2(y, x) - 2 * np.pi * rev_hz * t)))
    rel = np.angle(np.exp(1j * (rel - np.angle(np.exp(1j * rel).mean()))))
    on = real["p"].astype(bool)
    # The front (OFF, the arc arriving) and the back (ON, leaving): their median angles.
    width = float(abs(np.median(rel[~on]) - np.median(rel[on])))
    on_px, off_px = per_pixel(real, 640)
    bg = 200.0
    theta = SCENE_PARAMS.threshold_off
    arc = bg / float(np.exp(theta * off_px))
    print(
        f"Real: {len(real)} events over {span_us / 1e3:.1f} ms; centre ({cx:.1f}, {cy:.1f}); "
        f"rotation {rev_hz:.2f} rev/s (concentration {conc:.3f}); arc radii {r0:.0f}-{r1:.0f} "
        f"px, {width:.3f} rad between OFF front and ON back; arc luma {arc:.1f} on {bg:g} "
        f"(from {off_px:g} OFF events per pixel at θ {theta:g}).\n"
    )
    ratio = on_px / max(off_px, 1e-9)
    fast = dataclasses.replace(SCENE_PARAMS, refractory_us=1.0)
    variants = {
        "emulated, SCENE_PARAMS (refractory 100 us)": SCENE_PARAMS,
        "emulated, refractory 1 us": fast,
        f"emulated, refractory 1 us, th_on = th_off / {ratio:.2f}": dataclasses.replace(
            fast, threshold_on=theta / ratio
        ),
    }
    runs = {"real (Prophesee Gen3)": real}
    for name, params in variants.items():
        runs[name] = arc_events(rev_hz, (cx, cy), (r0, r1), width, arc, bg, span_us, params)
    print(
        "| | events | events / rev | ON fraction | ON / pixel | OFF / pixel | rate peak Hz "
        "(>= 20 Hz) | its relative amplitude |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    curves = []
    for name, ev in runs.items():
        n = len(ev)
        per_rev = n / (span_us * 1e-6 * rev_hz)
        a, b = per_pixel(ev, 640)
        f, p = event_rate_spectrum(ev["t"], bin_us=100, relative=True)
        band = f >= 20
        peak = float(f[band][np.argmax(p[band])])
        mod = float(np.sqrt(p[band].max()))
        print(
            f"| {name} | {n} | {per_rev:.0f} | {float(ev['p'].mean()):.3f} | {a:g} | {b:g} "
            f"| {peak:.0f} | {mod:.4f} |"
        )
        curves.append((name, f, p))
    top = max(float(c[2][c[1] >= 20].max()) for c in (curves[0], curves[-1]))
    if args.png is not None:
        plot_spectra(
            [(c[0], c[1], c[2] / top) for c in (curves[0], curves[-1])],
            str(args.png),
            title=(
                f"spinner: power of the relative event-rate modulation (one scale), "
                f"{rev_hz:.2f} rev/s marked"
            ),
            max_hz=1000.0,
            marks=(rev_hz,),
        )
        print(f"\nwrote {args.png}")


if __name__ == "__main__":
    main()
