"""What identification costs beside the network, on the same windows, in one run.

Loads a model file with identification and a dataset of format 2 (raw events) and times, on
one thread (CPU time, ``time.process_time``, so other work on a shared machine inflates the
figures little):

- batch: ``Network.infer`` on the split's windows, then ``identify.window_features`` (the
  merged objects, their rotor signatures and features, from the same inference) and
  ``Identifier.window_scores``;
- streaming: each recording's raw events, in time order, through a ``Detector`` with the
  rotor signature off (the network, and the tracker every ``Detector`` runs: no scores without
  a rotor), then on with the model's identification (rotor signature, tracks, scores): the
  same events, pushed in 10 ms chunks. The tracker's cost is in both, so not in what is added.

Costs are given per event the network consumes (the windows' input spikes in batch, the raw
events in streaming) and as the ratio identification / network (the issue's target: at most
0.5).

    python benches/python/bench_identify.py MODEL.npz DATASET [--split test] [--windows 400]

Times on a busy machine mean little. ``--section NAME`` runs one of the four parts once
(``network``, ``identification``, ``stream-network``, ``stream-full``) inside a call of
``functools.reduce``, so that callgrind counts its instructions alone
(``--collect-atstart=no --toggle-collect=functools_reduce``), and prints the events it
consumed; ``benches/python/count_identify.py`` runs the four under callgrind and gives the
same ratios in instructions.
"""

from __future__ import annotations

import os

for _var in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import functools  # noqa: E402
import itertools  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from _identify_args import SECTIONS, parser  # noqa: E402

from uavsnn import Detector, Network, identify  # noqa: E402
from uavsnn.dataset import load  # noqa: E402


def _cpu(fn: Any, *args: Any, repeat: int = 3) -> tuple[float, Any]:
    best, out = float("inf"), None
    for _ in range(repeat):
        start = time.process_time()
        out = fn(*args)
        best = min(best, time.process_time() - start)
    return best, out


def _streams(data: Any, limit: int) -> list[np.ndarray]:
    """Each recording's raw events from its first window's start to its last window's end."""
    raw = data.raw
    out = []
    for rec in np.unique(data.recording)[:limit]:
        idx = np.flatnonzero(data.recording == rec)
        out.append(raw.events[int(raw.start[idx].min()) : int(raw.stop[idx].max())])
    return out


def _stream(network: Network, streams: list[np.ndarray], full: bool) -> int:
    objects = 0
    for events in streams:
        det = Detector(network, rotor=full)
        t = events["t"].astype(np.int64)
        edges = np.searchsorted(t, np.arange(int(t[0]), int(t[-1]) + 10_000, 10_000))
        for a, b in itertools.pairwise(edges):
            for report in det.push_windows(events[a:b]):
                objects += len(report.objects)
        for report in det.flush_windows():
            objects += len(report.objects)
    return objects


def _once(fn: Any) -> Any:
    """``fn()`` called inside ``functools.reduce``: the C function callgrind's
    ``--toggle-collect=functools_reduce`` counts, and nothing else here calls."""
    return functools.reduce(lambda _, __: fn(), [None], None)


def _section(name: str, network: Network, data: Any, spikes: int, recordings: int) -> dict:
    """Run one part of the bench once (see the module's docstring): the events it consumed."""
    if name in ("network", "identification"):
        if name == "network":
            _once(lambda: network.infer(data.windows, threads=1))
        else:
            inference = network.infer(data.windows, threads=1)
            ident = network.identification
            _once(lambda: ident.window_scores(identify.window_features(network, data, inference)))
        return {"section": name, "events": spikes, "unit": "input spike"}
    streams = _streams(data, recordings)
    _once(lambda: _stream(network, streams, name == "stream-full"))
    return {"section": name, "events": int(sum(len(s) for s in streams)), "unit": "raw event"}


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument(
        "--section",
        choices=SECTIONS,
        help="run this part alone, once, inside functools.reduce (for callgrind)",
    )
    args = ap.parse_args()

    network = Network.load(args.model)
    ident = network.identification
    if ident is None:
        raise SystemExit(f"{args.model} has no identification (`uavsnn train` fits it)")
    data = load(args.dataset, args.split)
    data = data.select(np.arange(min(args.windows, len(data))))
    spikes = int(np.diff(np.asarray(data.windows.offsets, dtype=np.int64)).sum())
    if args.section is not None:
        print(json.dumps(_section(args.section, network, data, spikes, args.recordings)))
        return

    net_s, inference = _cpu(lambda: network.infer(data.windows, threads=1))
    feat_s, feats = _cpu(lambda: identify.window_features(network, data, inference))
    score_s, _ = _cpu(lambda: ident.window_scores(feats))
    streams = _streams(data, args.recordings)
    raw_events = int(sum(len(s) for s in streams))
    bare_s, _ = _cpu(lambda: _stream(network, streams, False), repeat=1)
    full_s, objects = _cpu(lambda: _stream(network, streams, True), repeat=1)

    out = {
        "windows": len(data),
        "input_spikes": spikes,
        "objects": len(feats.window),
        "batch": {
            "network_ns_per_spike": 1e9 * net_s / spikes,
            "identification_ns_per_spike": 1e9 * (feat_s + score_s) / spikes,
            "ratio": (feat_s + score_s) / net_s,
        },
        "streaming": {
            "recordings": len(streams),
            "raw_events": raw_events,
            "objects": objects,
            "network_ns_per_event": 1e9 * bare_s / raw_events,
            "with_identification_ns_per_event": 1e9 * full_s / raw_events,
            "ratio": (full_s - bare_s) / bare_s,
        },
    }
    if args.json:
        print(json.dumps(out, indent=2))
        return
    b, s = out["batch"], out["streaming"]
    print(
        f"batch, {len(data)} windows, {spikes} input spikes, {out['objects']} objects: network "
        f"{b['network_ns_per_spike']:.1f} ns/spike, identification "
        f"{b['identification_ns_per_spike']:.1f} ns/spike, ratio {b['ratio']:.3f}"
    )
    print(
        f"streaming, {s['recordings']} recordings, {raw_events} raw events: network and tracker "
        f"{s['network_ns_per_event']:.1f} ns/event, with rotor, tracks and scores "
        f"{s['with_identification_ns_per_event']:.1f} ns/event, added {s['ratio']:.3f} of the "
        "network's"
    )


if __name__ == "__main__":
    main()
