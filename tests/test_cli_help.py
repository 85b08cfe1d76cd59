"""What a new user meets first, held to what it should be: ``--ray`` before a positional takes no
address (``uavsnn detect --ray rec.npz -m M`` streams ``rec.npz``), and a missing SOURCE is named
once; every command, action, option and positional has its help text; a bare ``uavsnn`` exits
2 as ``uavsnn dataset`` does; ``bench`` counts one thread in the singular. And the API's: the
``Detector`` example keeps what ``flush`` returns; ``window_us`` is refused with its real bounds
under its own name; ``filters.downsample`` only reduces; the names ``uavsnn/__init__.py`` cites,
and ``docs/api.md``'s ``SceneSource`` and CSV sensor size, are right; pyproject names the
repository."""

from __future__ import annotations

import argparse
import re
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import blob_events, small_config

import uavsnn
import uavsnn.cli.dataset
import uavsnn.cli.detect
import uavsnn.cli.evaluate
import uavsnn.cli.reproduce
import uavsnn.cli.train
import uavsnn.detector
from uavsnn import EVENT_DTYPE, ParameterError, Recording
from uavsnn.cli import _build_parser, main
from uavsnn.detector import Detector
from uavsnn.filters import downsample
from uavsnn.network import Network

ROOT = Path(__file__).resolve().parents[1]

# -- 1. --ray [ADDRESS] before a positional ------------------------------------------------------


def _parsed(monkeypatch: pytest.MonkeyPatch, module: Any, handler: str, argv: list[str]) -> Any:
    """The arguments ``uavsnn ARGV`` hands its handler (replaced: nothing runs, no Ray starts)."""
    seen: list[argparse.Namespace] = []
    monkeypatch.setattr(module, handler, lambda args: seen.append(args) or 0)
    assert main(argv) == 0
    return seen[0]


@pytest.fixture
def files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A folder holding ``rec.npz``, ``other.npz`` and a file named like a Ray address, made the
    working directory."""
    for name in ("rec.npz", "other.npz", *(["head:6379"] if sys.platform != "win32" else [])):
        (tmp_path / name).write_bytes(b"")
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.parametrize(
    ("argv", "sources"),
    [
        (["--model", "m.npz", "--ray", "rec.npz"], ["rec.npz"]),
        (["--ray", "rec.npz", "other.npz", "-m", "m.npz"], ["rec.npz", "other.npz"]),
        (["--ray", "-", "-m", "m.npz"], ["-"]),
        (["--ray", "udp://0.0.0.0:7001", "-m", "m.npz"], ["udp://0.0.0.0:7001"]),
        # A word that is no address is a positional, whether or not a file has that name yet.
        (["--ray", "missing.npz", "-m", "m.npz"], ["missing.npz"]),
        # An existing file wins over the HOST:PORT it looks like.
        (["--ray", "head:6379", "-m", "m.npz"], ["head:6379"]),
        (["rec.npz", "-m", "m.npz", "--ray"], ["rec.npz"]),
    ],
)
def test_ray_before_a_source_takes_no_address(
    files: Path, monkeypatch: pytest.MonkeyPatch, argv: list[str], sources: list[str]
) -> None:
    if "head:6379" in argv and sys.platform == "win32":
        pytest.skip("a Windows file name holds no ':'")
    args = _parsed(monkeypatch, uavsnn.cli.detect, "run", ["detect", *argv])
    assert [args.source, *args.more_sources] == sources
    assert args.ray == "local"


@pytest.mark.parametrize(
    "address", ["auto", "local", "head:6380", "10.0.0.2:6379", "[::1]:6379", "ray://head:10001"]
)
def test_ray_keeps_its_address(files: Path, monkeypatch: pytest.MonkeyPatch, address: str) -> None:
    for argv in (["--ray", address, "rec.npz"], [f"--ray={address}", "rec.npz"]):
        args = _parsed(monkeypatch, uavsnn.cli.detect, "run", ["detect", "-m", "m.npz", *argv])
        assert (args.source, args.more_sources, args.ray) == ("rec.npz", [], address)
    # An explicit --ray=WORD stays WORD, whatever it is (connect() judges it).
    argv = ["detect", "-m", "m.npz", "--ray=rec.npz", "x.npz"]
    args = _parsed(monkeypatch, uavsnn.cli.detect, "run", argv)
    assert (args.source, args.ray) == ("x.npz", "rec.npz")


def test_ray_before_the_positionals_of_every_command(
    files: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    args = _parsed(
        monkeypatch,
        uavsnn.cli.dataset,
        "_build",
        ["dataset", "build", "--ray", "out", "--domain", "dvs"],
    )
    assert (args.out_dir, args.ray) == (Path("out"), "local")
    args = _parsed(
        monkeypatch, uavsnn.cli.train, "_train", ["train", "--ray", "rec.npz", "-o", "m"]
    )
    assert (args.dataset, args.ray) == (Path("rec.npz"), "local")
    args = _parsed(
        monkeypatch, uavsnn.cli.evaluate, "_evaluate", ["evaluate", "--ray", "rec.npz", "other.npz"]
    )
    assert (args.model, args.dataset, args.ray) == (Path("rec.npz"), Path("other.npz"), "local")
    # A command without positionals takes the word as its address (connect() refuses a bad one).
    args = _parsed(
        monkeypatch, uavsnn.cli.reproduce, "_reproduce", ["reproduce", "--ray", "rec.npz"]
    )
    assert args.ray == "rec.npz"
    # After `--` every word is a positional: --ray there is left to argparse.
    args = _parsed(
        monkeypatch, uavsnn.cli.detect, "run", ["detect", "-m", "m", "--ray", "--", "rec.npz"]
    )
    assert (args.source, args.ray) == ("rec.npz", "local")


def test_ray_before_a_source_is_refused_for_what_is_wrong(
    files: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The command's own refusals, which come before Ray starts, instead of a missing SOURCE."""
    assert main(["detect", "--model", "missing.npz", "--ray", "rec.npz"]) == 2
    err = capsys.readouterr().err
    assert "missing.npz" in err and "required" not in err
    (files / "data").mkdir()
    assert main(["evaluate", "--ray", "rec.npz", "data"]) == 2
    assert "--ray runs the --clips streams: give --clips" in capsys.readouterr().err
    assert main(["train", "--ray", "data", "-o", "m.npz"]) == 2
    assert "--ray runs the --track-minutes recordings" in capsys.readouterr().err


def test_ray_before_a_source_reports_what_is_missing(
    files: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit):
        main(["detect", "--ray", "rec.npz"])
    err = capsys.readouterr().err
    assert err.endswith("error: the following arguments are required: --model/-m\n"), err


def test_a_missing_source_is_named_once(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["detect", "-m", "m.npz"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert err.endswith("error: the following arguments are required: SOURCE\n"), err
    assert "SOURCE [MORE_SOURCES ...]" in " ".join(err.split())


# -- 5. every parser's help text -----------------------------------------------------------------


def _parsers(
    parser: argparse.ArgumentParser, name: str = "uavsnn"
) -> list[tuple[str, argparse.ArgumentParser, list[argparse.Action]]]:
    """Every parser under ``parser`` (sub-commands, and their actions) with its name, and the
    choices' entries of its sub-parsers (what ``--help`` lists for each)."""
    found = []
    choices: list[argparse.Action] = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            choices += action._choices_actions
            for sub, subparser in action.choices.items():
                found += _parsers(subparser, f"{name} {sub}")
    return [(name, parser, choices), *found]


def test_every_command_option_and_positional_has_help() -> None:
    missing = []
    for name, parser, choices in _parsers(_build_parser("*")):
        if not parser.description:
            missing.append(f"{name}: no description")
        missing += [f"{name} {c.dest}: no help" for c in choices if not c.help]
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                continue
            if not action.help or action.help == argparse.SUPPRESS:
                missing.append(f"{name} {'/'.join(action.option_strings) or action.dest}: no help")
    assert missing == []


def test_help_texts_name_the_defaults() -> None:
    """Where an option's default is a number, its help says it (in the project's ``(0)`` or
    ``default`` form)."""
    for name, parser, _ in _parsers(_build_parser("*")):
        if name not in ("uavsnn dataset demo", "uavsnn dataset preview", "uavsnn demo"):
            continue
        for action in parser._actions:
            if isinstance(action.default, int) and not isinstance(action.default, bool):
                assert f"({action.default})" in str(action.help), (name, action.dest)


# -- 6. a missing command ------------------------------------------------------------------------


@pytest.mark.parametrize(("argv", "missing"), [([], "COMMAND"), (["dataset"], "ACTION")])
def test_a_missing_command_is_an_error(
    capsys: pytest.CaptureFixture[str], argv: list[str], missing: str
) -> None:
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.startswith("usage: uavsnn") and err.endswith(f"required: {missing}\n"), err


# -- 7. plurals ----------------------------------------------------------------------------------


def test_bench_counts_one_thread_in_the_singular(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["bench", "--size", "32x24", "--density", "1", "--windows", "1", "--repeat", "1"]
    assert main([*argv, "--threads", "1", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert " 1 thread " in out and "1 threads" not in out, out
    assert main([*argv, "--threads", "2", "--quiet"]) == 0
    assert " 2 threads " in capsys.readouterr().out


# -- 2. the Detector's example -------------------------------------------------------------------


def test_the_detector_example_reports_what_flush_returns() -> None:
    doc = str(uavsnn.detector.__doc__)
    code = textwrap.dedent(doc.split("Example::", 1)[1])
    net = Network(small_config(), seed=3)
    events = blob_events(0, 3000)
    # Cut the stream at its first detection: that detection is still pending at the end.
    first = Detector(net, window_us=50_000, overlap=0.5).push(events)["t"].min()
    events = events[events["t"] <= first]
    det = Detector(net, window_us=50_000, overlap=0.5)
    expected = [(d["t"], d["x"], d["y"]) for d in np.concatenate([det.push(events), det.flush()])]
    assert expected
    printed: list[tuple[Any, ...]] = []
    namespace = {
        "uavsnn": uavsnn,
        "network": net,
        "source": [events[:3], events[3:]],
        "print": lambda *values: printed.append(values),
    }
    exec(compile(code, "uavsnn.detector example", "exec"), namespace)
    assert printed == expected


# -- 3. window_us's bounds -----------------------------------------------------------------------


def test_window_us_is_checked_with_its_real_bounds_and_name() -> None:
    net = Network(small_config(), seed=3)
    for bad in (0, 2**62 + 1, 2**63, 2**64):
        with pytest.raises(
            ParameterError, match=r"^window_us must be in \[1, 4611686018427387904\]"
        ):
            Detector(net, window_us=bad, rotor=False)
    assert Detector(net, window_us=2**62, rotor=False).window_us == 2**62
    # start_us likewise: the engine's latest time, under its own name.
    with pytest.raises(ParameterError, match=r"^start_us must be in \[0, 4611686018427387904\]"):
        Detector(net, start_us=2**63, rotor=False)
    assert Detector(net, start_us=2**62, rotor=False).start_us == 2**62


# -- 8. downsample only reduces ------------------------------------------------------------------


def test_downsample_refuses_a_larger_target() -> None:
    events = np.zeros(3, EVENT_DTYPE)
    events["t"] = [1, 2, 3]
    events["x"] = [0, 100, 239]
    events["y"] = [0, 50, 179]
    rec = Recording(events, (240, 180))
    for target, larger in (
        ((480, 360), "wider and taller"),
        ((241, 90), "wider"),
        ((100, 181), "taller"),
    ):
        with pytest.raises(ParameterError) as refused:
            downsample(rec, target)
        text = str(refused.value)
        w, h = target
        assert f"a 240x180 sensor cannot be downsampled to {w}x{h}" in text
        assert "only reduces" in text and f"{w}x{h} is {larger} than 240x180" in text
    # The same size keeps every event; a smaller one scales down.
    np.testing.assert_array_equal(downsample(rec, (240, 180)).events, events)
    assert downsample(rec, (120, 90)).sensor_size == (120, 90)


# -- 4. the names uavsnn/__init__.py cites -------------------------------------------------------


def test_the_calls_the_package_cites_exist() -> None:
    source = (ROOT / "python" / "uavsnn" / "__init__.py").read_text(encoding="utf-8")
    cited = re.findall(r"uavsnn\.(\w+)\.(\w+)\(", source)
    assert ("sim", "pix2nvs") in cited
    for module, name in cited:
        assert hasattr(getattr(uavsnn, module), name), f"uavsnn.{module}.{name}"


# -- 9. docs/api.md ------------------------------------------------------------------------------


def test_api_md_names_scene_source_and_the_csv_sensor_size() -> None:
    import uavsnn.dataset
    import uavsnn.dataset.synthetic
    from uavsnn.io import FAERY_FALLBACK_SIZE

    api = " ".join((ROOT / "docs" / "api.md").read_text(encoding="utf-8").split())
    assert uavsnn.dataset.SceneSource is uavsnn.dataset.synthetic.SceneSource
    assert not hasattr(uavsnn.scenes, "SceneSource")
    assert re.findall(r"`((?:\w+\.)*)SceneSource\(", api) == ["uavsnn.dataset."]
    # uavsnn.io.read's entry says what a CSV read without sensor_size gets.
    read = api.split("`uavsnn.io.read(path", 1)[1].split("`uavsnn.io.write_npz", 1)[0]
    width, height = FAERY_FALLBACK_SIZE
    assert "CSV" in read and f"{width}×{height}" in read and "FAERY_FALLBACK_SIZE" in read


# -- 10. pyproject's links -----------------------------------------------------------------------


def test_pyproject_links_the_repository() -> None:
    tomllib = pytest.importorskip("tomllib")  # Python 3.11
    repository = tomllib.loads((ROOT / "Cargo.toml").read_text())["package"]["repository"]
    urls = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["urls"]
    assert urls["Homepage"] == urls["Repository"] == repository
    assert urls["Documentation"].startswith(f"{repository}/") and urls["Documentation"].endswith(
        "/docs"
    )
