"""The columns of a CSV event line: ``t,x,y,p`` by default, or in the order a header names
them. Shared by :func:`uavsnn.io.read` (CSV files) and standard input's ``csv`` format."""

from __future__ import annotations

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


def columns(header: bytes) -> dict[str, int]:
    """The column of each field that a header line names, when it names all four once each;
    else :data:`DEFAULT_COLUMNS`."""
    names = [name.strip().strip(b"\"'").decode("latin-1").lower() for name in header.split(b",")]
    found = {
        field: [i for i, name in enumerate(names) if name in synonyms]
        for field, synonyms in COLUMN_NAMES.items()
    }
    if all(len(at) == 1 for at in found.values()):
        return {field: at[0] for field, at in found.items()}
    return dict(DEFAULT_COLUMNS)
