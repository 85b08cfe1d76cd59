"""A :class:`~uavsnn.network.Network`'s use from threads, and its memory check.

- :class:`Use`: a call on a network while :meth:`~uavsnn.network.Network.train_layer` may run
  (refused from another thread, as the engine refuses a call that meets another's);
  :func:`training` holds the network for the thread that trains it, between the engine's
  chunks too; :func:`init_guard` gives a network the state both share.
- :func:`check_memory`: window states that would not fit in ``uavsnn.windows.MEMORY_LIMIT``,
  refused before the engine allocates them.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

from uavsnn import windows as windows_module
from uavsnn.errors import ParameterError, StreamError

if TYPE_CHECKING:
    from uavsnn.network import Network

__all__ = ["Use", "check_memory", "init_guard", "training"]


def init_guard(net: Network) -> None:
    """Give ``net`` the state of its guard (see :class:`Use`): the thread in ``train_layer``,
    the calls under way, and the lock of both."""
    net._guard = threading.Lock()
    net._trainer = None
    net._users = 0


class Use:
    """A call on a :class:`~uavsnn.network.Network` while
    :meth:`~uavsnn.network.Network.train_layer` may run: the engine lets the network go
    between training's chunks (for its callback and Ctrl-C), so another thread's call would
    read half-trained weights there, or change them under it. Refused with a
    :class:`~uavsnn.StreamError` instead, as the engine refuses a call that meets another's; the
    training thread's own reads (its callback's) go on."""

    __slots__ = ("call", "net", "write")

    def __init__(self, net: Network, call: str, write: bool = False) -> None:
        self.net, self.call, self.write = net, call, write

    def __enter__(self) -> None:
        net = self.net
        with net._guard:
            trainer = net._trainer
            if trainer is not None and (self.write or trainer != threading.get_ident()):
                who = (
                    "another thread (its train_layer() is running)"
                    if trainer != threading.get_ident()
                    else "this thread's train_layer(), whose callback may read it, not change it"
                )
                raise StreamError(
                    f"{self.call}(): the network is in use by {who}; use a copy() per thread"
                )
            net._users += 1

    def __exit__(self, *exc: object) -> None:
        with self.net._guard:
            self.net._users -= 1


@contextmanager
def training(net: Network) -> Iterator[None]:
    """``net`` this thread's while training runs, between the engine's chunks too (:class:`Use`
    refuses other threads' calls meanwhile).

    Raises:
        StreamError: another thread trains it, or one of its calls is running.
    """
    with net._guard:
        if net._trainer is not None or net._users:
            raise StreamError(
                "train_layer(): the network is in use by another thread (one of its calls "
                "is running); use a copy() per thread"
            )
        net._trainer = threading.get_ident()
    try:
        yield
    finally:
        with net._guard:
            net._trainer = None


def check_memory(net: Network, states: int = 1, *, more: int = 0, hint: str = "") -> None:
    """Refuse, before the engine allocates them, ``states`` window states of ``net`` (and
    ``more`` bytes beside them) that would not fit in ``uavsnn.windows.MEMORY_LIMIT`` (the
    memory this process may have): the engine checks them against its fixed 4 GiB only, and an
    allocation the system cannot honour aborts the process.

    Raises:
        ParameterError: they would not fit (the bytes and the limit named; ``hint`` added).
    """
    limit = windows_module.MEMORY_LIMIT
    need = states * net.state_bytes + more
    if limit is None or need <= limit:
        return
    c = net.config
    maps = "/".join(str(c[name]["maps"]) for name in ("conv1", "conv2", "conv3"))
    what = "one window's state" if states == 1 else f"the states of {states} live windows"
    beside = f" ({more:,} of them beside the states)" if more else ""
    raise ParameterError(
        f"{what} of a {c['width']}x{c['height']} network (conv maps {maps}) would need "
        f"{need:,} bytes{beside}, more than the {limit:,} bytes allowed "
        f"(uavsnn.windows.MEMORY_LIMIT): use a smaller width and height, or fewer maps{hint}"
    )
