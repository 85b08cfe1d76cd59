"""Is a wing beat (or a main rotor) in the event rate of an object over its track? A probe told
the labelled box.

A bird's wings beat at 2.5–14 Hz in the dvs domain (a helicopter's main rotor passes a blade
at tens of Hz); each stroke changes how many edges move, so the object's event rate should rise
and fall at once or twice the beat. A drone's rotors pass at hundreds of Hz, far above that
band, and its body moves smoothly. The window-level features cannot see this (a 50 ms window
holds under one beat); a track holds up to a second.

For every recording of a split with a labelled object, this script follows the labelled box
from window to window (each time bin takes the box of the kept window whose middle is nearest,
padded by ``--pad`` px), counts the recording's raw events inside it in bins of ``--bin-ms``,
and keeps the longest run of bins the dataset's raw events cover (each window keeps its own
events and those of the window length before it). On that run, over ``--span-ms`` at most,
it measures:

- ``swing``: the rate's swing in ``--band`` Hz — the square root of its variance in the
  band (after dividing by its running mean over ``--trend-ms``) less what the shot noise of a
  Poisson count of that mean puts there;
- ``prominence``: the periodogram's highest bin in the band over the band's median bin (a
  line, not broad noise);
- ``peak_hz``: that bin's frequency.

It prints, per class, the recordings measured and the medians, and each quantity's area under
the ROC of drones against every other class and against each class alone (0.5: no
separation; below 0.5: drones swing *more*). The box is the label, not a detection: this
describes the classes' events, it is not a detector's figure (``rate_swing.py`` gives those).

    python benches/python/wingbeat_probe.py runs/reproduce/data/dvs --split train
    python benches/python/wingbeat_probe.py runs/reproduce/data/dvs --split test
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass

import numpy as np

from uavsnn.dataset import load
from uavsnn.evaluation import roc_area


@dataclass
class Measure:
    recording: int
    cls: str
    size_px: float
    seconds: float
    events_per_bin: float
    swing: float
    prominence: float
    peak_hz: float


def _cover(t0: np.ndarray, before_us: int, length_us: int, bin_us: int) -> tuple[int, int]:
    """The longest run of time (µs, aligned to bins from the first window's start minus
    ``before_us``) covered by the windows' ``[t0 - before, t0 + length)`` spans."""
    starts = np.sort(t0.astype(np.int64)) - before_us
    stops = starts + before_us + length_us
    best, run_start, run_stop = (0, 0), int(starts[0]), int(stops[0])
    for s, e in zip(starts[1:], stops[1:], strict=True):
        if s > run_stop:
            if run_stop - run_start > best[1] - best[0]:
                best = (run_start, run_stop)
            run_start = int(s)
        run_stop = max(run_stop, int(e))
    if run_stop - run_start > best[1] - best[0]:
        best = (run_start, run_stop)
    return best


def spectrum(
    counts: np.ndarray, bin_ms: float, band: tuple[float, float], trend_ms: float | None
) -> tuple[float, float, float]:
    """The swing of a rate ``counts`` (events per bin of ``bin_ms``) in ``band`` Hz, its
    periodogram's prominence there and the peak's frequency.

    The rate is divided by its running mean over ``trend_ms`` (``None``: by a straight line
    fitted to it), so what is left is the relative swing around it. The swing is the square
    root of that swing's variance in the band less what the shot noise of a Poisson count puts
    there (about ``1 / mean`` spread evenly over the frequencies), zero when noise explains it.
    """
    n = len(counts)
    if n < 4 or counts.mean() <= 0:
        return 0.0, 0.0, 0.0
    if trend_ms is None:
        u = np.arange(n)
        trend = np.polyval(np.polyfit(u, counts, 1), u)
    else:
        k = max(1, round(trend_ms / bin_ms))
        padded = np.pad(counts, (k // 2, k - 1 - k // 2), mode="edge")
        trend = np.convolve(padded, np.ones(k) / k, "valid")
    trend = np.maximum(trend, counts.mean() * 0.05)
    rel = counts / trend - 1.0
    rel -= rel.mean()
    power = np.abs(np.fft.rfft(rel * np.hanning(n))) ** 2
    freqs = np.fft.rfftfreq(n, d=bin_ms / 1000)
    inband = (freqs >= band[0]) & (freqs <= band[1])
    total = power[1:].sum()
    if not inband.any() or total <= 0:
        return 0.0, 0.0, 0.0
    share = power[inband].sum() / total
    floor = inband.sum() / max(len(freqs) - 1, 1) / trend.mean()
    j = int(np.flatnonzero(inband)[power[inband].argmax()])
    median = float(np.median(power[inband]))
    prominence = float(power[j] / median) if median > 0 else 0.0
    return math.sqrt(max(share * rel.var() - floor, 0.0)), prominence, float(freqs[j])


def swing(
    counts: np.ndarray, bin_ms: float, band: tuple[float, float], trend_ms: float | None
) -> float:
    """:func:`spectrum`'s swing alone."""
    return spectrum(counts, bin_ms, band, trend_ms)[0]


def measure_recording(data, idx: np.ndarray, args: argparse.Namespace) -> Measure | None:
    """The measures of one recording's windows ``idx`` (all with a box), or ``None`` when its
    covered run is shorter than ``--min-ms``."""
    raw = data.raw
    length = int(data.windows.length_us)
    t0 = np.asarray(data.windows.t0, dtype=np.int64)[idx]
    order = np.argsort(t0)
    idx, t0 = idx[order], t0[order]
    bin_us = round(args.bin_ms * 1000)
    lo, hi = _cover(t0, raw.before_us, length, bin_us)
    hi = min(hi, lo + int(args.span_ms * 1000))
    n_bins = (hi - lo) // bin_us
    if n_bins * bin_us < args.min_ms * 1000:
        return None
    hi = lo + n_bins * bin_us
    start = int(raw.start[idx].min())
    stop = int(raw.stop[idx].max())
    ev = raw.events[start:stop]
    ev = ev[(ev["t"] >= lo) & (ev["t"] < hi)]
    # Each bin's box: the box of the window whose middle is nearest the bin's middle.
    mids = t0 + length // 2
    bin_mid = lo + bin_us * np.arange(n_bins) + bin_us // 2
    nearest = np.abs(bin_mid[:, None] - mids[None, :]).argmin(axis=1)
    boxes = data.box[idx][nearest]
    b = ((ev["t"].astype(np.int64) - lo) // bin_us).astype(np.int64)
    x0, y0, x1, y1 = (boxes[b, k] for k in range(4))
    pad = args.pad
    inside = (
        (ev["x"] >= x0 - pad) & (ev["x"] < x1 + pad) & (ev["y"] >= y0 - pad) & (ev["y"] < y1 + pad)
    )
    counts = np.bincount(b[inside], minlength=n_bins).astype(np.float64)
    if counts.mean() <= 0:
        return None
    amount, prominence, peak_hz = spectrum(counts, args.bin_ms, args.band, args.trend_ms)
    return Measure(
        recording=int(data.recording[idx[0]]),
        cls=str(data.cls[idx[0]]),
        size_px=float(np.nanmedian(data.size_px[idx])),
        seconds=n_bins * bin_us / 1e6,
        events_per_bin=float(counts.mean()),
        swing=amount,
        prominence=prominence,
        peak_hz=peak_hz,
    )


def measure(root: str, split: str, args: argparse.Namespace) -> list[Measure]:
    data = load(root, split)
    if data.raw is None:
        raise SystemExit(f"{root} {split}: no raw events (format 2 needed)")
    has_box = np.isfinite(data.box).all(axis=1) & (data.cls != "none")
    out = []
    for rec in np.unique(data.recording[has_box]):
        idx = np.flatnonzero(has_box & (data.recording == rec))
        m = measure_recording(data, idx, args)
        if m is not None:
            out.append(m)
    return out


def table(rows: list[Measure], drone: str) -> dict:
    classes = sorted({r.cls for r in rows})
    result: dict = {"classes": {}, "auc": {}}
    for c in classes:
        sel = [r for r in rows if r.cls == c]
        result["classes"][c] = {
            "recordings": len(sel),
            "size_px": float(np.median([r.size_px for r in sel])),
            "events_per_bin": float(np.median([r.events_per_bin for r in sel])),
            "swing": float(np.median([r.swing for r in sel])),
            "prominence": float(np.median([r.prominence for r in sel])),
            "peak_hz": float(np.median([r.peak_hz for r in sel])),
        }
    for q in ("swing", "prominence"):
        pos = [getattr(r, q) for r in rows if r.cls == drone]
        aucs = {}
        for c in ["all others", *[c for c in classes if c != drone]]:
            neg = [getattr(r, q) for r in rows if r.cls != drone and c in (r.cls, "all others")]
            # A drone should swing *less*: the chance that another object swings more.
            actual = np.r_[np.ones(len(neg)), np.zeros(len(pos))].astype(bool)
            aucs[c] = roc_area(np.r_[neg, pos], actual) if neg and pos else None
        result["auc"][q] = aucs
    return result


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("dataset")
    p.add_argument("--split", default="test")
    p.add_argument("--bin-ms", type=float, default=5.0)
    p.add_argument("--trend-ms", type=float, default=250.0)
    p.add_argument("--span-ms", type=float, default=1000.0)
    p.add_argument("--min-ms", type=float, default=300.0)
    p.add_argument("--band", type=float, nargs=2, default=(3.0, 40.0))
    p.add_argument("--pad", type=int, default=2)
    p.add_argument("--drone", default="drone")
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    rows = measure(args.dataset, args.split, args)
    result = table(rows, args.drone)
    if args.json:
        json.dump(result, sys.stdout, indent=1)
        print()
        return 0
    print("| class | recordings | size (px) | events per bin | swing | prominence | peak (Hz) |")
    print("|---|---|---|---|---|---|---|")
    for c, v in result["classes"].items():
        print(
            f"| {c} | {v['recordings']} | {v['size_px']:.1f} | {v['events_per_bin']:.1f} | "
            f"{v['swing']:.3f} | {v['prominence']:.1f} | {v['peak_hz']:.1f} |"
        )
    for q, aucs in result["auc"].items():
        print(q, ", ".join(f"{c} {a:.2f}" if a is not None else f"{c} –" for c, a in aucs.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
