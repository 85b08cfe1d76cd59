"""The columns of a CSV event line: ``t,x,y,p`` by default, or in the order a header names
them. Shared by :func:`uavsnn.io.read` (CSV files) and standard input's ``csv`` format."""

from __future__ import annotations

from uavsnn.errors import RecordingFileError

__all__ = ["COLUMN_NAMES", "DEFAULT_COLUMNS", "columns"]

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

    Raises:
        RecordingFileError: the header names a field in another column than the default order
            gives it without naming all four once each: read in the default order, its events
            would be wrong. The message quotes the header, not its file or line;
            :class:`~uavsnn.sources.StdinSource` raises it as a ``StreamError``.
    """
    names = [name.strip().strip(b"\"'").decode("latin-1").lower() for name in header.split(b",")]
    found = {
        field: [i for i, name in enumerate(names) if name in synonyms]
        for field, synonyms in COLUMN_NAMES.items()
    }
    if all(len(at) == 1 for at in found.values()):
        return {field: at[0] for field, at in found.items()}
    moved = sorted(
        (i, field) for field, at in found.items() for i in at if i != DEFAULT_COLUMNS[field]
    )
    if moved:
        text = header.strip().decode("latin-1")
        if len(text) > _QUOTED:
            text = text[: _QUOTED - 3] + "..."
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
