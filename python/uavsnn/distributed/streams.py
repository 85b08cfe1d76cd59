"""Many streams: one :class:`~uavsnn.Detector` per stream, each in a Ray actor that opens its
own source (file or UDP port), so events never pass through the driver (:func:`detect_streams`).
"""

from __future__ import annotations

import contextlib
import os
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from uavsnn.distributed.cluster import RayRunner, Runner
from uavsnn.errors import ParameterError, UavsnnError
from uavsnn.network import Network

if TYPE_CHECKING:
    from uavsnn.grouping import WindowReport
    from uavsnn.tracks import Tracker

__all__ = ["MAX_STREAMS", "STOP_WAIT_S", "StreamResult", "detect_streams"]

#: The most streams :func:`detect_streams` runs at once: each is an actor, a process of its own
#: holding the model.
MAX_STREAMS = 256
#: Seconds :func:`detect_streams`, stopped by Ctrl-C, waits for the streams to report the
#: windows they still hold open before it stops their actors.
STOP_WAIT_S = 5.0
# The longest a live stream's worker waits on a quiet source before it looks whether it was
# asked to stop (its source's heartbeat).
_WAKE_S = 0.25


@dataclass
class StreamResult:
    """What one stream gave: its name, every detection in time order
    (:data:`~uavsnn.detector.WINDOW_DETECTION_DTYPE`; after a sensor restart, in time order
    again from the new clock), its closed windows with their objects when run with
    ``windows=True`` (:class:`~uavsnn.grouping.WindowReport`, in window order; their spikes are
    :attr:`detections`), the source's and detector's counts, and the error that ended it early
    (``None`` when it ran to its end). With ``keep=False`` :attr:`detections` and
    :attr:`reports` stay empty and only the counts are kept."""

    name: str
    detections: np.ndarray
    reports: list[WindowReport] = field(default_factory=list)
    #: conv3 spikes the stream's detector gave (kept or not).
    spikes: int = 0
    #: Windows reported closed (``windows=True``; kept or not), and those of them detected.
    windows_reported: int = 0
    windows_detected: int = 0
    #: The stream has ended: its source's end, or the error that ended it.
    ended: bool = False
    events: int = 0
    events_seen: int = 0
    packets: int = 0
    dropped: int = 0
    rejected_events: int = 0
    windows: int = 0
    #: Sensor restarts (:attr:`uavsnn.sources.SourceStats.restarts`): at each the detector
    #: was flushed and started again, so the detections after it start again in time.
    restarts: int = 0
    error: str | None = None
    address: tuple[str, int] | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """The stream ran to its end."""
        return self.error is None


#: detect_streams' source options: :func:`uavsnn.sources.open_source`'s, but standard input's
#: and heartbeats (set from ``idle_flush_s``), with ``downsample`` (to the model's input) for
#: ``downsample_to``.
_STREAM_OPTIONS = (
    "sensor_size",
    "realtime",
    "downsample",
    "udp_format",
    "max_packets",
    "idle_timeout",
)


def _given(value: Any) -> bool:
    """Whether a source option was given (``None`` and ``False`` are its defaults)."""
    return value is not None and value is not False


class _StreamWorker:
    """One stream: its source and its Detector, run in a thread so that :meth:`poll` answers
    while it works. Lives in a Ray actor (see :func:`detect_streams`). A stream that cannot
    start (its source cannot be opened, or does not fit the model) is not an actor that fails
    to start, which Ray would report with a traceback: its error is :meth:`poll`'s."""

    def __init__(self, name: str, spec: str, model: Network, options: dict[str, Any]) -> None:
        self.name = name
        self.windows = bool(options.get("windows", False))
        self.source: Any = None
        self.address: tuple[str, int] | None = None
        self._lock = threading.Condition()
        # Detections (arrays) or closed windows (WindowReports) not yet polled.
        self._found: list[Any] = []
        self._rejected = 0
        # The detector's counters as the worker thread last read them: poll must not touch the
        # detector itself, which push holds (its engine call releases the GIL; a getter from
        # poll's thread then meets the borrow: "Already mutably borrowed").
        self._seen = 0
        self._windows = 0
        self._done = False
        self._error: str | None = None
        self._stop = threading.Event()
        try:
            self._open(spec, model, dict(options))
        except Exception as exc:
            self._error = f"{type(exc).__name__}: {exc}"
            self._done = True
            return
        self._thread = threading.Thread(target=self._run, name=f"uavsnn-{name}", daemon=True)
        self._thread.start()

    def _open(self, spec: str, model: Network, opts: dict[str, Any]) -> None:
        from uavsnn.detector import Detector
        from uavsnn.driver import StreamDriver
        from uavsnn.sources import (
            IdleClock,
            UdpSource,
            check_fits,
            is_live,
            open_source,
            source_options,
        )

        window_us, overlap = opts.pop("window_us"), opts.pop("overlap")
        start_us = opts.pop("start_us", None)
        idle_flush_s = opts.pop("idle_flush_s", None)
        opts.pop("windows", None)
        tracker = opts.pop("tracker", None)
        model_size = (int(model.config["width"]), int(model.config["height"]))
        live = is_live(spec)
        if opts.get("sensor_size") is None and live:
            opts["sensor_size"] = model_size
        if live:
            # Heartbeats move a quiet stream on (idle_flush_s), and wake the worker to see a stop.
            beat = IdleClock.heartbeat_for(idle_flush_s)
            opts["heartbeat_s"] = _WAKE_S if beat is None else min(beat, _WAKE_S)
        if opts.pop("downsample", False):
            opts["downsample_to"] = model_size
        # Each source takes the options of its kind (the others apply to the other streams);
        # what was not given is left to open_source's defaults.
        given = {key: value for key, value in opts.items() if _given(value)}
        self.source = open_source(spec, **source_options(spec, given))
        try:
            check_fits(self.source, model_size)
        except UavsnnError:
            self.source.close()
            raise
        if tracker is not None:
            tracker.reset()  # a copy of the caller's, with its parameters and none of its tracks
        self.detector = Detector(
            model,
            window_us=window_us,
            overlap=overlap,
            start_us=start_us,
            sensor_size=self.source.sensor_size,
            tracker=tracker,
        )
        self.driver = StreamDriver(
            self.source,
            self.detector,
            idle_flush_s=idle_flush_s if live else None,
            windows=self.windows,
        )
        self.address = self.source.address if isinstance(self.source, UdpSource) else None

    def _run(self) -> None:
        def note(found: Any) -> None:
            seen, windows = self.driver.events_seen, self.driver.windows_opened
            with self._lock:
                self._seen, self._windows = seen, windows
                self._rejected = self.driver.rejected
                if found is not None and len(found):
                    if self.windows:
                        self._found.extend(found)  # WindowReports: immutable, sent as they are
                    else:
                        self._found.append(found.copy())
                    self._lock.notify_all()

        try:
            with self.source:
                for step in self.driver:
                    if step.kind != "restarted":
                        note(step.found)
                    if self._stop.is_set():
                        # Asked to stop (detect_streams was interrupted): the windows still
                        # open are reported, as one stream's detect reports them at Ctrl-C.
                        note(self.driver.flush())
                        break
        except Exception as exc:  # reported with the stream's name; the others go on
            with self._lock:
                self._error = f"{type(exc).__name__}: {exc}"
        finally:
            with self._lock:
                self._rejected = self.driver.rejected
                self._done = True
                self._lock.notify_all()

    def bound(self) -> tuple[str, int] | None:
        """The UDP address the source listens on (``None`` for other sources)."""
        return self.address

    def stop(self, wait_s: float) -> tuple[Any, dict[str, Any], bool]:
        """Stop the stream, its windows still open flushed: what :meth:`poll` gives once the
        worker has stopped, or after ``wait_s`` (the third item says whether it stopped)."""
        self._stop.set()
        deadline = time.monotonic() + wait_s
        with self._lock:
            while not self._done and (left := deadline - time.monotonic()) > 0:
                self._lock.wait(left)
        return self.poll(0.0)

    def poll(self, wait_s: float) -> tuple[Any, dict[str, Any], bool]:
        """Detections found since the last poll (time order; the windows closed since, a list
        of WindowReports, when the stream reports windows), the counts, and whether the stream
        has ended; waits up to ``wait_s`` for something to report."""
        with self._lock:
            if not self._found and not self._done:
                self._lock.wait(wait_s)
            found: Any
            if self.windows:
                found = self._found
            else:
                found = (
                    np.concatenate(self._found) if self._found else np.empty(0, _detection_dtype())
                )
            self._found = []
            done = self._done
            s = self.source.stats if self.source is not None else None  # None: never opened
            counts = {
                "events": s.events if s else 0,
                "events_seen": self._seen,
                "packets": s.packets if s else 0,
                "dropped": s.dropped if s else 0,
                "rejected_events": self._rejected,
                "windows": self._windows,
                "restarts": s.restarts if s else 0,
                "error": self._error,
            }
        return found, counts, done


def detect_streams(
    runner: Runner,
    sources: Sequence[str | os.PathLike[str]],
    model: Network | str | os.PathLike[str],
    *,
    window_us: int | None = None,
    overlap: float | None = None,
    start_us: int | None = None,
    names: Sequence[str] | None = None,
    on_ready: Callable[[dict[str, tuple[str, int] | None], dict[str, Any]], None] | None = None,
    on_detections: Callable[[str, Any], None] | None = None,
    on_update: Callable[[StreamResult], None] | None = None,
    poll_s: float = 0.1,
    idle_flush_s: float | None = None,
    windows: bool = False,
    tracker: Tracker | None = None,
    keep: bool = True,
    **source_options: Any,
) -> dict[str, StreamResult]:
    """Run one :class:`~uavsnn.Detector` per source, each in a Ray actor, until every stream
    ends (a file's last event, a UDP source's ``max_packets`` or ``idle_timeout``).

    Each actor opens its own source (a file path or ``udp://HOST:PORT`` on the node it runs
    on), so events go from the source into the actor's detector and nowhere else; only
    detections come back. The model goes through the object store once, with its
    identification (set its operating point before: ``model.identification =
    model.identification.at_false_alarm(0.01)``). ``on_ready`` gets
    each stream's bound UDP address (``None`` for a file) and its actor (``ray.kill(actor)``
    stops the stream) once every source is open; ``on_detections(name, found)``
    gets each stream's detections as they come, in time order. A stream whose actor dies or
    whose source fails is reported in its result's ``error``; the others go on.

    ``windows``: each detector reports its windows as they close
    (:meth:`Detector.push_windows <uavsnn.detector.Detector.push_windows>`: the decision, the
    merged objects with their tracks, rotor signatures, UAV scores and class guesses, as one
    stream's ``uavsnn detect`` prints them); ``on_detections`` then gets lists of
    :class:`~uavsnn.grouping.WindowReport`, in window order. ``tracker``: the parameters of
    every stream's tracker (each detector gets a copy, without its tracks; default
    :func:`uavsnn.tracks.tracker_for` the model, as a ``Detector``'s). ``keep``: whether the
    results keep every detection and window (``False`` for a stream of any length: only the
    counts, in bounded memory; ``on_detections`` still gets them all). ``on_update(result)``
    gets a stream's result as it stands after each of its polls (its counts so far, its
    ``restarts`` and ``error``), for a program's progress lines.

    Stopped by Ctrl-C (:class:`KeyboardInterrupt`), it asks each stream still running to stop
    and report the windows it holds open, as one stream's ``uavsnn detect`` does, and gives
    them to ``on_detections`` (waiting up to :data:`STOP_WAIT_S` seconds; a stream that does
    not answer by then reports nothing more), then stops every actor and raises; its streams'
    last ``on_update`` results are not ``ended``. Stopped by an exception from a callback, it
    stops every actor at once and raises.

    ``model``: a :class:`~uavsnn.network.Network` or the path of a model file.
    ``source_options``: as :func:`uavsnn.sources.open_source` (``sensor_size``, ``realtime``,
    ``udp_format``, ``max_packets``, ``idle_timeout``), and ``downsample`` (fit each source to
    the model's input: a file's sensor, a UDP stream's ``sensor_size``); each applies to the
    sources of its kind (``realtime`` to files, the others but ``sensor_size`` and
    ``downsample`` to UDP) and is refused when none is of that kind.

    ``idle_flush_s``: a live stream quiet for that many seconds is advanced
    with the wall clock (:class:`uavsnn.sources.IdleClock`; ``uavsnn detect --idle-flush``),
    so its last windows need not wait for its next event; events then stamped before the time
    reached are counted in ``rejected_events``. ``None``: never.

    Raises:
        ParameterError: before any actor starts: a runner that is not Ray's, ``sources`` not a
            list of file paths and ``udp://HOST:PORT`` addresses (standard input cannot be
            one), names missing or repeated, more than :data:`MAX_STREAMS` sources, a model
            that is neither a network nor a model file, a window, overlap or start a ``Detector``
            refuses, a bad ``idle_flush_s``, an unknown source option or one for a kind of
            source none is, or a ``tracker`` that is no :class:`~uavsnn.tracks.Tracker` or is
            given without ``windows``.
    """
    from uavsnn.detector import Detector
    from uavsnn.sources import check_applies, is_live
    from uavsnn.tracks import Tracker

    if not isinstance(runner, RayRunner):
        raise ParameterError("streams run in Ray actors: pass the runner connect() returns")
    if isinstance(sources, (str, bytes, os.PathLike)) or not all(
        isinstance(spec, (str, os.PathLike)) and isinstance(os.fspath(spec), str)
        for spec in sources
    ):
        raise ParameterError(
            f"sources must be a list of file paths (str or Path) and udp://HOST:PORT addresses, "
            f"got {sources!r}"
        )
    specs: list[str] = [os.fspath(spec) for spec in sources]  # a Path's stream: its text
    if "-" in specs:
        raise ParameterError(
            "standard input ('-') cannot be a stream here: each stream's actor opens its source"
        )
    unknown = sorted(set(source_options) - set(_STREAM_OPTIONS))
    if unknown:
        raise ParameterError(
            f"unknown source option {unknown[0]!r}: the options are {', '.join(_STREAM_OPTIONS)}"
        )
    # An option for a kind of source no stream is, by open_source's names and defaults.
    as_opened = dict(source_options)
    if "downsample" in as_opened:
        as_opened["downsample_to"] = True if as_opened.pop("downsample") else None
    check_applies(specs, as_opened, spelled={"downsample_to": "downsample"})
    if idle_flush_s is not None and not any(is_live(spec) for spec in specs):
        raise ParameterError("idle_flush_s applies to live streams (UDP), and no stream is one")
    if isinstance(model, (str, os.PathLike)):
        model = Network.load(model)
    elif not isinstance(model, Network):
        raise ParameterError(
            f"model must be a uavsnn.Network or the path of a model file, got "
            f"{type(model).__name__}"
        )
    # The window, overlap and start as every stream's Detector takes them (refused here, once).
    Detector(model, window_us=window_us, overlap=overlap, start_us=start_us)
    if tracker is not None:
        if not isinstance(tracker, Tracker):
            raise ParameterError(f"tracker must be a uavsnn.tracks.Tracker, got {tracker!r}")
        if not windows:
            raise ParameterError("tracker links the objects of windows: give windows=True")
    ray = runner._ray
    names = list(names) if names is not None else list(specs)
    if len(names) != len(specs) or len(set(names)) != len(names):
        raise ParameterError("every stream needs a name of its own")
    if len(specs) > MAX_STREAMS:
        raise ParameterError(
            f"{len(specs)} streams: at most {MAX_STREAMS} run at once (uavsnn.distributed."
            f"MAX_STREAMS), each an actor process holding the model"
        )
    from uavsnn.sources import check_seconds

    check_seconds("idle_flush_s", idle_flush_s)
    options = {
        "window_us": window_us,
        "overlap": overlap,
        "start_us": start_us,
        "idle_flush_s": idle_flush_s,
        "windows": bool(windows),
        "tracker": tracker,
        **source_options,
    }
    # Every stream must run at once however many CPUs the cluster has: an actor reserves
    # none (Ray's default for a running actor), so none waits for another to finish.
    actor_class = ray.remote(num_cpus=0, max_restarts=0, max_task_retries=0)(_StreamWorker)
    model_ref = ray.put(model)
    actors = {
        name: actor_class.remote(name, spec, model_ref, options)
        for name, spec in zip(names, specs, strict=True)
    }
    results = {name: StreamResult(name, np.empty(0, dtype=_detection_dtype())) for name in names}
    parts: dict[str, list[np.ndarray]] = {name: [] for name in names}
    keep = bool(keep)
    live: dict[str, Any] = {}
    for name, actor in actors.items():
        try:
            results[name].address = ray.get(actor.bound.remote())
            live[name] = actor
        except Exception as exc:
            results[name].error = _actor_error(exc)
    if on_ready is not None:
        on_ready({name: results[name].address for name in live}, dict(live))
    try:
        _gather(ray, live, results, parts, windows, keep, on_detections, on_update, poll_s)
    except BaseException:
        # Ctrl-C, or a callback's error (a closed pipe): the actors would stream on.
        for actor in live.values():
            with contextlib.suppress(Exception):
                ray.kill(actor, no_restart=True)
        raise
    for name, chunks in parts.items():
        if any(len(c) for c in chunks):
            results[name].detections = np.concatenate(chunks)
    return results


def _gather(
    ray: Any,
    live: dict[str, Any],
    results: dict[str, StreamResult],
    parts: dict[str, list[np.ndarray]],
    windows: bool,
    keep: bool,
    on_detections: Callable[[str, Any], None] | None,
    on_update: Callable[[StreamResult], None] | None,
    poll_s: float,
) -> None:
    """:func:`detect_streams`' loop: poll every live stream until each has ended. Stopped by
    Ctrl-C, each stream still running is asked to stop and report its open windows (within
    :data:`STOP_WAIT_S`), after the polls already asked for, then the interruption goes on."""

    def take(name: str, answer: Any, ended: bool) -> None:
        found, counts, _ = answer
        r = results[name]
        for key in ("events", "events_seen", "packets", "dropped", "rejected_events"):
            setattr(r, key, counts[key])
        r.windows, r.restarts = counts["windows"], counts["restarts"]
        r.error, r.ended = counts["error"], ended
        if len(found):
            spikes = [w.detections for w in found] if windows else [found]
            r.spikes += sum(len(a) for a in spikes)
            if windows:
                r.windows_reported += len(found)
                r.windows_detected += sum(bool(w.detected) for w in found)
            if keep:
                parts[name].extend(spikes)
                if windows:
                    r.reports.extend(found)
            if on_detections is not None:
                on_detections(name, found)
        if on_update is not None:
            on_update(r)

    def failed(name: str, exc: Exception) -> None:
        results[name].error = _actor_error(exc)
        results[name].ended = True
        if on_update is not None:
            on_update(results[name])

    pending: dict[Any, str] = {actor.poll.remote(poll_s): name for name, actor in live.items()}
    try:
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1, timeout=None)
            for ref in ready:
                name = pending.pop(ref)
                try:
                    answer = ray.get(ref)
                except Exception as exc:
                    failed(name, exc)
                    continue
                done = answer[2]
                take(name, answer, done)
                if done:
                    ray.kill(live[name], no_restart=True)
                else:
                    pending[live[name].poll.remote(poll_s)] = name
    except KeyboardInterrupt:
        # Each stream still running (its poll in flight, or the one whose answer was being
        # taken) stops; an actor answers in order: its poll in flight first, then its stop.
        asked = list(pending.items())
        running = [name for name in live if not results[name].ended]
        asked += [(live[name].stop.remote(STOP_WAIT_S), name) for name in running]
        ready, _ = ray.wait([ref for ref, _ in asked], num_returns=len(asked),
                            timeout=STOP_WAIT_S + 1.0)  # fmt: skip
        for ref, name in asked:
            if ref in ready:
                try:
                    answer = ray.get(ref)
                except Exception:
                    continue  # the actor died as it stopped: what it held is lost
                # Stopped, not ended: a stream that was interrupted.
                take(name, answer, False)
        raise


def _detection_dtype() -> np.dtype:
    from uavsnn.detector import WINDOW_DETECTION_DTYPE

    return WINDOW_DETECTION_DTYPE


def _actor_error(exc: BaseException) -> str:
    cause = getattr(exc, "cause", None)
    if isinstance(cause, BaseException):
        return f"{type(cause).__name__}: {cause}"
    text = str(exc).strip().splitlines()
    kind = type(exc).__name__
    if "ActorDied" in kind or "ActorError" in kind:
        if "creation task" in str(exc) and text:
            # The stream could not start (its source or detector refused it): Ray gives the
            # error as the last line of the traceback it prints, "module.Error: message".
            error, _, message = text[-1].strip().partition(": ")
            return f"{error.rpartition('.')[2]}: {message}"
        return "its actor died (killed, or its node was lost)"
    return f"{kind}: {text[0] if text else ''}"
