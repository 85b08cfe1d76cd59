"""What identification costs beside the network, in instructions (callgrind), not time.

Runs each part of ``bench_identify.py`` (``--section``) once under callgrind, counting only
that part (``--collect-atstart=no --toggle-collect=functools_reduce``), and prints the
instructions per event the network consumes and the ratios of ``bench_identify.py``:

- batch: identification (``identify.window_features`` and ``Identifier.window_scores``)
  over the network's inference (``Network.infer``, one thread), per input spike;
- streaming: the ``Detector`` with rotor, tracks and scores over the network and tracker, on the
  same raw events, per raw event.

Instruction counts do not depend on what else the machine runs, so a shared machine gives
the same figures as a quiet one; time them too on a quiet machine (``bench_identify.py``).
Each part takes about half a minute under callgrind at the defaults.

    python benches/python/count_identify.py MODEL.npz DATASET [--windows 400] [--recordings 4]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from _identify_args import SECTIONS, parser

BENCH = Path(__file__).with_name("bench_identify.py")


def count(section: str, args: argparse.Namespace) -> tuple[int, int]:
    """``(instructions, events)`` of one section."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "callgrind.out"
        cmd = [
            "valgrind",
            "--tool=callgrind",
            "--collect-atstart=no",
            "--toggle-collect=functools_reduce",
            f"--callgrind-out-file={out}",
            sys.executable,
            str(BENCH),
            str(args.model),
            str(args.dataset),
            "--split",
            args.split,
            "--windows",
            str(args.windows),
            "--recordings",
            str(args.recordings),
            "--section",
            section,
        ]
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise SystemExit(f"{section}: callgrind run failed:\n{done.stderr[-2000:]}")
        events = json.loads(done.stdout.strip().splitlines()[-1])["events"]
        found = re.search(r"^summary: (\d+)", out.read_text(), re.MULTILINE)
        if found is None or int(found.group(1)) == 0:
            raise SystemExit(
                f"{section}: callgrind counted nothing; does this Python keep the symbol "
                "functools_reduce?"
            )
        return int(found.group(1)), int(events)


def main() -> None:
    ap = parser(__doc__)
    args = ap.parse_args()
    os.environ.setdefault("PYTHONHASHSEED", "0")

    ir = {}
    for section in SECTIONS:
        ir[section] = count(section, args)
    (net, spikes), (ident, _) = ir["network"], ir["identification"]
    (bare, raw), (full, _) = ir["stream-network"], ir["stream-full"]
    out = {
        "batch": {
            "input_spikes": spikes,
            "network_per_spike": net / spikes,
            "identification_per_spike": ident / spikes,
            "ratio": ident / net,
        },
        "streaming": {
            "raw_events": raw,
            "network_per_event": bare / raw,
            "with_identification_per_event": full / raw,
            "ratio": (full - bare) / bare,
        },
        "instructions": {s: n for s, (n, _) in ir.items()},
    }
    if args.json:
        print(json.dumps(out, indent=2))
        return
    b, s = out["batch"], out["streaming"]
    print(
        f"batch, {spikes} input spikes: network {b['network_per_spike']:.0f} instructions/spike, "
        f"identification {b['identification_per_spike']:.0f}, ratio {b['ratio']:.3f}"
    )
    print(
        f"streaming, {raw} raw events: network and tracker {s['network_per_event']:.0f} "
        f"instructions/event, with rotor, tracks and scores "
        f"{s['with_identification_per_event']:.0f}, added {s['ratio']:.3f} of the network's"
    )


if __name__ == "__main__":
    main()
