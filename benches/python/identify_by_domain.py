"""A network's identification fitted again on the windows of some domains only.

A combined dataset (``uavsnn dataset build --domain combined``) trains on dvs and sim windows
mixed, and ``uavsnn train`` fits identification on both. The sim windows come from 30/60 fps
video, which shows no propeller flicker, so a drone there has no rotor. This script fits the
network's identification on the windows of the recordings of ``--domain`` alone (the domain of
each recording is in the manifest), of the training split and of ``--tune``'s train split, and
writes the model to ``-o``; score it with ``uavsnn evaluate OUT DATASET --tracks --json`` beside
the model as trained. No test split is read here.

    python benches/python/identify_by_domain.py runs/comb1280/model.npz runs/comb1280 \\
        --tune runs/tunecomb1280st --domain dvs -o runs/comb1280/model-dvs-ident.npz
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from uavsnn import Network
from uavsnn.dataset import LabelledWindows, load
from uavsnn.experiments import fit_identification


def of_domains(data: LabelledWindows, domains: set[str]) -> LabelledWindows:
    """The windows of ``data`` whose recording (by the manifest's ``recordings``) is of one of
    ``domains``."""
    keep = {int(r["id"]) for r in data.manifest["recordings"] if r.get("domain") in domains}
    idx = np.flatnonzero(np.isin(np.asarray(data.recording, dtype=np.int64), sorted(keep)))
    if len(idx) == 0:
        raise SystemExit(f"no window of a {'/'.join(sorted(domains))} recording")
    return data.select(idx)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("model", help="a model file with a network (its identification is replaced)")
    p.add_argument("dataset", help="the dataset the network was trained on (its train split)")
    p.add_argument("--tune", required=True, help="the tuning dataset (its train split)")
    p.add_argument("--domain", action="append", required=True, help="a domain kept (repeatable)")
    p.add_argument("-o", "--output", required=True, type=Path, help="model file to write")
    args = p.parse_args()
    domains = set(args.domain)
    network = Network.load(args.model)
    train = of_domains(load(args.dataset, "train"), domains)
    tune = of_domains(load(args.tune, "train"), domains)
    summary = fit_identification(network, train, tune)
    if "skipped" in summary:
        raise SystemExit(f"no identification: {summary['skipped']}")
    network.save(args.output)
    shown = {k: v for k, v in summary.items() if not isinstance(v, (list, dict))}
    print(
        f"fitted on {len(train)} training and {len(tune)} tuning windows of "
        f"{'/'.join(sorted(domains))} recordings; wrote {args.output}"
    )
    print(json.dumps(shown, indent=1, default=str))


if __name__ == "__main__":
    main()
