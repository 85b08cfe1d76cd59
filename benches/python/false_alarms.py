"""False alarms per minute of UAV-free recording, as the streaming detector raises them
(:mod:`uavsnn.false_alarms`), on this machine's processes.

Renders as many fresh UAV-free dvs recordings as asked, streams each through the ``Detector``
and counts the windows and the tracks that alarm per rule: the any-spike rule, identification
at the model's threshold and at each operating point set beforehand. ``uavsnn reproduce``
runs the same for the combined network (``--free-minutes``); this script runs it for any model
file, on ``--workers`` processes.

    python benches/python/false_alarms.py MODEL.npz [--minutes 10] [--seed 0] [--workers 2]
        [--tune-key] [--lens F_NUMBER [--focus-m M]] [--json]

``--lens``: the recordings seen through a lens of that f-number (``uavsnn.scenes.Lens``, the
sensor's pixel pitch; focused at ``--focus-m``, default infinity), as ``uavsnn dataset build
--lens`` makes them; by default a pinhole, as the datasets by default.
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
from uavsnn.cli._camera import lens_option  # noqa: E402
from uavsnn.errors import ParameterError  # noqa: E402
from uavsnn.false_alarms import (  # noqa: E402
    DEFAULT_CONFIRM,
    FREE_KEY,
    MAX_MINUTES,
    TUNE_KEY,
    alarm_rules,
    false_alarm_table,
    scene_batches,
    stream_batch,
    summarise,
)
from uavsnn.scenes import Lens  # noqa: E402
from uavsnn.track_eval import Confirm  # noqa: E402

#: The most worker processes (each holds a model and one recording at a time).
MAX_WORKERS = 8

_model: Network | None = None


def _load(model: str) -> None:
    global _model
    _model = Network.load(model)


def _batch(
    work: tuple[list[tuple[str, int]], tuple[int, int] | None, Lens | None],
) -> list[dict[str, Any]]:
    assert _model is not None
    scenes, confirm, lens = work
    return stream_batch(_model, scenes, confirm, lens)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model")
    parser.add_argument("--minutes", type=float, default=10.0, help="of UAV-free recording (10)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2, help=f"processes, 1 to {MAX_WORKERS}")
    parser.add_argument(
        "--tune-key",
        action="store_true",
        help="the recordings operating points are set on (false_alarms.TUNE_KEY), not the ones "
        "false alarms are measured on",
    )
    parser.add_argument(
        "--confirm",
        metavar="HITS/WINDOWS",
        help="the tracker's confirmation rule (default 3/5, the detector's)",
    )
    parser.add_argument("--lens", type=float, metavar="F_NUMBER", help="a lens of this f-number")
    parser.add_argument("--focus-m", type=float, metavar="M", help="its focus (infinity)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if not 1 <= args.workers <= MAX_WORKERS:
        parser.error(f"--workers must be 1 to {MAX_WORKERS}")
    if not 0 < args.minutes <= MAX_MINUTES:
        parser.error(f"--minutes must be in (0, {MAX_MINUTES:g}]")
    confirm = None
    if args.confirm is not None:
        rule = Confirm.parse(args.confirm)
        if rule.fast is not None:
            parser.error("--confirm takes HITS/WINDOWS (the detector has no score-aware rule)")
        confirm = rule.pair
    try:
        lens = lens_option(args.lens, args.focus_m)
    except ParameterError as exc:
        parser.error(str(exc))
    network = Network.load(args.model)
    batches = scene_batches(args.minutes, args.seed, TUNE_KEY if args.tune_key else FREE_KEY)
    work = [(b, confirm, lens) for b in batches]
    with ProcessPoolExecutor(args.workers, initializer=_load, initargs=(args.model,)) as pool:
        rows = [row for batch in pool.map(_batch, work) for row in batch]
    out = summarise(rows, alarm_rules(network, confirm or DEFAULT_CONFIRM)) | {
        "seed": args.seed, "tune_key": args.tune_key, "confirm": args.confirm or "3/5",
        "lens": None if lens is None else lens.describe(),
    }  # fmt: skip
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        print(false_alarm_table(out))


if __name__ == "__main__":
    main()
