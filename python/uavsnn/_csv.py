"""CSV recordings: the columns of an event line (``t,x,y,p`` by default, or in the order a
header names them), shared by :func:`uavsnn.io.read` (CSV files) and standard input's ``csv``
format; and a CSV file's check before faery reads it (:func:`check_file`, the layout faery is
told) and, when faery skipped a line, which line and why (:func:`bad_line`).

Both read a line whose first character that is not white space is ``#`` as a comment, skipped
wherever it is; the header, if any, is the first line that is neither blank nor a comment and
does not start with a number. A header names its columns (each field a name, or empty: see
:func:`columns`); a first line that is neither an event line nor a header (numbers separated by
tabs or semicolons, quoted numbers, a ``nan`` time) is refused, not dropped as a header. With
no header, a comment before the first event that names all four columns once each
(``# t,x,y,p``, as ``np.savetxt`` writes a header; ``# x,y,t,p``) names them. A UTF-8
byte-order mark at the start is dropped. faery ends lines only at ``\n``: a file with a
carriage return not followed by one (old Mac line ends) is refused, naming the line; standard
input ends a line at either."""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn._validate import MAX_TIME_US
from uavsnn.errors import RecordingFileError
from uavsnn.events import EVENT_DTYPE

__all__ = [
    "BOM",
    "COLUMN_NAMES",
    "CSV_MAX_LINE",
    "DEFAULT_COLUMNS",
    "CsvLayout",
    "bad_line",
    "check_file",
    "columns",
    "comment_columns",
    "is_comment",
    "is_number",
]

#: The names a CSV header may give each field (any case; quotes and spaces around are
#: ignored; ``_us`` allowed on the time).
COLUMN_NAMES = {
    "t": ("t", "ts", "time", "timestamp", "t_us", "ts_us", "time_us", "timestamp_us"),
    "x": ("x",),
    "y": ("y",),
    "p": ("p", "pol", "polarity", "on"),
}
#: The column of each field without a header that names them.
DEFAULT_COLUMNS = {"t": 0, "x": 1, "y": 2, "p": 3}

#: The most characters of a refused header its message quotes.
_QUOTED = 80


def columns(header: bytes) -> dict[str, int]:
    """The column of each field that a header line names, when it names all four once each;
    else :data:`DEFAULT_COLUMNS`, when every field it names is where the default order has it
    (a header naming none of them, or ``time,x,y,brightness``).

    A header names its columns: each of its fields, quotes and spaces around dropped, is empty
    or a name (it holds a letter and is not a number: ``nan``, ``inf`` and ``1e5`` are not
    names). A first line that is not an event line and not a header (numbers separated by
    tabs or semicolons, quoted numbers, a ``nan`` time) is refused, so that no event is taken
    for a header and dropped.

    Raises:
        RecordingFileError: a field of the line is not a name; or the header names a field in
            another column than the default order gives it without naming all four once each:
            read in the default order, its events would be wrong. The message quotes the
            header, not its file or line; :class:`~uavsnn.sources.StdinSource` raises it as a
            ``StreamError``.
    """
    _check_names(header)
    names, found = _names(header)
    if all(len(at) == 1 for at in found.values()):
        return {field: at[0] for field, at in found.items()}
    moved = sorted(
        (i, field) for field, at in found.items() for i in at if i != DEFAULT_COLUMNS[field]
    )
    if moved:
        text = _quoted(header)
        said = [
            f"{field} as column {i + 1}" + ("" if names[i] == field else f" ({names[i]!r})")
            for i, field in moved
        ]
        where = said[0] if len(said) == 1 else f"{', '.join(said[:-1])} and {said[-1]}"
        raise RecordingFileError(
            f"the CSV header {text!r} names {where}, not where the default order t,x,y,p has "
            f"{'it' if len(said) == 1 else 'them'}, and does not name all four columns once "
            "each: name t, x, y and p in the header (any order), or drop the header to read "
            "the columns as t,x,y,p"
        )
    return dict(DEFAULT_COLUMNS)


def _check_names(header: bytes) -> None:
    """Refuse a header line with a field that is not a column name (:func:`columns`)."""
    fields = [field.strip().strip(b"\"'").strip() for field in header.split(b",")]
    for i, field in enumerate(fields):
        if field and not (_LETTER.search(field) and not _NUMBER_WORD.fullmatch(field)):
            text = _quoted(header)
            what = field.decode("latin-1")
            if len(what) > 40:
                what = what[:37] + "..."
            raise RecordingFileError(
                f"{text!r} is neither an event line t,x,y,p (integers separated by commas, "
                f"unquoted) nor a header naming its columns: its field {i + 1} ({what!r}) is "
                "not a column name"
            )


def _quoted(header: bytes) -> str:
    """A header line for a message, cut to :data:`_QUOTED` characters."""
    text = header.strip().decode("latin-1")
    return text if len(text) <= _QUOTED else text[: _QUOTED - 3] + "..."


def _names(header: bytes) -> tuple[list[str], dict[str, list[int]]]:
    """The names of a header line's columns (lower case, quotes and spaces around dropped),
    and the columns that name each field."""
    names = [name.strip().strip(b"\"'").decode("latin-1").lower() for name in header.split(b",")]
    found = {
        field: [i for i, name in enumerate(names) if name in synonyms]
        for field, synonyms in COLUMN_NAMES.items()
    }
    return names, found


def is_comment(line: bytes) -> bool:
    """Whether a CSV line is a comment: its first character that is not white space is
    ``#``."""
    return line.lstrip()[:1] == b"#"


def comment_columns(comment: bytes) -> dict[str, int] | None:
    """The column of each field that a comment line names as a header would (``# t,x,y,p``,
    as ``np.savetxt`` writes a header), when it names all four once each; else ``None`` (a
    comment that names fewer is only a comment)."""
    _, found = _names(comment.lstrip()[1:])
    if all(len(at) == 1 for at in found.values()):
        return {field: at[0] for field, at in found.items()}
    return None


def is_number(field: bytes) -> bool:
    """Whether a CSV field is a number (a line that starts with one is not a header)."""
    return bool(_NUMBER.fullmatch(field.strip()))


#: The longest line of a CSV recording, in bytes (an event line ``t,x,y,p`` takes at most 40;
#: a header line a few dozen): a longer one is refused, so a file without line breaks is not
#: gathered into memory.
CSV_MAX_LINE = 4096
# The most digits of a CSV time or coordinate (2^62 has 19): a longer field is refused before
# it is parsed (Python refuses to parse more than 4,300 digits, and takes quadratic time below).
_CSV_MAX_DIGITS = 20

# A number that is not a plain integer (a first CSV field like this is a time, not a header).
_NUMBER = re.compile(rb"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
# A letter (non-ASCII bytes, UTF-8 letters, count as one): a header's column names hold one.
_LETTER = re.compile(rb"[A-Za-z\x80-\xff]")
# A field with letters that is a number all the same: not a column name.
_NUMBER_WORD = re.compile(
    rb"[+-]?((\d+\.?\d*|\.\d+)([eE][+-]?\d+)?|nan|inf|infinity)", re.IGNORECASE
)
#: A UTF-8 byte-order mark, dropped from the start of a recording.
BOM = b"\xef\xbb\xbf"
# A carriage return that does not end a line with the newline after it: faery, which splits
# lines at newlines only, would read it inside a line (and old Mac line ends as one line).
_LONE_CR = re.compile(rb"\r(?!\n)")


# What faery strips from a CSV line and from each of its fields (Rust's ``trim_ascii``), and a
# field faery reads as an unsigned integer (Rust's ``parse``: an optional "+", then digits).
_ASCII_SPACE = b" \t\n\x0c\r"
_UNSIGNED = re.compile(rb"\+?[0-9]+")


@dataclass(frozen=True)
class CsvLayout:
    """How a CSV recording is laid out: a header line or not (faery skips the first line), the
    index of each column, the value of an OFF polarity, the event of a first line faery cannot
    read, the number of the header line (0: none), and how many events faery is to read (one a
    line, blank lines, the header and the first line's event read here aside)."""

    has_header: bool = False
    t: int = 0
    x: int = 1
    y: int = 2
    p: int = 3
    off: bytes = b"0"
    first_event: np.ndarray | None = None
    header: int = 0
    events: int = 0

    def properties(self, faery: Any) -> Any:
        """faery's ``CsvProperties`` for this layout. faery is told to skip the lines it cannot
        read, as it cannot read a blank line: a line skipped otherwise leaves it fewer events
        than :attr:`events`, which the reader refuses (:func:`bad_line`)."""
        props = vars(faery.CsvProperties.default()) | {
            "has_header": self.has_header,
            "t_index": self.t,
            "x_index": self.x,
            "y_index": self.y,
            "on_index": self.p,
            "off_value": self.off,
            "skip_errors": True,
        }
        return faery.CsvProperties(**props)


def _blocks(file: Path) -> Iterator[tuple[list[bytes], dict[int, bytes]]]:
    """The lines of a CSV recording, a UTF-8 byte-order mark dropped, in blocks of about 4 MiB,
    each comment line (:func:`is_comment`) blank in its place, and the block's comment lines by
    their index in it. A line longer than :data:`CSV_MAX_LINE` is refused, so that a file
    without line breaks is not gathered into memory; so is a carriage return that no newline
    follows (but at the end of the file), which faery would read inside a line."""
    line_no = 0
    rest = b""
    with open(file, "rb") as handle:
        if handle.read(len(BOM)) != BOM:
            handle.seek(0)
        while True:
            block = handle.read(1 << 22)
            data = rest + block
            lone = _LONE_CR.search(data) if b"\r" in data else None
            # (A last one may be the first half of a "\r\n", or ends the file.)
            if lone is not None and lone.start() < len(data) - 1:
                where = line_no + data.count(b"\n", 0, lone.start()) + 1
                raise RecordingFileError(
                    f"{file}: line {where}: a carriage return (\\r) that no newline follows: "
                    "lines must end in \\n or \\r\\n (old Mac line ends, \\r alone, are not "
                    "read: convert them, e.g. with tr '\\r' '\\n')"
                )
            if len(rest) > CSV_MAX_LINE:
                raise RecordingFileError(
                    f"{file}: line {line_no + 1} is longer than {CSV_MAX_LINE:,} bytes: not a "
                    "CSV event line (t,x,y,p)"
                )
            cut = len(data) if not block else data.rfind(b"\n") + 1
            text, rest = data[:cut], data[cut:]
            lines = text.splitlines()
            comments: dict[int, bytes] = {}
            if b"#" in text:
                comments = {k: line for k, line in enumerate(lines) if is_comment(line)}
                for k in comments:
                    lines[k] = b""
            yield lines, comments
            line_no += len(lines)
            if not block:
                return


def check_file(file: Path) -> CsvLayout:
    """How a CSV recording is laid out (:class:`CsvLayout`): whether it has a header line (its
    first line that is neither blank nor a comment), and if the header names the columns (or,
    without one, a comment before the first event names all four: :func:`comment_columns`),
    which is which;
    whether its OFF events are ``0`` or ``-1``; the event of its first line when faery cannot
    read it (a data line behind a UTF-8 byte-order mark, which faery would take as part of the
    time; faery is then told to skip it as a header); and how many events faery is to read.
    Refuse a first line whose time is a number but not an integer (it is not a header), one
    that is neither an event line nor a header naming its columns (:func:`columns`), times
    beyond the engine's 2^62 µs, times that go backwards (faery would clamp them to the time
    before, silently), and OFF events written both as ``0`` and ``-1``, naming the line.

    Comment lines are skipped as blank lines are (faery cannot read them as events either);
    one that faery could read as an event (the header's columns leave the first field unread)
    is refused. Lines are read in blocks.
    """
    has_header = False
    at = dict(DEFAULT_COLUMNS)  # the column of each field
    with open(file, "rb") as handle:
        bom = handle.read(len(BOM)) == BOM
    bom_line = None  # the line behind a byte-order mark, when it is an event
    header = 0
    text_seen = False  # a line that is not blank was seen (the first may be the header)
    blank = 0
    previous = -1
    line_no = 0
    commented: dict[str, int] | None = None  # the columns a comment before any text names
    any_comment = False
    # The first line of an OFF event written 0, and of one written -1.
    off_lines: dict[bytes, int] = {}
    for lines, comments in _blocks(file):
        start = 0  # the block's first line after the header
        any_comment = any_comment or bool(comments)
        if not text_seen:
            k = next((k for k, line in enumerate(lines) if line.strip()), None)
            for i, comment in comments.items():
                if k is None or i < k:
                    commented = comment_columns(comment) or commented
            if k is not None:
                text_seen = True
                head = lines[k].split(b",", 1)[0].strip()
                if not head.lstrip(b"-").isdigit():
                    if _NUMBER.fullmatch(head):
                        raise RecordingFileError(
                            f"{file}: line {line_no + k + 1}: time {head.decode('latin-1')!r} "
                            "is not an integer: times must be integers (microseconds), and a "
                            "first line that starts with a number is not a header"
                        )
                    has_header = True
                    header = line_no + k + 1
                    try:
                        at = columns(lines[k])
                    except RecordingFileError as exc:
                        raise RecordingFileError(f"{file}: line {header}: {exc}") from exc
                    start = k + 1
                else:
                    at = commented or at
                    if bom and line_no + k == 0:
                        bom_line = lines[0]
        # Each line split as it is read (a list kept per line would cost the collector
        # more than the split).
        tc, pc = at["t"], at["p"]
        seen = {
            parts[pc] if len(parts := line.split(b",", pc + 1)) > pc else b""
            for line in lines[start:]
        }
        for value in {v.strip() for v in seen} & {b"0", b"-1"} - off_lines.keys():
            k = next(k for k in range(start, len(lines)) if _field(lines[k], pc) == value)
            off_lines[value] = line_no + k + 1
        if len(off_lines) == 2:
            raise RecordingFileError(
                f"{file}: line {max(off_lines.values())}: an OFF event written "
                f"{'0' if off_lines[b'0'] > off_lines[b'-1'] else '-1'}, after OFF events "
                "written the other way (line "
                f"{min(off_lines.values())}): polarities must be 1/0 or 1/-1 throughout"
            )
        first = [
            parts[tc].strip() if len(parts := line.split(b",", tc + 1)) > tc else b""
            for line in lines
        ]
        if b"" in first:
            blank += sum(1 for i, f in enumerate(first) if not f and not lines[i].strip())
        # Negative or malformed times are left to faery, which refuses them ("+5" it reads).
        numbers = [
            (i, f)
            for i, f in enumerate(first)
            if f.isdigit() or (f[:1] == b"+" and f[1:].isdigit())
        ]
        long = [(i, f) for i, f in numbers if len(f) > _CSV_MAX_DIGITS]
        if long:
            i, f = long[0]
            raise RecordingFileError(
                f"{file}: line {line_no + i + 1}: a time of {len(f):,} digits "
                f"({f[:20].decode()}...) is not a time the detector takes (at most 2^62 = "
                f"{MAX_TIME_US} µs)"
            )
        late = [k for k, (_, f) in enumerate(numbers) if len(f) > 18 and int(f) > MAX_TIME_US]
        if late:
            i, f = numbers[late[0]]
            raise RecordingFileError(
                f"{file}: line {line_no + i + 1}: time {int(f)} is beyond the latest the "
                f"detector takes (2^62 = {MAX_TIME_US} µs)"
            )
        if numbers:
            t = np.array([int(f) for _, f in numbers], dtype=np.int64)
            back = np.flatnonzero(np.diff(t, prepend=previous) < 0)
            if len(back):
                k = int(back[0])
                before = previous if k == 0 else int(t[k - 1])
                raise RecordingFileError(
                    f"{file}: line {line_no + numbers[k][0] + 1}: time {int(t[k])} is "
                    f"earlier than the time before it ({before}); events must be in time "
                    "order"
                )
            previous = int(t[-1])
        line_no += len(lines)
    layout = CsvLayout(
        # faery cannot read the line behind a byte-order mark: it skips it as a header, and
        # its event, if it is not a header, is read here.
        has_header or bom,
        t=at["t"],
        x=at["x"],
        y=at["y"],
        p=at["p"],
        off=b"-1" if b"-1" in off_lines else b"0",
        header=header,
        events=line_no - blank - bool(header) - (bom_line is not None),
    )
    if any_comment and 0 not in at.values():
        _refuse_readable_comments(file, layout)
    if bom_line is None:
        return layout
    return dataclasses.replace(layout, first_event=_event(file, bom_line, layout))


def bad_line(file: Path, layout: CsvLayout, sensor: tuple[int, int], read: int, hint: str) -> str:
    """Why faery read ``read`` events from a CSV recording, not one for each of its event
    lines: the first line that is neither blank nor a comment and that faery cannot read as an
    event (:func:`_fault`), named by its number. ``hint`` is added to an event off the sensor."""
    line_no = 0
    for lines, _ in _blocks(file):
        for line in lines:
            line_no += 1
            if not line.strip() or line_no == layout.header:
                continue
            if line_no == 1 and layout.first_event is not None:
                continue  # read here, not by faery
            text = line.strip(_ASCII_SPACE)
            fields = [field.strip(_ASCII_SPACE) for field in text.split(b",")]
            why = _fault(fields, layout, sensor, hint)
            if why:
                return f"line {line_no}: {text[:80].decode('latin-1')!r}: {why}"
    return f"cannot decode as csv: {read:,} events read from its {layout.events:,} event lines"


def _refuse_readable_comments(file: Path, layout: CsvLayout) -> None:
    """Refuse a comment line that faery would read as an event: one whose first field (the
    ``#``) is in no column the layout reads, whose other fields are an event (faery skips
    only the lines it cannot read, and, with a header, the first)."""
    skipped = 1 if layout.has_header else 0  # faery's header line, whatever it is
    line_no = 0
    for lines, comments in _blocks(file):
        for k, comment in comments.items():
            text = comment.strip(_ASCII_SPACE)
            fields = [field.strip(_ASCII_SPACE) for field in text.split(b",")]
            if line_no + k + 1 != skipped and not _fault(fields, layout, (65536, 65536), ""):
                raise RecordingFileError(
                    f"{file}: line {line_no + k + 1}: the comment {text[:80].decode('latin-1')!r}"
                    " reads as an event in the header's columns (its first column is in none "
                    "of them): remove the comment"
                )
        line_no += len(lines)


def _fault(fields: list[bytes], layout: CsvLayout, sensor: tuple[int, int], hint: str) -> str:
    """Why faery cannot read the fields of a CSV line as an event (``""`` when it can): it
    reads t, x and y as unsigned integers of 64, 16 and 16 bits, p as the ON or the OFF value,
    and refuses an event off the sensor."""
    index_of = {"t": layout.t, "x": layout.x, "y": layout.y, "p": layout.p}
    for name, index in index_of.items():
        if index >= len(fields):
            return f"no {name} (field {index + 1})"
    t, x, y, p = (fields[index] for index in index_of.values())
    if _unsigned(t, 2**64 - 1) is None:
        return f"t {t[:40].decode('latin-1')!r} is not a whole number of µs"
    at = []
    for name, value in (("x", x), ("y", y)):
        number = _unsigned(value, 65535)
        if number is None:
            return f"{name} {value[:40].decode('latin-1')!r} is not an integer from 0 to 65535"
        at.append(number)
    if p not in (b"1", layout.off):
        return f"p {p[:40].decode('latin-1')!r} is neither 1 nor {layout.off.decode()}"
    width, height = sensor
    if at[0] >= width or at[1] >= height:
        return f"x={at[0]}, y={at[1]} is off the {width}x{height} sensor{hint}"
    return ""


def _unsigned(field: bytes, top: int) -> int | None:
    """The value of a CSV field as faery reads an unsigned integer (an optional "+", then
    digits: Rust's ``parse``), ``None`` when it is not one or above ``top``."""
    if not _UNSIGNED.fullmatch(field):
        return None
    digits = field.lstrip(b"+").lstrip(b"0") or b"0"
    return int(digits) if len(digits) <= 20 and int(digits) <= top else None


def _field(line: bytes, index: int) -> bytes:
    """Field ``index`` of a CSV line, stripped; empty where the line has fewer."""
    fields = line.split(b",", index + 1)
    return fields[index].strip() if index < len(fields) else b""


def _event(file: Path, line: bytes, layout: CsvLayout) -> np.ndarray:
    """The event of one CSV line laid out as ``layout`` says (``p`` 1 or the OFF value)."""
    t, x, y, p = (_field(line, i) for i in (layout.t, layout.x, layout.y, layout.p))
    if not (
        all(part.isdigit() and len(part) <= _CSV_MAX_DIGITS for part in (t, x, y))
        and max(int(x), int(y)) < 65536
        and p in (b"1", layout.off)
    ):
        raise RecordingFileError(f"{file}: line 1: not an event t,x,y,p: {line[:80]!r}")
    event = np.zeros(1, EVENT_DTYPE)
    event[0] = (int(t), int(x), int(y), p == b"1")
    return event
