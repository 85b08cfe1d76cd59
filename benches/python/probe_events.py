"""Probe whether a richer input than first spikes would tell a drone from another object: the
same supervised classifier, told the labelled box, fitted once on each window's first spikes
(what the network sees, SPEC §2) and once on all of its events (counts per cell and polarity,
how often each pixel fired, when), on the same windows of freshly rendered dvs recordings.

Like ``probe_input.py`` this is a reference, not a detector: it is told where the object is and
fitted with labels. It answers one question: how much of the gap between the network and the
targets a change of input (all events instead of first spikes) could close at best::

    pip install -e ".[probe]"          # scikit-learn, for the gradient-boosted trees
    python benches/python/probe_events.py --train-recordings 300 --test-recordings 120

Recordings are rendered as ``uavsnn dataset build --domain dvs`` renders them (1 s at 500 fps,
the DVS emulator with its defaults, 50 ms windows at 50 % overlap, a window labelled when its
object is visible for half of it), alternately a ``"uav"`` and an ``"object"`` scene. Training
recordings are seeds ``0 ..``, test recordings seeds ``10**6 ..``: no recording is in both.
Only the usable windows with a labelled object take part. Features (on a 12 × 12 grid over the
square around the box's centre, 1.2 times its longer side, at least 4.8 px):

- first spikes: the share of each cell's pixels that spiked, their mean time, a histogram of
  the spike times, the box's size and the number of spikes (as ``probe_input.py``, plus the
  histogram);
- all events: ON and OFF events per cell (log1p, per pixel of the cell), a histogram of how
  many events each pixel that fired sent, ON and OFF time histograms, the size and the count.

Gradient-boosted trees (scikit-learn's histogram ones), the learning rate chosen on a quarter of
the training recordings held out, refitted on all training windows, scored once on the test
windows, also by the object's size (the bins of ``uavsnn.evaluation.SIZE_BINS_PX``).
"""

from __future__ import annotations

import argparse
import itertools
import json
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from probe_input import LEARNING_RATES, boosted, crop_cells, crop_features, held_out

from uavsnn.dataset.splits import SENSOR, WindowCut
from uavsnn.dataset.synthetic import SceneSource, synthetic_recording
from uavsnn.evaluation import SIZE_BINS_PX

GRID = 12
TIME_BINS = 8
SOURCE = SceneSource("dvs", SENSOR, 500.0, 1.0)
CUT = WindowCut(50_000, 0.5, 0.5)
#: Events per firing pixel, binned: 1, 2, 3-4, 5-8, 9-16, 17-32, more.
PER_PIXEL_BINS = (1, 2, 3, 5, 9, 17, 33, 2**31)


def event_features(
    events: np.ndarray, t0: float, box: tuple[float, float, float, float]
) -> np.ndarray:
    """All of a window's ``events`` (starting at ``t0``) in the crop of ``box``."""
    x, y = events["x"].astype(float), events["y"].astype(float)
    t = (events["t"].astype(float) - t0) / CUT.length_us
    on = events["p"].astype(bool)
    inside, cell, side = crop_cells(x, y, box, GRID)
    n = int(inside.sum())
    t_in, on_in = t[inside], on[inside]
    per_cell = max(1.0, (side / GRID) ** 2)
    n_on = np.bincount(cell[on_in], minlength=GRID * GRID) / per_cell
    n_off = np.bincount(cell[~on_in], minlength=GRID * GRID) / per_cell
    pixel = y[inside].astype(np.int64) * SENSOR[0] + x[inside].astype(np.int64)
    per_pixel = np.unique(pixel, return_counts=True)[1]
    pixels = np.histogram(per_pixel, bins=PER_PIXEL_BINS)[0] / max(1, len(per_pixel))
    hist_on = np.histogram(t_in[on_in], bins=TIME_BINS, range=(0.0, 1.0))[0] / max(1, n)
    hist_off = np.histogram(t_in[~on_in], bins=TIME_BINS, range=(0.0, 1.0))[0] / max(1, n)
    return np.r_[
        np.log1p(n_on), np.log1p(n_off), pixels, hist_on, hist_off, np.log(side), np.log1p(n)
    ]


def recording_rows(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Render recording ``seed`` and return, per usable window with an object: first-spike
    features, all-event features, the label and the object's size (longer side, px)."""
    rec = synthetic_recording(SOURCE, "uav" if seed % 2 == 0 else "object", seed)
    w = CUT.cut(rec.recording, rec.end_us)
    labels = CUT.label(w.t0, rec.timestamps_us, rec.labels, rec.labelled)
    events = rec.recording.events
    offsets, starts = np.asarray(w.offsets), np.asarray(w.t0)
    keep = np.flatnonzero(labels.usable & ~np.isnan(labels.box).any(axis=1))
    first, every = [], []
    for i in keep:
        x0, y0, x1, y1 = (float(v) for v in labels.box[i])
        box = (x0, y0, x1, y1)
        a, b = offsets[i], offsets[i + 1]
        t = (np.asarray(w.t[a:b], dtype=float) - float(starts[i])) / CUT.length_us
        x, y = np.asarray(w.x[a:b], float), np.asarray(w.y[a:b], float)
        first.append(crop_features(x, y, t, box, GRID, time_bins=TIME_BINS))
        lo, hi = np.searchsorted(events["t"], [starts[i], starts[i] + CUT.length_us])
        every.append(event_features(events[lo:hi], float(starts[i]), box))
    box = labels.box[keep]
    size = np.maximum(box[:, 2] - box[:, 0], box[:, 3] - box[:, 1])
    return np.asarray(first), np.asarray(every), labels.label[keep].astype(bool), size


def gather(seeds: range, pool: ProcessPoolExecutor) -> dict[str, np.ndarray]:
    """The rows of the recordings ``seeds``, with each row's recording (recordings without a
    usable window with an object add none)."""
    parts = [
        (seed, part)
        for seed, part in zip(seeds, pool.map(recording_rows, seeds), strict=True)
        if len(part[2])
    ]
    return {
        "first": np.concatenate([p[0] for _, p in parts]),
        "all": np.concatenate([p[1] for _, p in parts]),
        "label": np.concatenate([p[2] for _, p in parts]),
        "size": np.concatenate([p[3] for _, p in parts]),
        "recording": np.concatenate([np.full(len(p[2]), seed) for seed, p in parts]),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--train-recordings", type=int, default=300)
    parser.add_argument("--test-recordings", type=int, default=120)
    parser.add_argument("--workers", type=int, default=2, help="processes that render")
    parser.add_argument("--json", action="store_true", help="one JSON line")
    args = parser.parse_args()
    with ProcessPoolExecutor(args.workers) as pool:
        train = gather(range(args.train_recordings), pool)
        test = gather(range(10**6, 10**6 + args.test_recordings), pool)
    val = held_out(train["recording"], 0)
    y, y_test = train["label"], test["label"]
    size = test["size"]
    bins = {
        (f">= {lo:g}" if np.isinf(hi) else f"{lo:g}-{hi:g}"): (size >= lo) & (size < hi)
        for lo, hi in itertools.pairwise(SIZE_BINS_PX)
    }
    bins = {key: mask for key, mask in bins.items() if mask.any()}
    row: dict[str, object] = {
        "train_windows": len(y),
        "test_windows": len(y_test),
        "test_drone_share": float(np.mean(y_test)),
        "sizes": {
            key: {"windows": int(mask.sum()), "drones": float(np.mean(y_test[mask]))}
            for key, mask in bins.items()
        },
    }
    for name, x, x_test in (
        ("first spikes", train["first"], test["first"]),
        ("all events", train["all"], test["all"]),
        ("both", np.c_[train["first"], train["all"]], np.c_[test["first"], test["all"]]),
    ):
        scores = [
            float(np.mean(boosted(x[~val], y[~val], x[val], r) == y[val])) for r in LEARNING_RATES
        ]
        rate = LEARNING_RATES[int(np.argmax(scores))]
        right = boosted(x, y, x_test, rate) == y_test
        row[name] = {
            "learning rate": rate,
            "test": float(np.mean(right)),
            "by size": {key: float(np.mean(right[mask])) for key, mask in bins.items()},
        }
    if args.json:
        print(json.dumps(row))
        return
    print(
        f"{len(y)} training and {len(y_test)} test windows with an object "
        f"({100 * row['test_drone_share']:.1f} % of the test ones drones)"
    )
    sizes = row["sizes"]
    assert isinstance(sizes, dict)
    print(
        "  test windows  "
        + ", ".join(
            f"{k} px: {v['windows']} ({100 * v['drones']:.1f} % drones)" for k, v in sizes.items()
        )
    )
    for name in ("first spikes", "all events", "both"):
        r = row[name]
        assert isinstance(r, dict)
        by_size = ", ".join(f"{k} px {100 * acc:.1f} %" for k, acc in r["by size"].items())
        print(f"  {name:13s} {100 * r['test']:5.1f} %   ({by_size})")


if __name__ == "__main__":
    main()
