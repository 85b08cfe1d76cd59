"""The Python face of an engine object whose state changes as it is fed."""

from __future__ import annotations

from typing import Any, NoReturn, SupportsIndex


class EngineState:
    """A face of an engine object whose state changes as it is fed and cannot be copied:
    ``copy.copy`` would share the engine's state (feeding the copy would change the
    original), and the engine cannot copy it, so ``copy.copy``, ``copy.deepcopy`` and
    ``pickle`` all raise a ``TypeError`` saying what to do instead (:attr:`_remake`)."""

    #: What to do instead of a copy, the end of the ``TypeError``'s message.
    _remake = ""

    def _refuse_copy(self) -> NoReturn:
        name = type(self).__name__
        instead = self._remake or f"make a new one with {name}(...) and feed it the same input"
        raise TypeError(
            f"a uavsnn.{name} cannot be copied or pickled: its state lives in the engine, and "
            f"a copy would share it; {instead}"
        )

    def __copy__(self) -> NoReturn:
        self._refuse_copy()

    def __deepcopy__(self, memo: dict[int, Any]) -> NoReturn:
        self._refuse_copy()

    def __reduce_ex__(self, protocol: SupportsIndex) -> NoReturn:
        self._refuse_copy()
