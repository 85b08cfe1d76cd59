"""The ``uavsnn`` command line: one sub-command per step of the path (SPEC §6).

Each sub-command lives in the module of its name in this package and exposes
``register(subparsers) -> None``, which adds its parser and sets ``handler`` (a function of the
parsed arguments returning an exit code) with ``parser.set_defaults(handler=...)``. A module is
imported only when its command is run (or asked for its ``--help``): ``uavsnn --help`` lists
the commands from :data:`COMMANDS` without loading OpenCV, the renderer or the simulators, so
adding a command adds its line there. A private module (``_camera``: the lens and field of view
options) holds what several commands share.

Every failure a user can cause ends in one line on standard error and a documented exit code:
2 for bad input (any :class:`uavsnn.UavsnnError`, a file that cannot be read or written, not
enough memory), 130 for Ctrl-C (``interrupted``; files are written atomically, so nothing is
left half-written), and 1, silently, when the reader of standard output goes away
(``uavsnn info F | head -3``), as Python's documentation recommends for a broken pipe.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from uavsnn import __version__
from uavsnn._files import check_output_dir, output_dir, output_file
from uavsnn.errors import UavsnnError

__all__ = ["COMMANDS", "check_output_dir", "main", "output_dir", "output_file"]

#: The sub-commands, each the name of its module, with the one line ``uavsnn --help`` shows.
COMMANDS: dict[str, str] = {
    "bench": "measure the engine's speed on this machine",
    "dataset": "build and inspect labelled datasets of windows",
    "demo": "the whole pipeline on a small built-in synthetic set, with a report",
    "detect": "detect UAVs in a recording, standard input or a UDP event stream",
    "evaluate": "score a model on a labelled test set",
    "info": "sensor size, event count, duration and event rates of a recording",
    "reproduce": "the paper's experiments at full size, written to RESULTS.md",
    "simulate": "turn a video into events (PIX2NVS 'sim' or DVS emulation 'dvs')",
    "train": "train a detector by STDP, one layer at a time",
}

#: Exit code of a command stopped by Ctrl-C (128 + SIGINT, as shells report it).
EXIT_INTERRUPTED = 130


def _build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser, with ``command``'s module imported and its arguments defined (every command
    when ``command`` is ``"*"``); the others are listed by name and help line only."""
    parser = argparse.ArgumentParser(
        prog="uavsnn",
        description="Drone detection on event-camera streams with an STDP-trained SNN.",
    )
    parser.add_argument("--version", action="version", version=f"uavsnn {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, line in COMMANDS.items():
        if command in (name, "*"):
            importlib.import_module(f"{__name__}.{name}").register(subparsers)
        else:
            subparsers.add_parser(name, help=line)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``uavsnn`` command."""
    words = sys.argv[1:] if argv is None else argv
    # The top-level options take no value, so the first word that is not one names the command.
    parser = _build_parser(next((w for w in words if not w.startswith("-")), None))
    args = parser.parse_args(words)
    if args.command is None:
        parser.print_help()
        return 0
    handler = getattr(args, "handler", None)
    if handler is None:
        parser.error(f"unknown command {args.command!r}")
    name = f"uavsnn {args.command}"
    try:
        code = int(handler(args) or 0)
        sys.stdout.flush()  # a closed pipe shows here, not at exit
        return code
    except UavsnnError as exc:
        print(f"{name}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{name}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # The reader went away: send what is still buffered to /dev/null so that the flush
        # at exit does not fail again, and stop quietly.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1
    except MemoryError:
        print(
            f"{name}: error: not enough memory; give a smaller input (a shorter recording, "
            "fewer windows)",
            file=sys.stderr,
        )
        return 2
    except OSError as exc:
        # A file or folder the user named cannot be read or written.
        print(f"{name}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
