"""A network's identification fitted again on other windows: several datasets' train splits
together, or the windows of some domains only.

A combined dataset (``uavsnn dataset build --domain combined``) trains on dvs and sim windows
mixed, and ``uavsnn train`` fits identification on both. The sim windows come from 30/60 fps
video, which shows no propeller flicker, so a drone there has no rotor. This script fits the
network's identification on the train splits of every ``dataset`` named, together (``uavsnn
reproduce`` builds one set per domain), tuned on the train splits of every ``--tune`` set,
keeping with ``--domain`` only the windows of those domains' recordings (the domain of each
recording is in the manifest), and writes the model to ``-o``; score it with ``uavsnn evaluate
OUT DATASET --tracks --json`` beside the model as trained. Without ``--tune`` it is tuned on a
quarter of the kept training recordings held out, as ``uavsnn train`` tunes without one. No
test split is read here.

    python benches/python/identify_by_domain.py runs/comb1280/model.npz runs/comb1280 \\
        --tune runs/tunecomb1280st --domain dvs -o runs/comb1280/model-dvs-ident.npz
    python benches/python/identify_by_domain.py runs/reproduce/model-combined.npz \\
        runs/reproduce/data/dvs runs/reproduce/data/sim --tune runs/reproduce/data/tune-dvs \\
        --tune runs/reproduce/data/tune-sim [--mix 4000] -o model-combined-all.npz
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from uavsnn import Network
from uavsnn.dataset import LabelledWindows, load
from uavsnn.experiments import fit_identification, mix_windows


def of_domains(data: LabelledWindows, domains: set[str]) -> LabelledWindows:
    """The windows of ``data`` whose recording (by the manifest's ``recordings``) is of one of
    ``domains``."""
    keep = {int(r["id"]) for r in data.manifest["recordings"] if r.get("domain") in domains}
    idx = np.flatnonzero(np.isin(np.asarray(data.recording, dtype=np.int64), sorted(keep)))
    if len(idx) == 0:
        raise SystemExit(f"no window of a {'/'.join(sorted(domains))} recording")
    return data.select(idx)


def gathered(
    folders: Sequence[str], domains: set[str] | None, mix: int | None = None, seed: int = 0
) -> LabelledWindows:
    """The train splits of ``folders``, each kept to ``domains`` when given, every window of
    each, one after another (their recordings kept apart); with ``mix``, that many windows
    drawn in equal shares from them with ``seed`` (``uavsnn.experiments.mix_windows``)."""
    parts = [load(f, "train") for f in folders]
    if domains is not None:
        parts = [of_domains(p, domains) for p in parts]
    if mix is None and len(parts) == 1:
        return parts[0]  # with its manifest (the windows' step)
    return mix_windows(parts, mix, seed=seed)


def main(argv: Sequence[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("model", help="a model file with a network (its identification is replaced)")
    p.add_argument(
        "dataset", nargs="+", help="datasets whose train splits it is fitted on, together"
    )
    p.add_argument(
        "--tune",
        action="append",
        help="a tuning dataset (its train split; repeatable; default: a quarter of the kept "
        "training recordings held out, as `uavsnn train` without --tune)",
    )
    p.add_argument("--domain", action="append", help="a domain kept (repeatable; default: all)")
    p.add_argument(
        "--mix",
        type=int,
        metavar="N",
        help="N windows drawn in equal shares from the datasets (seed 0) and N from the tuning "
        "sets (seed 1), as `uavsnn reproduce` drew a combined network's before it fitted "
        "identification on the dvs windows alone",
    )
    p.add_argument("-o", "--output", required=True, type=Path, help="model file to write")
    args = p.parse_args(argv)
    if args.mix is not None and args.mix < 1:
        p.error(f"--mix takes a positive count of windows, got {args.mix}")
    domains = set(args.domain) if args.domain else None
    network = Network.load(args.model)
    train = gathered(args.dataset, domains, args.mix, seed=0)
    tune = None if args.tune is None else gathered(args.tune, domains, args.mix, seed=1)
    summary = fit_identification(network, train, tune)
    if "skipped" in summary:
        raise SystemExit(f"no identification: {summary['skipped']}")
    network.save(args.output)
    shown = {k: v for k, v in summary.items() if not isinstance(v, (list, dict))}
    kept = "/".join(sorted(domains)) if domains else "all"
    print(
        f"fitted on {summary['train_windows']} training and {summary['tune_windows']} tuning "
        f"windows ({summary['tune']}) of {kept} recordings; wrote {args.output}"
    )
    print(json.dumps(shown, indent=1, default=str))


if __name__ == "__main__":
    main()
