"""One progress rule for every long command (``train``, ``dataset build``, ``demo``,
``reproduce``, ``simulate``, ``bench``):

- on a terminal (standard error is a TTY): a tqdm bar, redrawn in place;
- piped or redirected: a plain line on standard error when the work starts, then at most every
  :data:`EVERY_S` seconds, and one when it ends (no carriage returns: a log file holds them);
- ``--quiet``: nothing.

Library functions take ``progress=True`` for this rule (or a callable of their own, or
``False``); :func:`bar` is the one place that chooses between the two forms.
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO

__all__ = ["EVERY_S", "LineProgress", "bar", "stop"]

#: Seconds between two plain progress lines when standard error is not a terminal.
EVERY_S = 10.0


class LineProgress:
    """The piped form of a progress bar: the part of tqdm's interface uavsnn uses, writing
    ``desc: n/total unit [postfix] (elapsed)`` lines instead of redrawing."""

    def __init__(
        self,
        total: int | None = None,
        desc: str = "",
        unit: str = "",
        *,
        stream: TextIO | None = None,
        every: float = EVERY_S,
        clock: Any = time.monotonic,
    ) -> None:
        self.total = total
        self.desc = desc
        self.unit = unit.strip()
        self.n = 0
        self.postfix = ""
        self.stream = stream if stream is not None else sys.stderr
        self.every = every
        self.clock = clock
        self.start = self.last = clock()
        self.closed = False
        self._line()  # at once: a piped run says what it is doing before the first interval

    def update(self, k: int = 1) -> None:
        self.n += k
        now = self.clock()
        if now - self.last >= self.every:
            self.last = now
            self._line()

    def set_description_str(self, desc: str, refresh: bool = True) -> None:
        self.desc = desc

    def set_postfix_str(self, postfix: str, refresh: bool = True) -> None:
        self.postfix = postfix

    def close(self, done: bool = True) -> None:
        """The last line, ending in "done"; none when the work stopped before its end
        (``done=False``)."""
        if not self.closed:
            self.closed = True
            if done:
                self._line(done=True)

    def _line(self, done: bool = False) -> None:
        if not self.total and not self.n and not done:
            # Nothing counted of an unknown total: "0 steps" would read as no work to do.
            self._print(f"{self.desc}: started")
            return
        count = f"{self.n}/{self.total}" if self.total else f"{self.n}"
        # The unit as tqdm takes it, in the singular ("step/s"); counted here, its plural.
        shown = self.total if self.total else self.n
        unit = f" {_plural(self.unit) if shown != 1 else self.unit}" if self.unit else ""
        post = f" [{self.postfix}]" if self.postfix else ""
        state = " done" if done else ""
        self._print(f"{self.desc}: {count}{unit}{post} ({self.clock() - self.start:.0f} s){state}")

    def _print(self, line: str) -> None:
        try:
            print(line, file=self.stream, flush=True)
        except (OSError, ValueError):
            # The reader went away (a closed pipe: BrokenPipeError, or on Windows EINVAL), or
            # the stream closed: a progress line is never worth stopping the work for.
            pass


def _plural(noun: str) -> str:
    """``noun``'s plural: ``"steps"``, ``"densities"``, ``"windows"``."""
    if noun.endswith("y") and noun[-2:-1] not in ("a", "e", "i", "o", "u"):
        return noun[:-1] + "ies"
    return noun + "s"


def stop(progress: Any) -> None:
    """Close a :func:`bar` whose work stopped before its end (an interruption, an error): a
    :class:`LineProgress` without its "done" line; tqdm's bar as it closes."""
    if isinstance(progress, LineProgress):
        progress.close(done=False)
    else:
        progress.close()


def bar(total: int | None = None, desc: str = "", unit: str = "", **kwargs: Any) -> Any:
    """A progress bar following the rule of this module: tqdm when standard error is a
    terminal, else a :class:`LineProgress`."""
    stream = sys.stderr
    if stream.isatty():
        from tqdm import tqdm

        return tqdm(total=total, desc=desc, unit=unit, file=stream, **kwargs)
    return LineProgress(total, desc, unit, stream=stream)
