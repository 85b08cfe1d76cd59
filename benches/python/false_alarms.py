"""False alarms per minute of UAV-free recording, as the streaming detector raises them.

A test split holds about half a minute of UAV-free recording (36 recordings of 1 s, their
windows overlapping): too little to show a rate of false tracks below several per minute
(docs/identification.md, "Tuned on other seeds"). This script renders as many UAV-free dvs
recordings as asked — the dataset's own scenes ("object" 70 %, a bird, aircraft, helicopter,
ball, insect or leaf; "empty" 30 %), under keys no dataset split uses, so none is a recording
a model was trained or tuned on — streams each through :class:`uavsnn.detector.Detector`
(``push_windows``, the tracker and identification as ``uavsnn detect`` runs them; a new stream
per recording) and counts, per rule:

- false windows: windows that alarm (any-spike: the window is detected; with identification
  at a threshold: also its best object's UAV score reaches it);
- false tracks: tracks that alarm (any-spike: confirmed; with identification: confirmed and
  the running mean of the track's object scores reaching the threshold at some window, as
  ``uavsnn.track_eval``'s identified rule), per minute of recording, with the 95 % upper bound
  (``track_eval.poisson_upper``) and by the class of the scene's object.

The rules: the any-spike rule, identification at the model's threshold, and at each operating
point set beforehand (``Identifier.alarm_thresholds``).

    python benches/python/false_alarms.py MODEL.npz [--minutes 10] [--seed 0] [--workers 2]
"""

from __future__ import annotations

import os

for _var in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402
from typing import Any  # noqa: E402

from uavsnn import Network  # noqa: E402
from uavsnn.dataset.splits import DOMAIN_KEY, keyed_rng, keyed_seed  # noqa: E402
from uavsnn.dataset.synthetic import default_source, synthetic_recording  # noqa: E402
from uavsnn.detector import Detector, WindowReport  # noqa: E402
from uavsnn.track_eval import poisson_upper  # noqa: E402

#: The key under a seed that no dataset split uses (``uavsnn.dataset.splits.SPLIT_KEY``: 1, 2).
FALSE_ALARM_KEY = 9
#: Events per chunk pushed into the detector, as a live stream arrives in pieces.
CHUNK = 20_000
#: The most worker processes (each holds a model and one recording at a time).
MAX_WORKERS = 8

_model: Network | None = None


def scenes(seed: int, recordings: int) -> list[tuple[str, int]]:
    """The kind and seed of each UAV-free recording: ``"object"`` 70 %, ``"empty"`` 30 %, as a
    dataset draws its UAV-free scenes, keyed by ``(seed, dvs, FALSE_ALARM_KEY, ...)``."""
    dkey = DOMAIN_KEY["dvs"]
    kinds = keyed_rng(seed, dkey, FALSE_ALARM_KEY, 0)
    out = []
    for i in range(recordings):
        kind = "object" if kinds.random() < 0.7 else "empty"
        out.append((kind, keyed_seed(seed, dkey, FALSE_ALARM_KEY, 1, i)))
    return out


def rules_of(network: Network) -> dict[str, float | None]:
    """Rule name -> threshold (``None``: the any-spike rule)."""
    rules: dict[str, float | None] = {"any_spike": None}
    ident = network.identification
    if ident is not None:
        rules["identified"] = ident.threshold
        for rate, threshold in ident.alarm_thresholds:
            rules[f"identified_at_{rate:g}"] = threshold
    return rules


def alarms(reports: list[WindowReport], rules: dict[str, float | None]) -> dict[str, Any]:
    """Per rule, the windows and the tracks that alarm among ``reports`` (one stream)."""
    windows = dict.fromkeys(rules, 0)
    tracks: dict[str, set[int]] = {rule: set() for rule in rules}
    for report in reports:
        if not report.detected:
            continue
        scores = [o.uav_score for o in report.objects if o.uav_score is not None]
        for rule, threshold in rules.items():
            if threshold is None or (scores and max(scores) >= threshold):
                windows[rule] += 1
        for o in report.objects:
            if o.track_id is None or not o.track_confirmed:
                continue
            for rule, threshold in rules.items():
                score = o.track_score
                if threshold is None or (score is not None and score >= threshold):
                    tracks[rule].add(o.track_id)
    return {"alarming": windows, "tracks": {rule: len(ids) for rule, ids in tracks.items()}}


def _load(model: str) -> None:
    global _model
    _model = Network.load(model)


def one(kind: str, seed: int) -> dict[str, Any]:
    """One recording through a fresh detector: its length, object, windows and alarms."""
    assert _model is not None
    width, height = int(_model.config["width"]), int(_model.config["height"])
    lr = synthetic_recording(default_source("dvs", (width, height)), kind, seed)
    events = lr.recording.events
    detector = Detector(_model, sensor_size=(width, height), start_us=0)
    reports: list[WindowReport] = []
    for start in range(0, len(events), CHUNK):
        reports += detector.push_windows(events[start : start + CHUNK])
    reports += detector.flush_windows()
    objects = lr.info.get("objects") or [{"kind": "none"}]
    return {
        "kind": str(objects[0]["kind"]),
        "seconds": lr.end_us / 1e6,
        "windows": len(reports),
        **alarms(reports, rules_of(_model)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("--minutes", type=float, default=10.0, help="of UAV-free recording (10)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2, help=f"processes, 1 to {MAX_WORKERS}")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if not 1 <= args.workers <= MAX_WORKERS:
        parser.error(f"--workers must be 1 to {MAX_WORKERS}")
    if not 0 < args.minutes <= 600:
        parser.error("--minutes must be in (0, 600]")
    network = Network.load(args.model)
    rules = rules_of(network)
    seconds = default_source("dvs").duration_s
    todo = scenes(args.seed, max(1, round(args.minutes * 60 / seconds)))
    with ProcessPoolExecutor(args.workers, initializer=_load, initargs=(args.model,)) as pool:
        rows = list(pool.map(one, *zip(*todo, strict=True)))
    minutes = sum(r["seconds"] for r in rows) / 60
    out: dict[str, Any] = {"recordings": len(rows), "minutes": minutes, "rules": {}}
    for rule, threshold in rules.items():
        false = sum(r["tracks"][rule] for r in rows)
        per_kind: dict[str, int] = {}
        for r in rows:
            if r["tracks"][rule]:
                per_kind[r["kind"]] = per_kind.get(r["kind"], 0) + r["tracks"][rule]
        out["rules"][rule] = {
            "threshold": threshold,
            "window_alarm_share": sum(r["alarming"][rule] for r in rows)
            / max(1, sum(r["windows"] for r in rows)),
            "false_tracks": false,
            "false_tracks_per_minute": false / minutes,
            "false_tracks_per_minute_upper95": poisson_upper(false) / minutes,
            "recordings_with_a_false_track": sum(1 for r in rows if r["tracks"][rule]),
            "false_tracks_per_kind": dict(sorted(per_kind.items())),
        }
    if args.json:
        print(json.dumps(out, indent=2))
        return
    print(f"{out['recordings']} UAV-free recordings, {minutes:.2f} minutes (seed {args.seed})")
    for rule, f in out["rules"].items():
        kinds = ", ".join(f"{k} {n}" for k, n in f["false_tracks_per_kind"].items()) or "none"
        print(
            f"  {rule:20s} windows alarming {100 * f['window_alarm_share']:.2f} %, false tracks "
            f"{f['false_tracks']} ({f['false_tracks_per_minute']:.2f}/min, 95 % bound "
            f"{f['false_tracks_per_minute_upper95']:.2f}) in "
            f"{f['recordings_with_a_false_track']} recordings ({kinds})"
        )


if __name__ == "__main__":
    main()
