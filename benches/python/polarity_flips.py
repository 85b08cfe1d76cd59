"""Do an object's polarity flips tell a rotor from a wing, a ball or a body?

The rotor signature (``uavsnn.signature``) votes only where a pixel repeats its period, which
the dataset's moving, dim drones rarely allow (docs/identification.md, "Why the dataset's
drones show no rotor"). A cruder cue needs no period: a pixel under a blade flips between ON
and OFF at the blade-pass rate, a pixel an edge sweeps over flips about once. For each object
of each window (as ``uavsnn.identify.window_features`` finds them) this counts, over the
window's raw events inside its box, taken pixel by pixel in time order:

- ``flip_share``: the events whose polarity differs from their pixel's event before, over all
  the box's events;
- ``fast_flip_share``: those that flip within :data:`FAST_US` of it (``--fast-from flip``: of
  the pixel's flip before);
- ``pixels_3_flips``: the share of the box's active pixels that flip three times or more.

Then it fits the UAV score without and with these columns, each kind (a logistic regression as
``identify.fit_score`` fits it, boosted trees as ``identify.fit_tree_score``), on ``--train``'s
train split, tuned on ``--tune``'s (L2 or trees and the threshold of ``identify.best_threshold``),
and reads both on the test splits of the ``VALIDATION`` sets pooled (datasets of other seeds,
never a reported test set): accuracy at the tuned threshold and detection where 1 % and 5 % of
the UAV-free windows alarm, each difference with its paired 95 % interval over the validation
recordings (``evaluation.recording_interval``, ``evaluation.roc_point_interval``). First the
columns' mean per class on the tuning objects.

    python benches/python/polarity_flips.py runs/reproduce/model-combined.npz \\
        --train runs/reproduce/data/dvs --tune runs/reproduce/data/tune-dvs \\
        runs/val2-dvs runs/val3-dvs
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from track_window_score import window_scores  # per window its best object, -1 where not fired

from uavsnn import Network, identify
from uavsnn.dataset import LabelledWindows, load
from uavsnn.evaluation import (
    FALSE_ALARM_RATES,
    detection_at_false_alarm,
    recording_interval,
    roc_point_interval,
)
from uavsnn.linear import predict_logistic

#: The flip columns, in order.
FLIP_COLUMNS = ("flip_share", "fast_flip_share", "pixels_3_flips")

#: A flip within this long of its pixel's event before counts as fast (µs): half a cycle of
#: 125 Hz. A blade pass (200–520 Hz) flips faster, a bird's wing beat (2–15 Hz) far slower.
FAST_US = 4_000

#: What a fast flip is timed from: the pixel's event before, or its flip before (the time the
#: rotor estimator keeps per pixel, so the cue would cost it no state).
FAST_FROM = ("event", "flip")


def flip_columns(
    events: np.ndarray, box: tuple[int, int, int, int], width: int, fast_from: str = "event"
) -> np.ndarray:
    """The :data:`FLIP_COLUMNS` of the ``events`` (time order) inside ``box`` ``(x0, y0, x1,
    y1)``, ``x1`` and ``y1`` excluded, on a sensor ``width`` pixels wide, a fast flip timed
    from the pixel's event or flip before (``fast_from``, one of :data:`FAST_FROM`); zeros for
    fewer than two events."""
    x0, y0, x1, y1 = box
    inside = (events["x"] >= x0) & (events["x"] < x1) & (events["y"] >= y0) & (events["y"] < y1)
    ev = events[inside]
    if len(ev) < 2:
        return np.zeros(len(FLIP_COLUMNS))
    pixel = ev["y"].astype(np.int64) * width + ev["x"]
    order = np.lexsort((ev["t"], pixel))
    pixel, t, on = pixel[order], ev["t"][order].astype(np.int64), ev["p"][order].astype(bool)
    flip = (pixel[1:] == pixel[:-1]) & (on[1:] != on[:-1])
    if fast_from == "flip":
        ft, fp = t[1:][flip], pixel[1:][flip]
        fast_n = int(((fp[1:] == fp[:-1]) & (np.diff(ft) < FAST_US)).sum())
    else:
        fast_n = int((flip & (np.diff(t) < FAST_US)).sum())
    active = np.unique(pixel)
    per_pixel = np.bincount(np.searchsorted(active, pixel[1:][flip]), minlength=len(active))
    return np.array([flip.sum() / len(ev), fast_n / len(ev), (per_pixel >= 3).mean()])


@dataclass(frozen=True)
class Split:
    """One split's objects (their features and flip columns) and its windows' calls, truth and
    recordings."""

    feats: identify.WindowFeatures
    flips: np.ndarray
    detected: np.ndarray
    label: np.ndarray
    recording: np.ndarray


def split(net: Network, data: LabelledWindows, tag: str = "", fast_from: str = "event") -> Split:
    """``data`` through ``net``: its objects with their flip columns (``fast_from`` as
    :func:`flip_columns`'); ``tag`` prefixes the recording ids (to pool sets)."""
    inference = net.infer(data.windows)
    feats = identify.window_features(net, data, inference)
    width = int(net.config["width"])
    flips = np.array(
        [
            flip_columns(data.raw.window(int(i)), tuple(int(v) for v in box), width, fast_from)
            for i, box in zip(feats.window, feats.boxes, strict=True)
        ]
    ).reshape(-1, len(FLIP_COLUMNS))
    return Split(
        feats,
        flips,
        np.asarray(inference.detected, dtype=bool),
        np.asarray(data.label, dtype=bool),
        np.char.add(tag, np.asarray(data.recording).astype(str)),
    )


def _columns(s: Split, with_flips: bool) -> np.ndarray:
    return np.hstack([s.feats.x, s.flips]) if with_flips else s.feats.x


def fit_scorers(
    train: Split, tune: Split, with_flips: bool
) -> dict[str, Callable[[Split], np.ndarray]]:
    """The window scores of each kind of UAV score (``"logistic"``, ``"trees"``) fitted on
    ``train``'s usable objects, tuned on ``tune``'s, with or without the flip columns: the
    logistic fit standardises the columns, and the trees are fitted on the same standardised
    columns."""
    x, u = _columns(train, with_flips), train.feats.usable
    xt, ut = _columns(tune, with_flips), tune.feats.usable
    mean, scale, coef, _ = identify.fit_score(
        x[u], train.feats.label[u], xt[ut], tune.feats.label[ut]
    )
    trees, _ = identify.fit_tree_score(
        (x[u] - mean) / scale,
        train.feats.label[u],
        (xt[ut] - mean) / scale,
        tune.feats.label[ut],
    )

    def z(s: Split) -> np.ndarray:
        return (_columns(s, with_flips) - mean) / scale

    return {
        "logistic": lambda s: window_scores(s.feats, predict_logistic(coef, z(s)), s.detected),
        "trees": lambda s: window_scores(s.feats, trees.predict(z(s)), s.detected),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("validation", nargs="+", metavar="VALIDATION")
    parser.add_argument("--train", required=True, metavar="DIR")
    parser.add_argument("--tune", required=True, metavar="DIR")
    parser.add_argument(
        "--fast-from",
        choices=FAST_FROM,
        default="event",
        help="time a fast flip from the pixel's event before (default) or its flip before",
    )
    args = parser.parse_args()
    net = Network.load(args.model)
    fast = args.fast_from
    train = split(net, load(args.train, "train"), fast_from=fast)
    tune = split(net, load(args.tune, "train"), fast_from=fast)
    parts = [split(net, load(p, "test"), f"{k}:", fast) for k, p in enumerate(args.validation)]
    print(f"{args.model}: {len(train.flips)} training objects, {len(tune.flips)} tuning objects")
    print("  the columns' mean per class of the tuning objects (usable ones):")
    u = tune.feats.usable
    for c in np.unique(tune.feats.cls[u]):
        rows = u & (tune.feats.cls == c)
        means = ", ".join(
            f"{n} {m:.3f}" for n, m in zip(FLIP_COLUMNS, tune.flips[rows].mean(0), strict=True)
        )
        print(f"    {c or 'unnamed (off the labelled box)'} ({int(rows.sum())}): {means}")
    label = np.concatenate([p.label for p in parts])
    recording = np.concatenate([p.recording for p in parts])
    fitted = {with_flips: fit_scorers(train, tune, with_flips) for with_flips in (False, True)}
    for kind in ("logistic", "trees"):
        calls, scores = {}, {}
        for with_flips in (False, True):
            scorer = fitted[with_flips][kind]
            threshold = identify.best_threshold(scorer(tune), tune.label)
            scores[with_flips] = np.concatenate([scorer(p) for p in parts])
            calls[with_flips] = scores[with_flips] >= threshold
            name = "+ flips" if with_flips else "features alone"
            det = ", ".join(
                f"{100 * detection_at_false_alarm(scores[with_flips], label, r):.1f} % at "
                f"{100 * r:g} %"
                for r in FALSE_ALARM_RATES
            )
            print(
                f"  {kind}, {name}: threshold {threshold:.3f}, accuracy "
                f"{100 * (calls[with_flips] == label).mean():.1f} %, detection {det}"
            )
        right, base = calls[True] == label, calls[False] == label
        lo, hi = recording_interval(right, recording, against=base, strata=label)
        leads = [f"accuracy {_points(right.mean() - base.mean(), lo, hi)}"]
        for r in FALSE_ALARM_RATES:
            lead = detection_at_false_alarm(scores[True], label, r) - detection_at_false_alarm(
                scores[False], label, r
            )
            lo, hi = roc_point_interval(scores[True], label, recording, r, against=scores[False])
            leads.append(f"detection at {100 * r:g} % {_points(lead, lo, hi)}")
        print("    the flips' lead: " + "; ".join(leads))


def _points(lead: float, lo: float, hi: float) -> str:
    return f"{100 * lead:+.2f} ({100 * lo:+.2f} to {100 * hi:+.2f})"


if __name__ == "__main__":
    main()
