"""The command line ``bench_identify.py`` and ``count_identify.py`` share: the same model,
dataset, split and sizes, so that the instruction counts and the times describe the same
windows and recordings."""

from __future__ import annotations

import argparse
from pathlib import Path

SECTIONS = ("network", "identification", "stream-network", "stream-full")


def parser(doc: str) -> argparse.ArgumentParser:
    """The arguments both scripts take, described by the first line of ``doc``."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("model", type=Path)
    ap.add_argument("dataset", type=Path)
    ap.add_argument("--split", default="test")
    ap.add_argument("--windows", type=int, default=400, help="windows of the split (400)")
    ap.add_argument("--recordings", type=int, default=4, help="recordings streamed (4)")
    ap.add_argument("--json", action="store_true")
    return ap
