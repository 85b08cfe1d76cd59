"""The runners a job's units of work run on, and joining a Ray cluster (:func:`connect`).

Ray is imported only when a cluster is joined (:func:`connect`, :class:`RayRunner`).
"""

from __future__ import annotations

import os
import signal
import socket
import threading
from collections.abc import Callable, Generator, Iterable, Sequence
from typing import Any
from urllib.parse import urlsplit

from uavsnn._validate import check_int, check_real
from uavsnn.errors import ParameterError, UavsnnError

#: How to install what ``--ray`` needs.
RAY_HINT = "pip install 'uavsnn[ray]'"
#: Seconds an unreachable ``--ray`` address may take to fail.
CONNECT_TIMEOUT_S = 5.0
#: The most CPUs a local cluster may be given (``num_cpus``; Ray starts a worker process for
#: each task it runs at once), the engine's most threads.
MAX_CPUS = 256


def ray_available() -> bool:
    """Whether Ray can be imported (without importing it)."""
    import importlib.util

    return importlib.util.find_spec("ray") is not None


def _import_ray() -> Any:
    try:
        import ray
    except ImportError as exc:
        raise ParameterError(
            f"Ray is not installed (--ray and uavsnn.distributed need it): {RAY_HINT}"
        ) from exc
    return ray


# ---------------------------------------------------------------------------- runners


class Runner:
    """Where a job's units of work run. :meth:`submit` starts one (``fn(*args)``) and returns a
    handle; :meth:`result` waits for it. Results are the same whichever runner runs them."""

    #: Units a job may keep in flight ahead of the one it waits for (0: one at a time).
    ahead: int = 0
    #: CPUs the runner has (1 for :class:`SerialRunner`).
    workers: int = 1

    def submit(self, fn: Callable[..., Any], *args: Any) -> Any:
        raise NotImplementedError

    def result(self, handle: Any) -> Any:
        raise NotImplementedError

    def cancel(self, handles: Iterable[Any]) -> None:
        """Give up on units no longer needed (their results are dropped)."""

    def put(self, obj: Any) -> Any:
        """Share ``obj`` with many units: pass what this returns instead of ``obj``."""
        return obj

    def imap(
        self, fn: Callable[..., Any], args: Iterable[Sequence[Any]]
    ) -> Generator[Any, None, None]:
        """``fn(*a)`` for each ``a`` of ``args``, in order, with up to ``ahead`` units in flight
        beyond the one being waited for; units still in flight when the iterator is closed
        (or raises) are cancelled."""
        todo = iter(args)
        flight: list[Any] = []
        try:
            while True:
                while len(flight) <= self.ahead:
                    nxt = next(todo, None)
                    if nxt is None:
                        break
                    flight.append(self.submit(fn, *nxt))
                if not flight:
                    return
                yield self.result(flight.pop(0))
        finally:
            self.cancel(flight)


class _Deferred:
    __slots__ = ("args", "fn")

    def __init__(self, fn: Callable[..., Any], args: tuple[Any, ...]) -> None:
        self.fn, self.args = fn, args


class SerialRunner(Runner):
    """Runs each unit in this process when its result is asked for: one machine, no Ray."""

    def submit(self, fn: Callable[..., Any], *args: Any) -> Any:
        return _Deferred(fn, args)

    def result(self, handle: Any) -> Any:
        return handle.fn(*handle.args)


#: The runner every job uses unless given another.
SERIAL = SerialRunner()


class RayRunner(Runner):
    """Runs each unit as a Ray task (one CPU each) on the cluster :func:`connect` joined."""

    def __init__(self) -> None:
        self._ray = _import_ray()
        if not self._ray.is_initialized():
            raise ParameterError("Ray is not connected: call uavsnn.distributed.connect() first")
        self.workers = max(1, int(self._ray.cluster_resources().get("CPU", 1)))
        self.ahead = 2 * self.workers
        self._remote: dict[Callable[..., Any], Any] = {}

    def submit(self, fn: Callable[..., Any], *args: Any) -> Any:
        remote = self._remote.get(fn)
        if remote is None:
            remote = self._remote[fn] = self._ray.remote(num_cpus=1, max_retries=0)(fn)
        return remote.remote(*args)

    def result(self, handle: Any) -> Any:
        try:
            return self._ray.get(handle)
        except self._ray.exceptions.RayTaskError as exc:
            # A uavsnn error in a task is the same error as on one machine: one line, exit 2.
            cause = getattr(exc, "cause", None)
            if isinstance(cause, UavsnnError):
                raise cause from None
            raise

    def cancel(self, handles: Iterable[Any]) -> None:
        for handle in handles:
            try:
                self._ray.cancel(handle)
            except Exception:  # already finished, or the cluster is gone: nothing to cancel
                pass

    def put(self, obj: Any) -> Any:
        return self._ray.put(obj)


#: The start of an HTTP/2 connection without TLS: the client's preface and an empty SETTINGS
#: frame. A Ray head's GCS port and Ray Client's port are gRPC servers, which answer it with a
#: SETTINGS frame of their own (type 4, the fourth byte of its 9-byte header).
_HTTP2_HELLO = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + bytes([0, 0, 0, 4, 0, 0, 0, 0, 0])


def _check_reachable(address: str, timeout_s: float) -> None:
    """Fail in seconds, not minutes, when nothing listens at a ``host:port`` address, or what
    listens is not a gRPC server (a Ray dashboard, a web server, Redis: ``ray.init`` waits on
    those without end, deaf to Ctrl-C). With ``RAY_USE_TLS`` set, only that the port is open."""
    try:
        url = urlsplit(address if "://" in address else f"ray://{address}")
        host, port = url.hostname, url.port
    except ValueError as exc:
        raise ParameterError(f"bad Ray address {address!r}: {exc}") from exc
    if not host or port is None:
        raise ParameterError(
            f"a Ray address is HOST:PORT (the head's GCS port, 6379 by default), "
            f"ray://HOST:PORT (Ray Client) or 'auto', got {address!r}"
        )
    tls = os.environ.get("RAY_USE_TLS", "0").lower() not in ("", "0", "false")
    try:
        with socket.create_connection((host, port), timeout=timeout_s) as sock:
            if tls:
                return
            sock.sendall(_HTTP2_HELLO)
            answer = b""
            while len(answer) < 9:
                part = sock.recv(9 - len(answer))
                if not part:
                    break
                answer += part
    except TimeoutError:
        answer = b""  # connected, and no answer in time
    except OSError as exc:
        raise ParameterError(
            f"cannot reach a Ray cluster at {address} ({exc}); start one with "
            f"'ray start --head' or check the address"
        ) from exc
    if len(answer) < 9 or answer[3] != 4:
        raise ParameterError(
            f"{address} is open but does not answer as a Ray cluster (gRPC): give the head's "
            f"GCS port (6379 by default; not the dashboard's 8265) or ray://HOST:PORT for Ray "
            f"Client (10001)"
        )


def connect(
    address: str | None = None,
    *,
    num_cpus: int | None = None,
    timeout_s: float = CONNECT_TIMEOUT_S,
) -> RayRunner:
    """Join a Ray cluster and return a runner for it.

    ``address``: ``None`` or ``"local"`` starts a local cluster on this machine (``num_cpus``,
    at most :data:`MAX_CPUS`, caps its CPUs; default all), as ``ray.init()`` does; ``"auto"``
    joins the cluster this machine is part of (``ray start``, or ``RAY_ADDRESS``);
    ``HOST:PORT`` or ``ray://HOST:PORT`` joins that cluster. An address where nothing answers
    fails within ``timeout_s``. When Ray is already initialised in this process, that cluster
    is used.

    Raises:
        ParameterError: Ray is not installed, or the cluster cannot be reached.
    """
    timeout = check_real("timeout_s", timeout_s, low=0.0, low_open=True)
    if num_cpus is not None:
        check_int("num_cpus", num_cpus, 1, MAX_CPUS)  # 0 CPUs: every task would wait for ever
    ray = _import_ray()
    local = address in (None, "", "local")
    if not local and address != "auto":
        _check_reachable(str(address), timeout)
    if not ray.is_initialized():
        kwargs: dict[str, Any] = {"logging_level": "WARNING"}
        if local:
            kwargs["include_dashboard"] = False
            if num_cpus is not None:
                kwargs["num_cpus"] = int(num_cpus)
        kept = _program_handlers()
        try:
            ray.init(address=None if local else address, **kwargs)
        except (ConnectionError, RuntimeError, ValueError, TimeoutError) as exc:
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise ParameterError(f"cannot join the Ray cluster at {address}: {first}") from exc
        finally:
            for sig, handler in kept:
                signal.signal(sig, handler)
    return RayRunner()


def _program_handlers() -> list[tuple[signal.Signals, Any]]:
    """The handlers of SIGTERM and SIGHUP that the program set (``uavsnn``'s commands take
    them on Ctrl-C's path: :mod:`uavsnn.cli`), to put back after ``ray.init``, which installs
    its own (SIGTERM then exited 15 with a crash dump, and no summary). Where the program set
    none, Ray's stay. Only in the main thread, where handlers can be set."""
    if threading.current_thread() is not threading.main_thread():
        return []
    kept = []
    for name in ("SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is not None and callable(handler := signal.getsignal(sig)):
            kept.append((sig, handler))
    return kept


def runner_for(address: str | None, *, num_cpus: int | None = None) -> Runner:
    """:data:`SERIAL` for ``None``; else the runner of the cluster :func:`connect` joins at
    ``address`` (what a command's ``--ray [ADDRESS]`` gives: ``"local"`` without one)."""
    return SERIAL if address is None else connect(address, num_cpus=num_cpus)


def add_ray_option(parser: Any, what: str) -> None:
    """Add ``--ray [ADDRESS]`` to a command's parser."""
    parser.add_argument(
        "--ray",
        nargs="?",
        const="local",
        default=None,
        metavar="ADDRESS",
        help=f"run {what} on Ray: a local cluster on this machine, or the cluster at ADDRESS "
        f"(HOST:PORT, ray://HOST:PORT or auto); needs {RAY_HINT} (docs/distributed.md)",
    )
