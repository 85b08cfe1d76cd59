"""How the rotor signature's detection threshold was chosen, and how exact its frequency is.

1. **Noise.** Uniform random events (uniform times, pixels and polarities) in a box, at total
   rates from 1 k to 1 M events/s, in 16×16 and 64×64 boxes, over ``--window-ms`` of event time,
   for ``--seeds`` seeds starting at ``--first-seed`` (default 0..199: seeds no test uses; the
   tests use 1000 and up). Prints, per rate and box, the largest strength, its 99th percentile,
   the largest number of agreeing pixels, and how many runs pass the detection rule at the
   default threshold (``uavsnn.signature.DEFAULTS``) and at ``--threshold``s given.
2. **Flicker.** Every pixel of a 16×16 box flickering at f (a run of ``--run`` ON events then as
   many OFF events per cycle, each edge jittered uniformly by ±``--jitter`` of the period, each
   pixel with its own phase) for f from 50 to 1000 Hz: the frequency found, its error, the
   strength and the agreeing pixels, over ``--window-ms``.
3. **Emulated propeller.** A two-blade propeller (dark blades, 36° wide, on a bright sky) drawn
   in a 24×24 box at 20,000 frames/s with 4×4 supersampling, turned into events by the dvs
   domain's sensor model (``uavsnn.sim.dvs.emulate_dvs``, default parameters: threshold
   mismatch, refractory period, leak and shot noise, hot pixels), at 5 to 250 rev/s: the
   blade-pass frequency (twice the rotation rate) against the one found, over 100 ms.

Run from the repository root after ``maturin develop --release``::

    python benches/python/rotor_noise.py [--seeds 200] [--first-seed 0] [--window-ms 100]
        [--propeller-ms 100] [--threshold T ...] [--figure rotor-signature.png]

``--figure`` draws both: the noise's largest strength against its rate, and the flicker's
strength against its frequency at jitters of ±2 % and ±5 %, each with the threshold.

``--estimator spectrum`` measures the event-rate spectrum (``uavsnn.signature.rotor_spectrum``)
instead, the same way: noise in 2×2 to 64×64 boxes from 10² to 10⁶ events/s (the small boxes
and low rates are its worst case: a few channels of a few events give a spiky spectrum), the
largest prominence over all runs and over the runs with at least ``min_pixels`` agreeing pixels,
and how many runs pass the rule; then one-event-per-cycle pixels and the emulated propeller::

    python benches/python/rotor_noise.py --estimator spectrum [--seeds 200] [--threshold T ...]

``--estimator compensated`` measures the motion-compensated rotor
(``uavsnn.signature.compensated_rotor``: the box's velocity by contrast maximisation, the events
moved to the object's frame, then both estimators): the same noise as the edge estimator's
(a detection by either estimator, and one left after ``motion_line``), then a 12×12 flickering
patch and the emulated propeller (24 and 8 px) moving across their box at 0 to 1000 px/s, each
read plain and compensated over 50 ms::

    python benches/python/rotor_noise.py --estimator compensated [--seeds 200]
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

import numpy as np

from uavsnn.events import EVENT_DTYPE
from uavsnn.signature import (
    DEFAULTS,
    SPECTRUM_DEFAULTS,
    compensated_rotor,
    motion_line,
    rotor_signature,
    rotor_spectrum,
)

RATES = (1e3, 1e4, 3e4, 1e5, 3e5, 1e6)
SIDES = (16, 64)
PROPELLER_REV_S = (5.0, 40.0, 100.0, 150.0, 200.0, 250.0)
FREQUENCIES = (50.0, 80.0, 120.0, 200.0, 260.0, 400.0, 520.0, 700.0, 1000.0)


def noise(rate: float, side: int, window_us: int, rng: np.random.Generator) -> np.ndarray:
    """Uniform random events in a ``side``×``side`` box at ``rate`` events/s."""
    n = int(rate * window_us * 1e-6)
    events = np.zeros(n, dtype=EVENT_DTYPE)
    events["t"] = np.sort(rng.integers(0, window_us, n))
    events["x"] = rng.integers(0, side, n)
    events["y"] = rng.integers(0, side, n)
    events["p"] = rng.integers(0, 2, n).astype(bool)
    return events


def noise_estimates(
    estimate: Callable[..., Any], rate: float, side: int, window_us: int, args: argparse.Namespace
) -> list[Any]:
    """``estimate`` (an estimator of :mod:`uavsnn.signature`) on the noise of each seed
    (``--seeds`` from ``--first-seed``) in a ``side``×``side`` box."""
    out = []
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        rng = np.random.default_rng(seed)
        out.append(estimate(noise(rate, side, window_us, rng), (0, 0, side, side)))
    return out


def pass_counts(s: np.ndarray, px: np.ndarray, thresholds: list[float], min_pixels: int) -> str:
    """The table's cells: of the noise windows, how many reach each threshold with at least
    ``min_pixels`` agreeing pixels."""
    return " | ".join(f"{int(((s >= t) & (px >= min_pixels)).sum())}/{s.size}" for t in thresholds)


def flicker(
    f: float,
    side: int,
    window_us: int,
    run: int,
    jitter: float,
    rng: np.random.Generator,
    *,
    coherent: bool = False,
) -> np.ndarray:
    """Every pixel of the box flickering at ``f`` Hz (see the module's documentation); with
    ``coherent``, every pixel in one phase (a lamp rather than a texture), edges still jittered
    pixel by pixel."""
    period = 1e6 / f
    cycles = int(window_us / period) + 2
    ts, xs, ys, ps = [], [], [], []
    common = rng.uniform(0, period)
    for y in range(side):
        for x in range(side):
            phase = common if coherent else rng.uniform(0, period)
            starts = phase + period * np.arange(-1, cycles)
            for half, p in ((0.0, True), (0.5, False)):
                edges = starts + half * period + rng.uniform(-jitter, jitter, starts.size) * period
                t = (edges[:, None] + 0.02 * period * np.arange(run)[None, :]).ravel()
                ts.append(t)
                xs.append(np.full(t.size, x))
                ys.append(np.full(t.size, y))
                ps.append(np.full(t.size, p))
    t = np.concatenate(ts)
    keep = (t >= 0) & (t < window_us)
    order = np.argsort(t[keep], kind="stable")
    events = np.zeros(order.size, dtype=EVENT_DTYPE)
    events["t"] = t[keep][order].astype(np.uint64)
    events["x"] = np.concatenate(xs)[keep][order]
    events["y"] = np.concatenate(ys)[keep][order]
    events["p"] = np.concatenate(ps)[keep][order]
    return events


def propeller(
    rev_s: float,
    *,
    blades: int = 2,
    size: int = 24,
    fps: float = 20_000.0,
    duration_s: float = 0.1,
    seed: int = 1,
) -> np.ndarray:
    """Events of a propeller turning at ``rev_s`` revolutions/s, through the dvs emulator (see the
    module's documentation)."""
    from uavsnn.sim.dvs import emulate_dvs

    sub = 4
    n = int(duration_s * fps)
    ts = (np.arange(n) * 1e6 / fps).astype(np.int64)
    c = (size - 1) / 2
    g = (np.arange(size * sub) + 0.5) / sub - 0.5
    yy, xx = np.meshgrid(g, g, indexing="ij")
    radius = np.hypot(xx - c, yy - c)
    angle = np.arctan2(yy - c, xx - c)
    frames = np.empty((n, size, size), np.float32)
    half_width = np.radians(18.0)
    for i, t in enumerate(ts):
        phase = 2 * np.pi * rev_s * t * 1e-6
        to_blade = np.angle(np.exp(1j * blades * (angle - phase))) / blades
        blade = (np.abs(to_blade) < half_width) & (radius < size / 2 - 1)
        image = np.where(blade, 40.0, 200.0)
        frames[i] = image.reshape(size, sub, size, sub).mean(axis=(1, 3))
    return emulate_dvs(frames, ts, seed=seed)


SPECTRUM_SIDES = (2, 4, 16, 64)
SPECTRUM_RATES = (1e2, 3e2, 1e3, 1e4, 1e5, 1e6)


def pulses(f: float, pixels: int, window_us: int, jitter: float, rng: np.random.Generator):
    """A row of ``pixels`` pixels, each giving one event per cycle at ``f`` Hz (own phase, one
    polarity per pixel, each event jittered uniformly by ±``jitter`` of the period): what a
    pixel under a blade of a small rotor gives."""
    period = 1e6 / f
    ts, xs, ps = [], [], []
    for x in range(pixels):
        t = rng.uniform(0, period) + np.arange(0.0, window_us, period)
        t = t + rng.uniform(-jitter, jitter, t.size) * period
        t = t[(t >= 0) & (t < window_us)]
        ts.append(t)
        xs.append(np.full(t.size, x))
        ps.append(np.full(t.size, x % 2 == 0))
    t = np.concatenate(ts)
    order = np.argsort(t, kind="stable")
    events = np.zeros(t.size, dtype=EVENT_DTYPE)
    events["t"] = t[order].astype(np.uint64)
    events["x"] = np.concatenate(xs)[order]
    events["p"] = np.concatenate(ps)[order]
    return events


def moving(events: np.ndarray, vx: float, vy: float, margin: int = 2) -> np.ndarray:
    """``events`` carried at ``(vx, vy)`` px/s from ``margin`` pixels in: each event moved to
    the pixel nearest its place at its time (time order kept)."""
    out = events.copy()
    t = events["t"].astype(np.float64) * 1e-6
    x0 = margin + max(0.0, -vx * t[-1]) if len(t) else margin
    y0 = margin + max(0.0, -vy * t[-1]) if len(t) else margin
    out["x"] = np.floor(events["x"] + x0 + vx * t + 0.5)
    out["y"] = np.floor(events["y"] + y0 + vy * t + 0.5)
    return out


def moving_propeller(
    rev_s: float,
    speed: float,
    *,
    size: int = 24,
    blades: int = 2,
    fps: float = 20_000.0,
    duration_s: float = 0.05,
    seed: int = 1,
) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    """The propeller of :func:`propeller` (``size`` px) carried across its box at ``speed``
    px/s (rendered at its place in each frame, 4×4 supersampled, so the sensor model sees the
    motion), and the box it crosses."""
    from uavsnn.sim.dvs import emulate_dvs

    sub = 4
    n = int(duration_s * fps)
    ts = (np.arange(n) * 1e6 / fps).astype(np.int64)
    width = int(size + speed * duration_s + 4)
    gx = (np.arange(width * sub) + 0.5) / sub - 0.5
    gy = (np.arange(size * sub) + 0.5) / sub - 0.5
    yy, xx = np.meshgrid(gy, gx, indexing="ij")
    c = (size - 1) / 2
    frames = np.empty((n, size, width), np.float32)
    half_width = np.radians(18.0)
    for i, t in enumerate(ts):
        cx = 2 + c + speed * t * 1e-6
        radius = np.hypot(xx - cx, yy - c)
        angle = np.arctan2(yy - c, xx - cx)
        phase = 2 * np.pi * rev_s * t * 1e-6
        to_blade = np.angle(np.exp(1j * blades * (angle - phase))) / blades
        blade = (np.abs(to_blade) < half_width) & (radius < size / 2 - 1)
        image = np.where(blade, 40.0, 200.0)
        frames[i] = image.reshape(size, sub, width, sub).mean(axis=(1, 3))
    return emulate_dvs(frames, ts, seed=seed), (0, 0, width, size)


def compensated_main(args: argparse.Namespace) -> None:
    """The motion-compensated rotor: noise, a moving flickering patch, a moving propeller."""
    window_us = int(args.window_ms * 1000)
    print(f"noise: {args.seeds} seeds from {args.first_seed}, {args.window_ms:g} ms windows")
    print(
        "| box | rate (ev/s) | max speed found (px/s) | max edge strength | max prominence "
        "| detected | detected, not a motion line |"
    )
    print("|---|---|---|---|---|---|---|")
    for side in SIDES:
        for rate in RATES:
            speed, strength, prom, det, kept = [], [], [], 0, 0
            for seed in range(args.first_seed, args.first_seed + args.seeds):
                rng = np.random.default_rng(seed)
                est = compensated_rotor(noise(rate, side, window_us, rng), (0, 0, side, side))
                speed.append(est.motion.speed)
                strength.append(est.edges.strength)
                prom.append(est.spectrum.prominence if est.spectrum.pixels >= 2 else 0.0)
                det += est.detected
                kept += any(
                    e.detected and not motion_line(e.frequency_hz, est.motion)
                    for e in (est.edges, est.spectrum)
                )
            print(
                f"| {side}×{side} | {rate:.0e} | {max(speed):.0f} | {max(strength):.3f} "
                f"| {max(prom):.2f} | {det}/{args.seeds} | {kept}/{args.seeds} |"
            )

    def cell(e: object, f: float) -> str:
        if not e.detected:  # type: ignore[attr-defined]
            return "–"
        return f"{e.frequency_hz:.1f} ({(e.frequency_hz - f) / f:+.2%})"  # type: ignore[attr-defined]

    print(
        "\n12×12 patch flickering at f (runs of 2, ±2 % jitter), carried at v px/s, 50 ms; "
        "each pixel in its own phase, then all in one phase"
    )
    print(
        "| phases | f (Hz) | v (px/s) | found v | edges | spectrum | edges, compensated "
        "| spectrum, compensated |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for coherent in (False, True):
        for i, f in enumerate((80.0, 240.0, 520.0)):
            for v in ((0.0, 0.0), (100.0, 0.0), (300.0, 100.0), (1000.0, -300.0)):
                rng = np.random.default_rng(20_000 + i)
                flick = flicker(f, 12, 50_000, 2, 0.02, rng, coherent=coherent)
                ev = moving(flick, *v)
                box = (0, 0, int(ev["x"].max()) + 3, int(ev["y"].max()) + 3)
                c = compensated_rotor(ev, box)
                print(
                    f"| {'one' if coherent else 'own'} | {f:g} | {v[0]:g}, {v[1]:g} "
                    f"| {c.motion.vx:.0f}, {c.motion.vy:.0f} "
                    f"| {cell(rotor_signature(ev, box), f)} "
                    f"| {cell(rotor_spectrum(ev, box), f)} "
                    f"| {cell(c.edges, f)} | {cell(c.spectrum, f)} |"
                )

    print("\nemulated two-blade propeller at 120 rev/s (240 Hz), dvs sensor model, 50 ms")
    print(
        "| size (px) | v (px/s) | events | found v | edges | spectrum | edges, compensated "
        "| spectrum, compensated |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for size in (24, 8):
        for v in (0.0, 100.0, 300.0, 1000.0):
            ev, box = moving_propeller(120.0, v, size=size)
            c = compensated_rotor(ev, box)
            print(
                f"| {size} | {v:g} | {len(ev)} | {c.motion.vx:.0f} "
                f"| {cell(rotor_signature(ev, box), 240.0)} "
                f"| {cell(rotor_spectrum(ev, box), 240.0)} "
                f"| {cell(c.edges, 240.0)} | {cell(c.spectrum, 240.0)} |"
            )


def spectrum_main(args: argparse.Namespace) -> None:
    """The event-rate spectrum: noise, periodic pulses, the emulated propeller."""
    window_us = int(args.window_ms * 1000)
    thresholds = [float(SPECTRUM_DEFAULTS["threshold"]), *args.threshold]
    min_pixels = int(SPECTRUM_DEFAULTS["min_pixels"])
    print(f"noise: {args.seeds} seeds from {args.first_seed}, {args.window_ms:g} ms windows")
    head = " | ".join(f"passes at {t:g}" for t in thresholds)
    print(
        "| box | rate (ev/s) | max prominence | max with >= min_pixels | p99 | max pixels "
        f"| {head} |"
    )
    print("|---|---|---|---|---|---|" + "---|" * len(thresholds))
    overall = 0.0
    for side in SPECTRUM_SIDES:
        for rate in SPECTRUM_RATES:
            ests = noise_estimates(rotor_spectrum, rate, side, window_us, args)
            s, px = np.array([e.prominence for e in ests]), np.array([e.pixels for e in ests])
            ruled = s[px >= min_pixels]
            top = float(ruled.max()) if ruled.size else 0.0
            overall = max(overall, top)
            passes = pass_counts(s, px, thresholds, min_pixels)
            print(
                f"| {side}×{side} | {rate:.0e} | {s.max():.2f} | {top:.2f} "
                f"| {np.percentile(s, 99):.2f} | {px.max()} | {passes} |"
            )
    print(f"\nlargest noise prominence with >= {min_pixels} agreeing pixels: {overall:.2f}")

    for jitter in (0.02, 0.05):
        print(f"\npulses: 8 pixels, one event per cycle, jitter ±{jitter:g} of the period")
        print("| f (Hz) | found (Hz) | error | prominence | pixels | detected |")
        print("|---|---|---|---|---|---|")
        for i, f in enumerate(FREQUENCIES):
            rng = np.random.default_rng(10_000 + i)
            est = rotor_spectrum(pulses(f, 8, window_us, jitter, rng), (0, 0, 8, 1))
            err = (est.frequency_hz - f) / f
            print(
                f"| {f:g} | {est.frequency_hz:.1f} | {err:+.2%} | {est.prominence:.1f} "
                f"| {est.pixels} | {est.detected} |"
            )

    print(
        "\nemulated two-blade propeller, 24×24 box, dvs sensor model (seed 1), "
        f"{args.propeller_ms:g} ms"
    )
    print(
        "| rev/s | blade pass (Hz) | events | found (Hz) | error | prominence | pixels | detected |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for rev in PROPELLER_REV_S:
        events = propeller(rev, duration_s=args.propeller_ms * 1e-3)
        est = rotor_spectrum(events, (0, 0, 24, 24))
        err = f"{(est.frequency_hz - 2 * rev) / (2 * rev):+.2%}" if est.frequency_hz else "–"
        print(
            f"| {rev:g} | {2 * rev:g} | {events.size} | {est.frequency_hz:.1f} | {err} "
            f"| {est.prominence:.1f} | {est.pixels} | {est.detected} |"
        )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=200)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--window-ms", type=float, default=100.0)
    parser.add_argument("--threshold", type=float, action="append", default=[])
    parser.add_argument("--run", type=int, default=3)
    parser.add_argument("--jitter", type=float, default=0.02)
    parser.add_argument("--propeller-ms", type=float, default=100.0)
    parser.add_argument("--figure", default=None, help="write the figure to this PNG")
    parser.add_argument("--estimator", choices=("edge", "spectrum", "compensated"), default="edge")
    args = parser.parse_args(argv)
    if args.estimator == "compensated":
        compensated_main(args)
        return
    if args.estimator == "spectrum":
        spectrum_main(args)
        return
    window_us = int(args.window_ms * 1000)
    thresholds = [float(DEFAULTS["threshold"]), *args.threshold]
    min_pixels = int(DEFAULTS["min_pixels"])

    print(f"noise: {args.seeds} seeds from {args.first_seed}, {args.window_ms:g} ms windows")
    head = " | ".join(f"passes at {t:g}" for t in thresholds)
    print(f"| box | rate (ev/s) | max strength | p99 strength | max pixels | {head} |")
    print("|---|---|---|---|---|" + "---|" * len(thresholds))
    worst: dict[str, list[float]] = {}
    for side in SIDES:
        for rate in RATES:
            ests = noise_estimates(rotor_signature, rate, side, window_us, args)
            s, px = np.array([e.strength for e in ests]), np.array([e.pixels for e in ests])
            worst.setdefault(f"noise, {side}x{side} box", []).append(float(s.max()))
            passes = pass_counts(s, px, thresholds, min_pixels)
            print(
                f"| {side}×{side} | {rate:.0e} | {s.max():.3f} | {np.percentile(s, 99):.3f} "
                f"| {px.max()} | {passes} |"
            )

    curves: dict[str, list[float]] = {}
    for jitter in (args.jitter, 0.05):
        print(f"\nflicker: 16×16 box, run {args.run}, jitter ±{jitter:g} of the period")
        print("| f (Hz) | found (Hz) | error | strength | pixels | detected |")
        print("|---|---|---|---|---|---|")
        for i, f in enumerate(FREQUENCIES):
            rng = np.random.default_rng(10_000 + i)
            events = flicker(f, 16, window_us, args.run, jitter, rng)
            est = rotor_signature(events, (0, 0, 16, 16))
            err = (est.frequency_hz - f) / f
            curves.setdefault(f"flicker, jitter {jitter:g}", []).append(est.strength)
            print(
                f"| {f:g} | {est.frequency_hz:.1f} | {err:+.2%} | {est.strength:.3f} "
                f"| {est.pixels} | {est.detected} |"
            )

    print(
        "\nemulated two-blade propeller, 24×24 box, dvs sensor model (seed 1), "
        f"{args.propeller_ms:g} ms"
    )
    print(
        "| rev/s | blade pass (Hz) | events | found (Hz) | error | strength | pixels "
        + "| detected |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for rev in PROPELLER_REV_S:
        events = propeller(rev, duration_s=args.propeller_ms * 1e-3)
        est = rotor_signature(events, (0, 0, 24, 24))
        err = f"{(est.frequency_hz - 2 * rev) / (2 * rev):+.2%}" if est.frequency_hz else "–"
        print(
            f"| {rev:g} | {2 * rev:g} | {events.size} | {est.frequency_hz:.1f} | {err} "
            f"| {est.strength:.3f} | {est.pixels} | {est.detected} |"
        )

    if args.figure:
        import cv2

        from uavsnn.pictures import hstack, line_chart

        line = [thresholds[0]] * len(RATES)
        left = line_chart(
            [float(np.log10(r)) for r in RATES],
            {**worst, "threshold": line},
            title=f"uniform noise: largest strength over {args.seeds} seeds",
            xlabel="log10 rate (events/s in the box)",
            ylabel="strength",
            y_range=(0.0, 1.0),
        )
        right = line_chart(
            list(FREQUENCIES),
            {**curves, "threshold": [thresholds[0]] * len(FREQUENCIES)},
            title="flicker in every pixel of a 16x16 box",
            xlabel="frequency (Hz)",
            ylabel="strength",
            y_range=(0.0, 1.0),
        )
        cv2.imwrite(args.figure, hstack([left, right]))
        print(f"\nfigure: {args.figure}")


if __name__ == "__main__":
    main()
