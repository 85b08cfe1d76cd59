"""The ``uavsnn`` command line's parser: ``uavsnn --help`` imports no sub-command (so neither
OpenCV nor the renderer nor the simulators), and its list of commands is the modules'."""

from __future__ import annotations

import argparse
import json
import pkgutil
import subprocess
import sys

import uavsnn.cli
from uavsnn.cli import COMMANDS, _build_parser

_LOADED = """
import json, runpy, sys
sys.argv = ["uavsnn", *sys.argv[1:]]
try:
    runpy.run_module("uavsnn", run_name="__main__", alter_sys=True)
except SystemExit:
    pass
print(json.dumps(sorted(sys.modules)), file=sys.stderr)
"""


_HEAVY = ("uavsnn.scenes", "uavsnn.sim", "uavsnn.cli.")


def _loaded(*argv: str) -> set[str]:
    done = subprocess.run(
        [sys.executable, "-c", _LOADED, *argv], capture_output=True, text=True, check=True
    )
    return set(json.loads(done.stderr.strip().splitlines()[-1]))


def test_help_imports_no_command() -> None:
    for argv in (["--help"], []):
        loaded = _loaded(*argv)
        heavy = {m for m in loaded if m.split(".")[0] == "cv2" or m.startswith(_HEAVY)}
        assert heavy == set(), argv
    # A command's own help imports that command only (the check above can see modules load).
    assert {m for m in _loaded("info", "--help") if m.startswith("uavsnn.cli.")} == {
        "uavsnn.cli.info"
    }


def test_commands_are_the_modules_with_their_help() -> None:
    # Every public module is a command; a private one (``_camera``) holds options they share.
    modules = {m.name for m in pkgutil.iter_modules(uavsnn.cli.__path__)}
    assert set(COMMANDS) == {m for m in modules if not m.startswith("_")}
    parser = _build_parser("*")
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    shown = {a.dest: a.help for a in action._choices_actions}
    assert shown == COMMANDS
