"""The ``uavsnn`` command line: one sub-command per step of the path (SPEC §6)."""

from __future__ import annotations

import argparse
import sys

from uavsnn import __version__
from uavsnn.errors import UavsnnError

__all__ = ["main"]


def _build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="uavsnn",
        description="Drone detection on event-camera streams with an STDP-trained SNN.",
    )
    parser.add_argument("--version", action="version", version=f"uavsnn {__version__}")
    parser.add_subparsers(dest="command", metavar="COMMAND")
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``uavsnn`` command."""
    parser = _build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    handler = getattr(args, "handler", None)
    if handler is None:
        parser.error(f"unknown command {args.command!r}")
    try:
        return int(handler(args) or 0)
    except UavsnnError as exc:
        print(f"uavsnn {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
