"""PIX2NVS's threshold for the real footage, read on the training clips ``uavsnn train`` holds out.

The real set's events come from 30 fps video through PIX2NVS, whose threshold on the change
of log luma (θ, ``--pix2nvs-threshold``, default 0.4) sets which faint drones give events at
all (docs/identification.md, "Real clips streamed whole"). Each θ is a dataset built with it
and a network trained on it with ``reproduce``'s recipe, whose identification ``uavsnn train``
fits on three quarters of the training clips and tunes on the quarter it holds out
(``identify.split_by_recording``). Those held-out clips are the only real footage no fit has
seen that the test clips do not hold, so this reads each θ there and never on the test split:

- the held-out windows: accuracy (balanced) with the any-spike rule and with identification at
  the model's threshold (tuned on these very windows, so optimistic alike for every θ), and
  detection at 1 % and 5 % false alarms read off their ROC;
- the shares of the UAV and the UAV-free windows each rule calls UAV;
- the held-out clips streamed whole (``uavsnn.clips.stream_clip``, as ``uavsnn evaluate
  --clips`` streams the test clips): clips decided right under each rule, and those decided
  otherwise than at the reference with identification;
- against the first ``--at`` (the reference): each lead with its paired 95 % interval, the
  clips drawn again (windows: those both datasets keep, matched by clip and start; clips with
  a UAV and the others apart).

    python benches/python/pix2nvs_choice.py --at 0.4 runs/reproduce/model-real.npz \\
        runs/reproduce/data/real --at 0.2 runs/real-t02/model.npz runs/real-t02
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn import identify
from uavsnn.clips import clip_set, stream_clip
from uavsnn.dataset import load
from uavsnn.evaluation import recording_interval
from uavsnn.false_alarms import alarm_rules
from uavsnn.network import Network
from uavsnn.roc import detection_at_false_alarm
from uavsnn.track_eval import DEFAULT_CONFIRM

sys.path.insert(0, str(Path(__file__).resolve().parent))
from tune_halves import balanced

RATES = (0.01, 0.05)


@dataclass
class Read:
    """One θ read on its held-out clips."""

    name: str
    key: list[tuple[str, int]]  # per held-out window: its clip and start (µs)
    label: np.ndarray
    clip: np.ndarray  # per window: its clip's name
    fired: np.ndarray
    called: np.ndarray  # identification at the model's threshold
    score: np.ndarray  # -1 where the any-spike rule does not fire
    clip_rows: list[dict[str, Any]]


def read(name: str, model: str, dataset: str) -> Read:
    """The held-out windows and clips of ``dataset``'s train split through ``model``."""
    net = Network.load(model)
    ident = net.identification
    if ident is None:
        raise SystemExit(f"{model} has no identification")
    data = identify.split_by_recording(load(dataset, "train"))[1]
    fired = np.asarray(net.infer(data.windows).detected, bool)
    score = np.where(fired, ident.window_scores(identify.window_features(net, data)), -1.0)
    manifest = json.loads((Path(dataset) / "manifest.json").read_text())
    names = {int(r["id"]): str(r["name"]) for r in manifest["recordings"]}
    clip = np.array([names[int(r)] for r in data.recording])
    t0 = np.asarray(data.windows.t0, dtype=np.int64)
    key = list(zip(clip.tolist(), t0.tolist(), strict=True))
    clips = clip_set(dataset, "train")
    held = set(clip.tolist())
    clips = replace(clips, clips=tuple(c for c in clips.clips if c.name in held))
    if {c.name for c in clips.clips} != held:
        raise SystemExit(f"{dataset}: the held-out windows' clips are not all in its train split")
    rows = [stream_clip(net, clips, k, DEFAULT_CONFIRM) for k in range(len(clips.clips))]
    rules = alarm_rules(net, DEFAULT_CONFIRM)
    for row in rows:
        row["rules"] = {r: row["rules"][r] for r in rules}
    label = np.asarray(data.label, bool)
    return Read(name, key, label, clip, fired, score >= ident.threshold, score, rows)


def window_lead(
    mine: Read, ref: Read, flag: str, resamples: int = 2000
) -> tuple[float, tuple[float, float], int]:
    """The lead of ``mine`` over ``ref`` in the balanced accuracy (the mean of the UAV and the
    UAV-free windows' shares decided right) of ``flag`` (``fired`` or ``called``) on the windows
    both keep, and its paired 95 % interval: the clips drawn again with replacement (those with
    a UAV window and the others apart), both leads on the same draws."""
    at = {k: i for i, k in enumerate(ref.key)}
    both = [(i, at[k]) for i, k in enumerate(mine.key) if k in at]
    a = np.array([i for i, _ in both], int)
    b = np.array([j for _, j in both], int)
    label = mine.label[a]
    if not np.array_equal(label, ref.label[b]):
        raise SystemExit(f"{mine.name} and {ref.name} label a shared window differently")
    diff = (getattr(mine, flag)[a] == label).astype(float) - (getattr(ref, flag)[b] == label)
    names, clip = np.unique(mine.clip[a], return_inverse=True)
    # Per clip: its UAV and UAV-free windows, and the sums of their differences.
    n_uav = np.bincount(clip, weights=label, minlength=len(names))
    n_free = np.bincount(clip, weights=~label, minlength=len(names))
    d_uav = np.bincount(clip, weights=diff * label, minlength=len(names))
    d_free = np.bincount(clip, weights=diff * ~label, minlength=len(names))

    def lead(counts: np.ndarray) -> np.ndarray:
        return 0.5 * (counts @ d_uav / (counts @ n_uav) + counts @ d_free / (counts @ n_free))

    rng = np.random.default_rng(0)
    counts = np.zeros((resamples, len(names)))
    for group in (n_uav > 0, n_uav == 0):
        idx = np.flatnonzero(group)
        if len(idx):
            pick = idx[rng.integers(0, len(idx), size=(resamples, len(idx)))]
            rows = np.repeat(np.arange(resamples), len(idx))
            np.add.at(counts, (rows, pick.ravel()), 1)  # how often each draw takes each clip
    draws = lead(counts)
    lo, hi = np.percentile(draws[np.isfinite(draws)], [2.5, 97.5])
    return float(lead(np.ones(len(names)))), (float(lo), float(hi)), len(a)


def clip_right(r: Read, rule: str) -> dict[str, bool]:
    """Per held-out clip: decided right under ``rule``."""
    return {row["clip"]: row["rules"][rule]["alarmed"] == row["uav"] for row in r.clip_rows}


def clip_lead(mine: Read, ref: Read, rule: str) -> tuple[int, tuple[float, float]]:
    """Clips decided right by ``mine`` minus by ``ref`` under ``rule``, and the paired
    interval of the share's difference (each clip its own unit, UAV and other clips apart)."""
    a, b = clip_right(mine, rule), clip_right(ref, rule)
    names = sorted(a)
    uav = {row["clip"]: row["uav"] for row in mine.clip_rows}
    hit = np.array([a[n] for n in names])
    against = np.array([b[n] for n in names])
    interval = recording_interval(
        hit, np.arange(len(names)), against=against, strata=np.array([uav[n] for n in names])
    )
    return int(hit.sum() - against.sum()), interval


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--at", nargs=3, action="append", required=True, metavar=("NAME", "MODEL", "DATASET")
    )
    args = ap.parse_args()
    reads = [read(*at) for at in args.at]
    ref = reads[0]
    rules = list(ref.clip_rows[0]["rules"])
    for r in reads:
        clips = len(r.clip_rows)
        uav_clips = sum(row["uav"] for row in r.clip_rows)
        print(
            f"θ {r.name}: {len(r.label)} held-out windows ({int(r.label.sum())} UAV) of "
            f"{clips} clips ({uav_clips} with a UAV)"
        )
        detect = ", ".join(
            f"{detection_at_false_alarm(r.score, r.label, rate):.3f} at {rate:g}" for rate in RATES
        )
        print(
            f"  windows: any-spike {balanced(r.fired, r.label):.3f}, with identification "
            f"{balanced(r.called, r.label):.3f}; detection {detect}"
        )
        shares = "; ".join(
            f"{what} {100 * flag[r.label].mean():.1f} % of the UAV windows and "
            f"{100 * flag[~r.label].mean():.1f} % of the UAV-free ones"
            for what, flag in (
                ("any-spike fires on", r.fired),
                ("identification calls UAV", r.called),
            )
        )
        print(f"  {shares}")
        right = {rule: sum(clip_right(r, rule).values()) for rule in rules}
        print("  clips decided right: " + ", ".join(f"{k} {v}/{clips}" for k, v in right.items()))
        if r is ref:
            continue
        for flag in ("fired", "called"):
            lead, (lo, hi), n = window_lead(r, ref, flag)
            print(
                f"  against θ {ref.name}, {flag} windows: {100 * lead:+.2f} points "
                f"({100 * lo:+.2f} to {100 * hi:+.2f}; {n} windows both keep)"
            )
        mine, theirs = clip_right(r, "identified"), clip_right(ref, "identified")
        moved = [
            f"{name} ({'right' if mine[name] else 'wrong'} here)"
            for name in sorted(mine)
            if mine[name] != theirs[name]
        ]
        print(f"  clips decided otherwise with identification: {', '.join(moved) or 'none'}")
        for rule in rules:
            diff, (lo, hi) = clip_lead(r, ref, rule)
            print(
                f"  against θ {ref.name}, clips {rule}: {diff:+d} "
                f"({100 * lo:+.1f} to {100 * hi:+.1f} points)"
            )


if __name__ == "__main__":
    main()
