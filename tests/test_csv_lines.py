"""CSV recordings read alike from a file and from standard input: comment lines (``#``), a
commented header, old Mac line ends (a lone carriage return), a UTF-8 byte-order mark on
standard input."""

from __future__ import annotations

import io as bytes_io
import re
from pathlib import Path

import numpy as np
import pytest

import uavsnn
from uavsnn import io
from uavsnn.sources import StdinSource

SENSOR = (64, 48)
TWO = [(5, 2, 3, True), (6, 4, 5, False)]


def _file(tmp_path: Path, data: bytes) -> list[tuple[int, int, int, bool]]:
    path = tmp_path / "rec.csv"
    path.write_bytes(data)
    return io.read(path, sensor_size=SENSOR).events.tolist()


class _Trickle:
    """A stream that hands out ``size`` bytes a read (a pipe that a slow producer fills)."""

    def __init__(self, data: bytes, size: int) -> None:
        self._data, self._size = data, size

    def read1(self, n: int) -> bytes:
        out, self._data = self._data[: min(n, self._size)], self._data[min(n, self._size) :]
        return out


def _stdin(data: bytes, size: int | None = None) -> tuple[list[tuple[int, int, int, bool]], int]:
    stream = bytes_io.BytesIO(data) if size is None else _Trickle(data, size)
    src = StdinSource(stream, fmt="csv", sensor_size=SENSOR)  # type: ignore[arg-type]
    chunks = [chunk for chunk in src if len(chunk)]
    events = np.concatenate(chunks).tolist() if chunks else []
    return events, src.stats.dropped


# -- 1. comment lines ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "text",
    [
        "# recorded 2026-01-01\n5,2,3,1\n6,4,5,0\n",
        "# recorded 2026-01-01\nt,x,y,p\n5,2,3,1\n6,4,5,0\n",  # the header after a comment
        "# recorded 2026-01-01\n# by a DAVIS\n\nx,y,t,p\n2,3,5,1\n4,5,6,0\n",
        "# t,x,y,p\n5,2,3,1\n6,4,5,0\n",  # a commented header (np.savetxt writes them)
        "# x,y,t,p\n2,3,5,1\n4,5,6,0\n",  # ... naming the columns in another order
        "#x,y,t,p\n2,3,5,1\n4,5,6,-1\n",
        "# note\n# x,y,t,p\n\n2,3,5,1\n4,5,6,0\n",
        "# y,x,p,t\nx,y,t,p\n2,3,5,1\n4,5,6,0\n",  # a header, not a comment, names them
        "\ufeff# recorded\nt,x,y,p\n5,2,3,1\n6,4,5,0\n",
        "\ufeff# x,y,t,p\n2,3,5,1\n4,5,6,0\n",
        "t,x,y,p\n5,2,3,1\n# 1,2,3,-1 (an OFF written -1, in a comment)\n6,4,5,0\n",
        "5,2,3,1\n  # 0,0,0,0 an earlier time, in a comment\n6,4,5,0\n# the end",
        "# recorded\r\nt,x,y,p\r\n5,2,3,1\r\n# between\r\n6,4,5,0\r\n",
        "5,2,3,1\n# x,y,t,p\n6,4,5,0\n",  # after the first event, only a comment
        "# x,y (names only some columns: a comment)\n5,2,3,1\n6,4,5,0\n",
    ],
)
def test_csv_comment_lines_are_skipped_in_a_file_and_on_standard_input(
    tmp_path: Path, text: str
) -> None:
    # A first line "# recorded ..." was taken as the header: the real header after it was
    # refused as an event line (file) or dropped (standard input).
    assert _file(tmp_path, text.encode()) == TWO
    assert _stdin(text.encode()) == (TWO, 0)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("# a\n# b\n5,1,2,1\n# c\n4,1,2,1\n", "line 5: time 4 is earlier than the time before"),
        ("# a\nt,x,y,p\n# b\n5,1,2,1\n# c\n6,a,2,1\n", "line 6: '6,a,2,1': x 'a' is not"),
        ("# a\n\n# b\n5,1,2,-1\n# c\n6,1,2,0\n", "line 6: an OFF event written 0, .*line 4"),
        ("# a\n# b\n0.5,1,2,1\n", r"line 3: time '0.5' is not an integer"),
    ],
)
def test_csv_comment_lines_keep_the_line_numbers_of_errors(
    tmp_path: Path, text: str, message: str
) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(uavsnn.RecordingFileError, match=f"^{re.escape(str(path))}: {message}"):
        io.read(path, sensor_size=SENSOR)


def test_a_csv_comment_that_faery_would_read_as_an_event_is_refused(tmp_path: Path) -> None:
    # faery skips only the lines it cannot read: with the first column in none the header names,
    # "# 1,6,4,5,0" is an event to it. Standard input skips it.
    text = "# 9,9,9,9,1 (faery's header line: skipped)\nidx,t,x,y,p\n0,5,2,3,1\n# 1,6,4,5,0\n"
    path = tmp_path / "rec.csv"
    path.write_text(text)
    with pytest.raises(uavsnn.RecordingFileError, match="line 4: the comment '# 1,6,4,5,0' reads"):
        io.read(path, sensor_size=SENSOR)
    assert _stdin(text.encode()) == ([(5, 2, 3, True)], 0)
    path.write_text(text.replace("# 1,6,4,5,0", "# 1,6,4,5"))
    assert io.read(path, sensor_size=SENSOR).events.tolist() == [(5, 2, 3, True)]


# -- 2. lone carriage returns ------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "line"),
    [
        ("5,2,3,1\r6,4,5,0\r", 1),  # old Mac line ends throughout
        ("t,x,y,p\r5,2,3,1\r6,4,5,0\r", 1),
        ("t,x,y,p\n5,2,3,1\n6,4,5,0\r7,4,5,0\n", 3),  # one inside a file
        ("t,x,y,p\r\n5,2,3,1\r\n6,4\r,5,0\r\n", 3),
        ("5,2,3,1\r" * 2000, 1),  # longer than a CSV line may be: not refused as one
    ],
)
def test_csv_lone_carriage_returns_in_a_file_are_refused_naming_the_line(
    tmp_path: Path, text: str, line: int
) -> None:
    # They gave "cannot decode as csv: 0 events read from its 2 event lines", no line.
    path = tmp_path / "mac.csv"
    path.write_bytes(text.encode())
    with pytest.raises(
        uavsnn.RecordingFileError, match=f"^{re.escape(str(path))}: line {line}: .*carriage return"
    ):
        io.read(path, sensor_size=SENSOR)


def test_csv_carriage_returns_at_the_end_of_a_file_or_before_a_newline_are_read(
    tmp_path: Path,
) -> None:
    assert _file(tmp_path, b"5,2,3,1\r\n6,4,5,0\r") == TWO
    assert _file(tmp_path, b"5,2,3,1\r\n6,4,5,0\r\n") == TWO


@pytest.mark.parametrize("size", [None, 7, 1])
def test_csv_lone_carriage_returns_on_standard_input_end_lines(size: int | None) -> None:
    # A stream with old Mac line ends was read whole as one line: past 4,096 bytes it was
    # dropped as too long, every event with it.
    lines = [(t, t % 64, t % 48, t % 2 == 1) for t in range(1, 1001)]
    data = "".join(f"{t},{x},{y},{int(p)}\r" for t, x, y, p in lines).encode()
    assert _stdin(b"t,x,y,p\r" + data, size) == (lines, 0)
    assert _stdin(b"5,2,3,1\r\n6,4,5,0\r\n", size) == (TWO, 0)


# -- 3. a byte-order mark on standard input -----------------------------------------------------


@pytest.mark.parametrize(
    "text",
    [
        "\ufeffx,y,t,p\n2,3,5,1\n4,5,6,0\n",  # refused: the mark was read as part of "x"
        "\ufeff5,2,3,1\n6,4,5,0\n",  # the first event was taken as a header
        "\ufefft,x,y,p\n5,2,3,1\n6,4,5,0\n",
        "\ufeff\nx,y,t,p\n2,3,5,1\n4,5,6,0\n",
    ],
)
@pytest.mark.parametrize("size", [None, 1, 2])
def test_a_byte_order_mark_on_standard_input_is_read_as_a_files(
    tmp_path: Path, text: str, size: int | None
) -> None:
    assert _file(tmp_path, text.encode()) == TWO
    assert _stdin(text.encode(), size) == (TWO, 0)


def test_a_byte_order_mark_alone_on_standard_input_holds_no_event() -> None:
    with pytest.raises(uavsnn.StreamError, match="no usable csv event"):
        _stdin("\ufeff".encode())
