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
(``uavsnn info F | head -3``), as Python's documentation recommends for a broken pipe (Windows
reports one as ``EINVAL``: :func:`pipe_closed`).
SIGTERM and SIGHUP (a service manager stopping the command, a closed terminal) take Ctrl-C's
path (:class:`Terminated`, a ``KeyboardInterrupt``) and exit 128 + the signal's number: 143 and
129, as shells report them. Their handlers are installed only in the main thread and only where
the signal's disposition is the default (a handler the embedding program set, or ``nohup``'s
ignored SIGHUP, is left alone), and put back when :func:`main` returns.

``--ray [ADDRESS]`` takes the word after it for its address when that word is a cluster's
address (``auto``, ``local``, ``ray://...``, ``HOST:PORT``) or cannot be a positional argument:
``uavsnn detect --ray rec.npz -m M`` runs ``rec.npz`` on a local cluster rather than miss its
SOURCE (:func:`_parse`).

What a command writes as JSON (``--json``, ``results.json``) is strict JSON: a figure that is not
defined is ``null``, never Python's bare ``NaN`` (:mod:`uavsnn._jsonout`).

A bare ``uavsnn``, like ``uavsnn dataset``, misses its command: the usage goes to standard error
and the exit code is 2, argparse's rule.
"""

from __future__ import annotations

import argparse
import contextlib
import contextvars
import errno
import importlib
import io
import os
import re
import signal
import sys
import threading
from collections.abc import Iterator
from types import FrameType
from typing import Any, NoReturn

from uavsnn import __version__
from uavsnn._files import check_output_dir, output_dir, output_file
from uavsnn.errors import UavsnnError

__all__ = [
    "COMMANDS",
    "Terminated",
    "check_output_dir",
    "exit_code",
    "held_stops",
    "interrupted_line",
    "main",
    "output_dir",
    "output_file",
    "pipe_closed",
    "quiet_stdout",
]

#: The sub-commands, each the name of its module, with the one line ``uavsnn --help`` shows.
COMMANDS: dict[str, str] = {
    "bench": "measure the engine's speed on this machine",
    "dataset": "build and inspect labelled datasets of windows",
    "demo": "the whole pipeline on a small built-in synthetic set, with a report",
    "detect": "detect UAVs in a recording, standard input or a UDP event stream",
    "evaluate": "score a model on a labelled test set",
    "info": (
        "a recording's sensor size, event count, duration and event rates; a model file's "
        "input, layers and identification"
    ),
    "reproduce": "the paper's experiments at full size, written to RESULTS.md",
    "simulate": "turn a video into events (PIX2NVS 'sim' or DVS emulation 'dvs')",
    "train": "train a detector by STDP, one layer at a time",
}

#: Exit code of a command stopped by Ctrl-C (128 + SIGINT, as shells report it).
EXIT_INTERRUPTED = 130

#: The signals that stop a command as Ctrl-C does (those present on this platform).
STOP_SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)
)


class Terminated(KeyboardInterrupt):
    """A command stopped by a signal other than Ctrl-C's (SIGTERM, SIGHUP): a
    ``KeyboardInterrupt``, so that every Ctrl-C path (flush what can be, report, leave files
    whole) applies; :attr:`signum` gives the exit code, 128 + it."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        #: The signal's number.
        self.signum = int(signum)

    @property
    def name(self) -> str:
        """The signal's name, e.g. ``"SIGTERM"``."""
        try:
            return signal.Signals(self.signum).name
        except ValueError:
            return f"signal {self.signum}"


def counted(n: int, noun: str) -> str:
    """``"1 recording"``, ``"3 recordings"``: a count and its noun, in the singular for one."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def exit_code(interrupt: KeyboardInterrupt) -> int:
    """The exit code of a command stopped by ``interrupt``: 128 + its signal's number (130 for
    Ctrl-C, 143 for SIGTERM, 129 for SIGHUP)."""
    if isinstance(interrupt, Terminated):
        return 128 + interrupt.signum
    return EXIT_INTERRUPTED


def interrupted_line(name: str, interrupt: KeyboardInterrupt) -> str:
    """The one line a command stopped by ``interrupt`` prints: ``uavsnn detect: interrupted``,
    with the signal's name when it is not Ctrl-C's."""
    if isinstance(interrupt, Terminated):
        return f"{name}: interrupted ({interrupt.name})"
    return f"{name}: interrupted"


def pipe_closed(exc: OSError, stream: Any) -> bool:
    """Whether ``exc``, raised while a command ran, says that the reader of ``stream`` (its
    standard output) went away. A ``BrokenPipeError`` does. On Windows a write to a closed pipe
    raises ``OSError`` with ``EINVAL`` instead, which a file name Windows refuses raises too:
    there it is the pipe when ``stream`` still cannot be flushed (the data a failed write left
    in its buffer fails again), not when it can."""
    if isinstance(exc, BrokenPipeError):
        return True
    if sys.platform != "win32" or exc.errno != errno.EINVAL:
        return False
    try:
        stream.flush()
    except OSError as again:
        return isinstance(again, BrokenPipeError) or again.errno == errno.EINVAL
    return False


def quiet_stdout(stream: Any) -> None:
    """After its reader went away, send what ``stream`` still buffers to the null device, so
    that the flush at exit does not fail again."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, stream.fileno())
    os.close(devnull)


def _terminate(signum: int, _frame: FrameType | None) -> None:
    raise Terminated(signum)


@contextlib.contextmanager
def _stop_signals() -> Iterator[None]:
    """SIGTERM and SIGHUP raise :class:`Terminated` inside the block, where their disposition
    is the default and this is the main thread; the previous handlers are put back after."""
    previous: list[tuple[signal.Signals, Any]] = []
    if threading.current_thread() is threading.main_thread():
        for sig in STOP_SIGNALS:
            if signal.getsignal(sig) == signal.SIG_DFL:
                previous.append((sig, signal.signal(sig, _terminate)))
    try:
        yield
    finally:
        for sig, handler in previous:
            signal.signal(sig, handler)


def _held(signum: int, _frame: FrameType | None) -> None:
    _HELD.append(signum)


#: The stop signals that came while :func:`held_stops` held them, in order.
_HELD: list[int] = []


@contextlib.contextmanager
def held_stops() -> Iterator[None]:
    """Ctrl-C, SIGTERM and SIGHUP wait for the block to end, then stop the command as they
    would have (``KeyboardInterrupt``, :class:`Terminated`): a block that prints a list of
    lines prints them all, each whole. A stop raised in the middle of a ``print`` left half a
    line (two JSON objects glued together when the flush's lines followed) and dropped the
    list's other lines. Only signals whose handler is Python's or :func:`_stop_signals`' are
    held, and only in the main thread; an error of the block itself goes on as it is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    ours = (signal.default_int_handler, _terminate)
    previous = [
        (sig, handler)
        for sig in (signal.SIGINT, *STOP_SIGNALS)
        if (handler := signal.getsignal(sig)) in ours
    ]
    for sig, _ in previous:
        signal.signal(sig, _held)
    try:
        yield
    finally:
        for sig, handler in previous:
            signal.signal(sig, handler)
    if previous and _HELD:  # held here (a block inside another's leaves them to the outer)
        signum = _HELD[0]
        _HELD.clear()
        if signum == signal.SIGINT:
            raise KeyboardInterrupt
        raise Terminated(signum)


#: The words ``--ray`` takes as its address; ``ray://...`` and ``HOST:PORT`` are addresses too.
_RAY_WORDS = ("auto", "local")
#: ``HOST:PORT`` (an IPv6 host in brackets), a Ray cluster's address.
_HOST_PORT = re.compile(r"(\[[0-9A-Fa-f:.]+\]|[^\s/\\:@\[\]]+):[0-9]+")
#: Set while :func:`_parse` tries a reading of the words: a parser's error then raises
#: :class:`_Unparsed` instead of printing the usage and exiting.
_TRYING: contextvars.ContextVar[bool] = contextvars.ContextVar("uavsnn_cli_trying", default=False)


class _Unparsed(Exception):
    """A reading of the words that :func:`_parse` tried does not parse."""


class _Parser(argparse.ArgumentParser):
    """The command line's parser (its sub-commands' parsers are of its class too): an
    ``ArgumentParser`` whose errors raise :class:`_Unparsed` while :func:`_parse` tries a
    reading of the words."""

    def error(self, message: str) -> NoReturn:
        if _TRYING.get():
            raise _Unparsed(message)
        super().error(message)


def _ray_takes(word: str) -> bool:
    """Whether ``word``, after ``--ray``, is surely its ADDRESS: ``auto``, ``local``,
    ``ray://...``, or ``HOST:PORT`` that names no existing file
    (:func:`uavsnn.distributed.connect`)."""
    if word in _RAY_WORDS or word.startswith("ray://"):
        return True
    return _HOST_PORT.fullmatch(word) is not None and not os.path.exists(word)


def _ray_without_address(words: list[str]) -> list[str]:
    """``words`` with each ``--ray`` that a word other than a cluster's address follows (a file,
    a folder to make, ``-``, ``udp://HOST:PORT``) moved after the options, where it takes no
    address. ``--ray=ADDRESS``, ``--ray`` before an option, and what follows ``--`` stay."""
    end = words.index("--") if "--" in words else len(words)
    kept: list[str] = []
    moved: list[str] = []
    for i, word in enumerate(words[:end]):
        after = words[i + 1] if i + 1 < end else "--"
        positional = after == "-" or not after.startswith("-")
        if word == "--ray" and positional and not _ray_takes(after):
            moved.append(word)
        else:
            kept.append(word)
    return [*kept, *moved, *words[end:]]


def _parse(parser: argparse.ArgumentParser, words: list[str]) -> argparse.Namespace:
    """``words`` parsed. ``--ray [ADDRESS]`` would take the positional argument after it for
    its address (``uavsnn detect -m M --ray rec.npz``: no SOURCE left): a word after ``--ray``
    that is no cluster's address is read as a positional argument, ``--ray`` without address,
    when the words then parse; else as written, when they parse so (``uavsnn reproduce --ray
    nonsense``: the address that ``--ray`` refuses). When neither parses, the error is that of
    the first reading (``uavsnn detect --ray rec.npz`` misses its --model, not its SOURCE)."""
    moved = _ray_without_address(words)
    if moved == list(words):
        return parser.parse_args(words)
    for reading in (moved, words):
        trying = _TRYING.set(True)
        try:
            return parser.parse_args(reading)
        except _Unparsed:
            pass
        finally:
            _TRYING.reset(trying)
    return parser.parse_args(moved)


def _build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser, with ``command``'s module imported and its arguments defined (every command
    when ``command`` is ``"*"``); the others are listed by name and help line only."""
    parser = _Parser(
        prog="uavsnn",
        description="Drone detection on event-camera streams with an STDP-trained SNN.",
    )
    parser.add_argument("--version", action="version", version=f"uavsnn {__version__}")
    # Without a command: the usage and "required: COMMAND" on standard error, exit 2, as a
    # command without its action (``uavsnn dataset``) exits.
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
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
    args = _parse(parser, words)
    handler = getattr(args, "handler", None)
    if handler is None:
        parser.error(f"unknown command {args.command!r}")
    # A command with actions names its action too ("uavsnn dataset info: error: ...").
    name = " ".join(
        ["uavsnn", args.command, *filter(None, [getattr(args, "dataset_action", None)])]
    )
    for stream in (sys.stdout, sys.stderr):
        _write_what_it_can(stream)
    with _stop_signals():
        return _run(name, handler, args)


def _write_what_it_can(stream: Any) -> None:
    """Let a text stream that cannot encode the commands' few non-ASCII characters (µs, ≥, —:
    a console or pipe in a legacy code page, such as cp932 on Windows) write them escaped
    rather than fail."""
    encoding = getattr(stream, "encoding", None)
    if not isinstance(stream, io.TextIOWrapper) or not encoding or stream.errors != "strict":
        return
    try:
        "µ≥—".encode(encoding)
    except (UnicodeEncodeError, LookupError):
        stream.reconfigure(errors="backslashreplace")


def _run(name: str, handler: Any, args: argparse.Namespace) -> int:
    """Run the command's handler; every failure becomes its line and exit code."""
    try:
        code = int(handler(args) or 0)
        sys.stdout.flush()  # a closed pipe shows here, not at exit
        return code
    except UavsnnError as exc:
        print(f"{name}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        print(interrupted_line(name, exc), file=sys.stderr)
        return exit_code(exc)
    except MemoryError:
        print(
            f"{name}: error: not enough memory; give a smaller input (a shorter recording, "
            "fewer windows)",
            file=sys.stderr,
        )
        return 2
    except OSError as exc:
        if pipe_closed(exc, sys.stdout):
            # The reader went away (`| head`): stop quietly.
            quiet_stdout(sys.stdout)
            return 1
        # A file or folder the user named cannot be read or written.
        print(f"{name}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
