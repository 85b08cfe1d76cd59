"""The commands' JSON (``--json``, ``results.json``) is strict JSON: a figure that is not
defined is ``null``, never the bare word ``NaN`` Python's ``json`` writes, which ``JSON.parse``,
``jq`` and most parsers outside Python refuse (the whole document with it)."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from uavsnn import _jsonout
from uavsnn.cli import main
from uavsnn.dataset import SceneSource, build, load
from uavsnn.dataset.format import read_manifest, save_split, write_manifest
from uavsnn.network import Network

SENSOR = (240, 180)


def _strict(text: str) -> object:
    def refuse(word: str) -> None:
        raise ValueError(f"not JSON: {word}")

    return json.loads(text, parse_constant=refuse)


def test_numbers_that_are_not_finite_are_written_as_null() -> None:
    value = {"a": math.nan, "b": [1.5, -math.inf, (math.inf, 2)], "c": {"d": np.float64("nan")}}
    text = _jsonout.dumps(value, indent=2)
    assert _strict(text) == {"a": None, "b": [1.5, None, [None, 2]], "c": {"d": None}}
    assert _jsonout.dumps({"x": 0.1, "n": 3, "s": "NaN", "t": True}) == (
        '{"x": 0.1, "n": 3, "s": "NaN", "t": true}'
    )


@pytest.fixture(scope="module")
def silent(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A dataset whose test windows hold no input spike: its speed per event is not defined."""
    root = tmp_path_factory.mktemp("data") / "set"
    build(root, "dvs", n_test=4, n_train=0, seed=3, dvs=SceneSource("dvs", SENSOR, 200.0, 0.3))
    data = load(root, "test")
    n = len(data.windows.t0)
    empty = dataclasses.replace(
        data.windows,
        offsets=np.zeros(n + 1, np.int64),
        t=np.zeros(0, np.uint64),
        x=np.zeros(0, np.uint16),
        y=np.zeros(0, np.uint16),
    )
    save_split(root / "test.npz", dataclasses.replace(data, windows=empty))
    write_manifest(root, read_manifest(root))
    return root


def test_evaluate_json_of_windows_without_an_event_is_strict(
    silent: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # "ns_per_event": NaN made the whole document unreadable to a strict parser.
    model = tmp_path / "m.npz"
    Network({"width": SENSOR[0], "height": SENSOR[1]}, seed=3).save(model)
    assert main(["evaluate", str(model), str(silent), "--json"]) == 0
    figures = _strict(capsys.readouterr().out)
    assert isinstance(figures, dict) and figures["ns_per_event"] is None


def test_every_json_document_names_the_version_that_wrote_it(
    silent: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A program reading `--json` could not tell which layout it held (results.json named its
    uavsnn, the commands' documents did not): each document leads with ``"uavsnn"``."""
    from uavsnn import __version__

    model = tmp_path / "m.npz"
    Network({"width": SENSOR[0], "height": SENSOR[1]}, seed=3).save(model)
    for argv in (
        ["evaluate", str(model), str(silent), "--json"],
        ["info", str(model), "--json"],
    ):
        assert main(argv) == 0
        document = _strict(capsys.readouterr().out)
        assert isinstance(document, dict)
        assert next(iter(document.items())) == ("uavsnn", __version__), argv
    assert _jsonout.document({"a": 1}, indent=None) == f'{{"uavsnn": "{__version__}", "a": 1}}'
