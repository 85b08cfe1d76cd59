"""``uavsnn demo``: the whole path on the small built-in synthetic set — build, train,
evaluate, report — in a few minutes on two cores (SPEC §6)."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from uavsnn import __version__, _jsonout, report, report_pictures
from uavsnn.cli import output_dir
from uavsnn.dataset import build_demo, load
from uavsnn.errors import ParameterError
from uavsnn.evaluation import evaluate
from uavsnn.experiments import (
    RECIPE_SETTINGS,
    have_dataset,
    noise_sweep,
    recipe_config,
    static_twin,
)
from uavsnn.network import Network
from uavsnn.provenance import TrainedOn
from uavsnn.training import train

__all__ = ["DEMO_WINDOWS_PER_LAYER", "register", "run_demo"]

DEMO_WINDOWS_PER_LAYER = 2000
DEMO_NOISE = (0.0, 0.01, 0.03, 0.05)


def register(subparsers: Any) -> None:
    """Add ``uavsnn demo``."""
    p = subparsers.add_parser(
        "demo",
        help="the whole pipeline on a small built-in synthetic set, with a report",
        description="Build the small synthetic dvs set, train conv2 and conv3 by STDP, "
        "evaluate on the held-out test windows (with added noise, PENT against static "
        "thresholds) and write report.md with pictures.",
    )
    p.add_argument("--out", type=Path, default=Path("runs/demo"), help="folder (runs/demo)")
    p.add_argument(
        "--seed",
        type=int,
        default=0,
        help="seed of the dataset, the network's weights, its training and the added noise (0)",
    )
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(handler=_demo)


def run_demo(out: Path, seed: int = 0, *, progress: bool = False) -> dict[str, Any]:
    """Run the demo into ``out``; returns its figures (also written to ``out/results.json``)."""
    started = time.perf_counter()
    data_dir = out / "data"
    if not have_dataset(data_dir, seed):
        build_demo(data_dir, seed, overwrite=True, progress=progress)
    built = time.perf_counter()
    train_set, test_set = load(data_dir, "train"), load(data_dir, "test")
    network = Network(recipe_config(), seed=seed)
    trained = train(
        network, train_set.windows, windows_per_layer=DEMO_WINDOWS_PER_LAYER, seed=seed,
        progress=progress,
    )  # fmt: skip
    network.trained_on = TrainedOn.of_sets(train_set)
    network.save(out / "model.npz")
    result = evaluate(network, test_set, keep_inference=True)
    static, theta = static_twin(network, train_set.windows)
    points = noise_sweep({"pent": network, "static": static}, test_set, DEMO_NOISE, seed=seed)
    written = report_pictures.figures(
        out, network, test_set, result, training=trained, noise=points, static=static, seed=seed
    )
    figures = {
        "uavsnn": __version__,
        "seed": seed,
        "settings": list(RECIPE_SETTINGS),
        "windows_per_layer": DEMO_WINDOWS_PER_LAYER,
        "train_windows": len(train_set),
        "test": result.to_dict(),
        "training": trained.to_dict(),
        "static_threshold": theta,
        "noise": [p.to_dict() for p in points],
        "seconds": {
            "dataset": round(built - started, 2),
            "total": round(time.perf_counter() - started, 2),
        },
    }
    (out / "results.json").write_text(_jsonout.dumps(figures, indent=2) + "\n", encoding="utf-8")
    text = [
        "# uavsnn demo\n",
        f"`uavsnn demo --seed {seed}` (uavsnn {__version__}): the small synthetic dvs set "
        f"({len(train_set)} train and {len(test_set)} test windows of 50 ms from different "
        f"recordings), conv2 and conv3 trained by STDP on {DEMO_WINDOWS_PER_LAYER} windows "
        f"each with Table 1's network changed by `{' '.join(RECIPE_SETTINGS)}`; no label is "
        "used in training. Figures on the held-out test windows:\n",
        report.evaluation_markdown(result),
        "\n## Added noise: PENT against static thresholds\n",
        f"Static threshold {theta:.2f}: the one PENT sets for the median clean training window.\n",
        report.noise_table(points),
        "\n## Pictures\n",
        *report_pictures.picture_links(written, out),
    ]
    (out / "report.md").write_text("\n".join(text), encoding="utf-8")
    return figures


def _demo(args: argparse.Namespace) -> int:
    if args.seed < 0:  # before the folder is made: a refusal leaves nothing behind
        raise ParameterError(f"--seed must be >= 0, got {args.seed}")
    output_dir(args.out, "--out")
    figures = run_demo(args.out, args.seed, progress=not args.quiet)
    if args.json:
        print(_jsonout.dumps(figures, indent=2))
        return 0
    test = figures["test"]
    (tp, fn), (fp, tn) = test["confusion"]
    print(f"uavsnn demo (seed {args.seed}) in {figures['seconds']['total']:.0f} s")
    print(
        f"  held-out test: accuracy {100 * test['accuracy']:.1f} % on {test['windows']} windows "
        f"(chance 50 %), TP {tp} FN {fn} FP {fp} TN {tn}"
    )
    for p in figures["noise"]:
        snr = "clean" if p["snr_db"] is None else f"{p['snr_db']:.1f} dB"
        print(
            f"  noise {100 * p['fraction']:g} % ({snr}), {p['mode']}: {100 * p['accuracy']:.1f} %"
        )
    print(f"  report: {args.out / 'report.md'}")
    return 0
