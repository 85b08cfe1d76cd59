"""What the docs and the help say the command line does, held to it: a CSV header naming some
columns out of the default order is refused rather than read in that order (api.md
``uavsnn.io.read``, streaming.md "Sources"); standard input that ends without a usable event is
an error (streaming.md "Bad input"); ``evaluate --seed`` without the noise it seeds is refused as
the other options without their partner are; ``train --windows-per-layer`` says a layer may see
a few more windows than asked."""

from __future__ import annotations

import io
import sys
from pathlib import Path
from typing import Any

import pytest
from conftest import SMALL_SENSOR, random_events, small_config
from conftest import one_line_exit_2 as _one_line_exit_2

import uavsnn.cli.evaluate
from uavsnn import io as uio
from uavsnn.cli import main
from uavsnn.errors import RecordingFileError, StreamError
from uavsnn.network import Network
from uavsnn.sources import StdinSource


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("model") / "model.npz"
    Network(small_config(), seed=3).save(path)
    return path


def _stdin(monkeypatch: pytest.MonkeyPatch, data: bytes) -> None:
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(data)))


def _detect_exit_2(capsys: pytest.CaptureFixture[str], argv: list[str], match: str) -> str:
    """Run ``uavsnn detect``: it must exit 2 with one error line that contains ``match``, after
    at most the note that the test model has no identification."""
    assert main(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert all("note: " in line for line in lines[:-1]) and len(lines) <= 2, lines
    assert "uavsnn detect: error: " in lines[-1] and match in lines[-1], lines[-1]
    return lines[-1]


# -- 1. a CSV header naming some columns where the default order does not put them --------------

#: Headers naming a column where the default order t,x,y,p does not put it, without naming all
#: four once each, and what the refusal says of them.
MISPLACED = [
    ("pos_x,pos_y,time,on", "names t as column 3 ('time'), not where the default order"),
    ("x,y,t", "names x as column 1, y as column 2 and t as column 3, not where"),
    ("Time,Y,X,brightness", "names y as column 2 and x as column 3, not where"),
    ("t,x,y,p,timestamp", "names t as column 5 ('timestamp'), not where"),
]


def _events_of(header: str) -> str:
    """Two events (t=5 at 2,3 ON; t=6 at 4,5 OFF) in the columns ``header`` names, the others in
    the default order's place, so that any wrong reading shows."""
    names = [n.strip().lower() for n in header.split(",")]
    rows = []
    for t, x, y, p in ((5, 2, 3, 1), (6, 4, 5, 0)):
        by = {"t": t, "x": x, "y": y, "p": p}
        aliases = {"time": "t", "timestamp": "t", "on": "p", "polarity": "p", "t_us": "t"}
        row = [str(by.get(aliases.get(n, n), 9)) for n in names]
        rows.append(",".join(row))
    return "\n".join([header, *rows]) + "\n"


@pytest.mark.parametrize(("header", "says"), MISPLACED)
def test_a_csv_file_header_naming_columns_out_of_the_default_order_is_refused(
    header: str, says: str, tmp_path: Path
) -> None:
    # 'pos_x,pos_y,time,on' was read as t,x,y,p: t=5, x=6, y=100, silently wrong events.
    path = tmp_path / "rec.csv"
    path.write_text(_events_of(header))
    with pytest.raises(RecordingFileError) as caught:
        uio.read(path, sensor_size=(64, 48))
    message = str(caught.value)
    assert says in message and f"the CSV header {header!r}" in message
    assert "name t, x, y and p in the header" in message and "drop the header" in message
    assert message.startswith(f"{path}: line 1: ") and "\n" not in message
    # after blank lines, the header's own line is named
    path.write_text("\n\n" + _events_of(header))
    with pytest.raises(RecordingFileError, match=r": line 3: the CSV header"):
        uio.read(path, sensor_size=(64, 48))


@pytest.mark.parametrize(
    "text",
    [
        # All four named, any alias, any case, _us on the time: read in the header's order.
        "x,y,t,p\n2,3,5,1\n4,5,6,0\n",
        "Y, Polarity, X, TIMESTAMP_US, extra\n3,1,2,5,9\n5,0,4,6,9\n",
        "'on',\"ts\",x,y\n1,5,2,3\n0,6,4,5\n",
        # None named, or fewer named where the default order has them: the default order.
        "foo,bar,baz,qux\n5,2,3,1\n6,4,5,0\n",
        "time,x,y,brightness\n5,2,3,1\n6,4,5,0\n",
        "t_us,x\n5,2,3,1\n6,4,5,0\n",
        ",,,polarity\n5,2,3,1\n6,4,5,0\n",
    ],
)
def test_csv_headers_that_say_where_the_columns_are_are_read_as_before(
    text: str, tmp_path: Path
) -> None:
    path = tmp_path / "rec.csv"
    path.write_text(text)
    assert uio.read(path, sensor_size=(64, 48)).events.tolist() == [
        (5, 2, 3, True),
        (6, 4, 5, False),
    ]
    source = StdinSource(io.BytesIO(text.encode()), fmt="csv", sensor_size=(64, 48))
    assert [e for chunk in source for e in chunk.tolist()] == [(5, 2, 3, True), (6, 4, 5, False)]


@pytest.mark.parametrize(("header", "says"), MISPLACED)
def test_a_stdin_csv_header_naming_columns_out_of_the_default_order_is_refused(
    header: str,
    says: str,
    model: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    text = _events_of(header).encode()
    with pytest.raises(StreamError, match=r"^standard input: the CSV header"):
        list(StdinSource(io.BytesIO(text), fmt="csv", sensor_size=SMALL_SENSOR))
    _stdin(monkeypatch, text)
    argv = ["detect", "-", "-m", str(model), "--stdin-format", "csv", "--summary-every", "0"]
    line = _detect_exit_2(capsys, argv, "standard input: the CSV header")
    assert says in line and "drop the header" in line


def test_a_stdin_csv_header_in_the_default_order_or_naming_all_four_still_works(
    model: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    events = random_events(300, SMALL_SENSOR)
    argv = ["detect", "-", "-m", str(model), "--stdin-format", "csv", "--summary-every", "0"]
    for header, row in (
        ("time,x,y,brightness", "{t},{x},{y},{p}"),
        ("Y,X,ON,T_US", "{y},{x},{p},{t}"),
    ):
        lines = [header] + [row.format(t=e["t"], x=e["x"], y=e["y"], p=int(e["p"])) for e in events]
        _stdin(monkeypatch, "\n".join(lines).encode())
        assert main(argv) == 0
        err = capsys.readouterr().err
        assert "events=300" in err and "dropped=0" in err, err


# -- 2. standard input that ends without one usable event ----------------------------------------


@pytest.mark.parametrize(
    ("fmt", "data", "dropped"),
    [
        ("packed", b"", 0),
        ("csv", b"", 0),
        ("csv", b"garbage\n", 0),  # taken as a header
        ("csv", b"t,x,y,p\n", 0),  # a header alone
        ("csv", b"\n\nt,x,y,p\n\n", 0),
        ("csv", b"1,500,1,1\n", 1),  # off the sensor: the message it gave already
        ("packed", b"\x00" * 5, 1),  # a truncated record
    ],
)
def test_detect_on_stdin_without_a_usable_event_exits_2(
    fmt: str,
    data: bytes,
    dropped: int,
    model: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # An empty stream, or one of a header alone, exited 0 as if it had been read.
    says = f"standard input held no usable {fmt} event ({dropped} dropped)"
    with pytest.raises(StreamError, match=r"--stdin-format"):
        list(StdinSource(io.BytesIO(data), fmt=fmt, sensor_size=SMALL_SENSOR))
    _stdin(monkeypatch, data)
    argv = ["detect", "-", "-m", str(model), "--stdin-format", fmt, "--summary-every", "0"]
    line = _detect_exit_2(capsys, argv, says)
    assert "is --stdin-format right" in line


# -- 3. evaluate --seed without the noise it seeds ----------------------------------------------


class _Reached(Exception):
    """Raised where evaluate starts its work, once its options are accepted."""


class _NoModel:
    @staticmethod
    def load(*_args: Any, **_kwargs: Any) -> None:
        raise _Reached


@pytest.mark.parametrize(
    "extra",
    [[], ["--tracks"], ["--clips"], ["--json", "--unbalanced"], ["--seed", "0"]],
)
def test_evaluate_refuses_a_seed_nothing_uses(
    extra: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # It was accepted and ignored ("seed of the added noise"), while every other option without
    # its partner is refused.
    argv = ["evaluate", str(tmp_path / "m.npz"), str(tmp_path / "ds"), "--seed", "5", *extra]
    line = _one_line_exit_2(capsys, argv, "--seed")
    assert "give --noise or --report" in line


def test_evaluate_takes_a_seed_with_the_noise_it_seeds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(uavsnn.cli.evaluate, "Network", _NoModel)
    argv = ["evaluate", str(tmp_path / "m.npz"), str(tmp_path / "ds")]
    for extra in (
        ["--noise", "--seed", "5"],
        ["--report", str(tmp_path / "report"), "--seed", "5"],
        ["--noise"],
        [],
    ):
        with pytest.raises(_Reached):
            main([*argv, *extra])
    _one_line_exit_2(capsys, [*argv, "--noise", "--seed", "-1"], "--seed must be >= 0")


# -- 4. train --windows-per-layer: at least that many --------------------------------------------


def test_train_help_says_a_layer_may_see_a_few_more_windows(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # A layer stops at its first progress report at or past the count (20 asked, 21 seen).
    with pytest.raises(SystemExit) as done:
        main(["train", "--help"])
    assert done.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "--windows-per-layer WINDOWS_PER_LAYER at least this many windows each layer" in text
    assert "may see a few more" in text
