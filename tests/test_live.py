"""Live streaming with ``uavsnn detect``: stopped by a service manager's signal, its output's
reader gone, options that apply to UDP only, ``--realtime`` over long gaps, and what the kernel
does to a UDP socket (its receive buffer, the datagrams it drops). Runs that need a process of
their own (signals, a closed pipe) run in a fresh interpreter of their own process group,
killed whole by a watchdog should they hang."""

from __future__ import annotations

import io
import json
import signal
import socket
import subprocess
import sys
import threading
import tracemalloc
import types
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import (
    SMALL_SENSOR,
    WindowsClosedPipe,
    blob_events,
    kill_group,
    one_line_exit_2,
    random_events,
    small_config,
)

from uavsnn import EVENT_DTYPE, ParameterError, StreamError
from uavsnn import driver as driver_module
from uavsnn import sources as sources_module
from uavsnn.cli import main
from uavsnn.detector import Detector
from uavsnn.network import Network
from uavsnn.sources import FileSource, UdpSource

WINDOW_MS = "3"
LOOPBACK = "127.0.0.1"
LINUX = sys.platform.startswith("linux")


@pytest.fixture(scope="module")
def net() -> Network:
    return Network(small_config(), seed=3)


@pytest.fixture(scope="module")
def model(net: Network, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("model") / "model.npz"
    net.save(path)
    return path


@pytest.fixture(scope="module")
def events() -> np.ndarray:
    return blob_events(11, 1_500)


def detect_argv(model: Path, *more: str) -> list[str]:
    argv = ["detect", "-", "-m", str(model), "--window-ms", WINDOW_MS]
    return [*argv, "--summary-every", "0", *more]


def run_in_process(
    argv: list[str],
    data: bytes,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> tuple[int, list[str], str]:
    """``main(argv)`` with ``data`` on standard input: exit code, stdout lines, stderr."""
    monkeypatch.setattr(sys, "stdin", types.SimpleNamespace(buffer=io.BytesIO(data)))
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out.splitlines(), err


# A fresh interpreter running the command line as a service manager would start it, with
# SIGTERM and SIGHUP at their default and SIGINT ignored (as in a shell's background job).
CHILD = """
import signal, sys
signal.signal(signal.SIGINT, signal.SIG_IGN)
for name in ("SIGTERM", "SIGHUP"):
    signal.signal(getattr(signal, name), signal.SIG_DFL)
from uavsnn.cli import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.fixture
def child() -> Iterator[Callable[[list[str]], subprocess.Popen[bytes]]]:
    """Start the command line in a process group of its own; killed whole after the test, or
    by a watchdog after 120 s (a hang then fails the test instead of stalling the run)."""
    started: list[subprocess.Popen[bytes]] = []
    timers: list[threading.Timer] = []

    def kill(proc: subprocess.Popen[bytes]) -> None:
        if proc.poll() is None:
            kill_group(proc)

    def start(argv: list[str]) -> subprocess.Popen[bytes]:
        proc = subprocess.Popen(
            [sys.executable, "-c", CHILD, *argv],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            start_new_session=True,
        )
        started.append(proc)
        timer = threading.Timer(120, kill, (proc,))
        timer.daemon = True
        timer.start()
        timers.append(timer)
        return proc

    yield start
    for timer in timers:
        timer.cancel()
    for proc in started:
        kill(proc)
        for pipe in (proc.stdin, proc.stdout, proc.stderr):
            try:
                if pipe is not None:
                    pipe.close()
            except OSError:
                pass
        proc.wait()


# -- 1. SIGTERM and SIGHUP take the Ctrl-C path ------------------------------------------------


@pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="POSIX signals")
@pytest.mark.parametrize("name", ["SIGTERM", "SIGHUP"])
def test_a_service_managers_signal_reports_what_was_found_and_exits_128_plus_it(
    name: str,
    net: Network,
    model: Path,
    events: np.ndarray,
    child: Callable[[list[str]], subprocess.Popen[bytes]],
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # A last event well after the others: once the windows it closes are printed, every
    # event has been pushed, and the signal comes while the stream waits for more.
    last = np.array(events[-1:])
    last["t"] += 10 * int(WINDOW_MS) * 1000
    data = np.concatenate([events, last]).tobytes()
    argv = detect_argv(model, "--json")
    code, ended, _ = run_in_process(argv, data, monkeypatch, capsys)
    assert code == 0
    det = Detector(net, window_us=int(WINDOW_MS) * 1000, overlap=0.5, sensor_size=SMALL_SENSOR)
    closed = len(det.push_windows(np.frombuffer(data, dtype=EVENT_DTYPE)))
    assert 0 < closed < len(ended)  # some windows are still open when the signal comes

    proc = child(argv)
    assert proc.stdin is not None and proc.stdout is not None
    proc.stdin.write(data)
    proc.stdin.flush()
    got = [proc.stdout.readline() for _ in range(closed)]
    assert all(got), got  # (an empty line: the child ended, or the watchdog killed it)
    sig = getattr(signal, name)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + sig, err.decode()[-2000:]
    # Every window, the ones still open flushed, as if the stream had ended.
    lines = [line.decode() for line in got] + out.decode().splitlines()
    assert [json.loads(x) for x in lines] == [json.loads(x) for x in ended]
    last_lines = err.decode().splitlines()[-2:]
    assert last_lines[0].startswith("uavsnn detect: done"), err.decode()
    assert last_lines[1] == f"uavsnn detect: interrupted ({name})"


class _Watching(io.BytesIO):
    """Standard input's bytes, noting SIGTERM's and SIGHUP's handlers while being read."""

    def __init__(self, data: bytes) -> None:
        super().__init__(data)
        self.seen: list[tuple[Any, Any]] = []

    def read1(self, size: int = -1, /) -> bytes:
        self.seen.append((signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGHUP)))
        return super().read1(size)


@pytest.fixture
def dispositions() -> Iterator[None]:
    """Put SIGTERM's and SIGHUP's handlers back as they were after the test."""
    before = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGHUP)}
    yield
    for s, handler in before.items():
        signal.signal(s, handler)


@pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="POSIX signals")
@pytest.mark.usefixtures("dispositions")
@pytest.mark.parametrize("embedded", [False, True])
def test_main_handles_the_stop_signals_only_where_default_and_puts_them_back(
    embedded: bool,
    model: Path,
    events: np.ndarray,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    def own(signum: int, frame: Any) -> None:  # an embedding program's handler
        pass

    before = (own, signal.SIG_IGN) if embedded else (signal.SIG_DFL, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, before[0])
    signal.signal(signal.SIGHUP, before[1])
    stdin = _Watching(events.tobytes())
    monkeypatch.setattr(sys, "stdin", types.SimpleNamespace(buffer=stdin))
    assert main(detect_argv(model)) == 0
    capsys.readouterr()
    assert stdin.seen
    for during in stdin.seen:
        if embedded:
            assert during == before  # left alone
        else:
            assert all(callable(h) for h in during), during  # installed
    assert (signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGHUP)) == before


def test_main_runs_outside_the_main_thread(
    model: Path, events: np.ndarray, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Handlers can only be installed from the main thread: elsewhere none is, and main runs.
    monkeypatch.setattr(sys, "stdin", types.SimpleNamespace(buffer=io.BytesIO(events.tobytes())))
    codes: list[int] = []
    thread = threading.Thread(target=lambda: codes.append(main(detect_argv(model))), daemon=True)
    thread.start()
    thread.join(timeout=60)
    assert codes == [0]


# -- 2. the reader of standard output goes away ------------------------------------------------


@pytest.mark.parametrize("mode", ["--json", "--per-spike"])
def test_a_reader_gone_ends_detect_quietly_with_exit_1(
    mode: str,
    net: Network,
    model: Path,
    events: np.ndarray,
    child: Callable[[list[str]], subprocess.Popen[bytes]],
) -> None:
    first, second = events[:700], events[700:]
    det = Detector(net, window_us=int(WINDOW_MS) * 1000, overlap=0.5, sensor_size=SMALL_SENSOR)
    assert len(det.push(first)) > 0
    assert len(det.push(second)) + len(det.flush()) > 0  # more to print after the reader goes
    proc = child(detect_argv(model, mode))
    assert proc.stdin is not None and proc.stdout is not None and proc.stderr is not None
    proc.stdin.write(first.tobytes())
    proc.stdin.flush()
    assert proc.stdout.readline()  # the command is printing: now its reader goes (`| head -1`)
    proc.stdout.close()
    try:
        proc.stdin.write(second.tobytes())
        proc.stdin.close()
    except BrokenPipeError:
        pass
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 1, err
    assert "done" not in err and "Traceback" not in err, err


def test_a_reader_gone_on_windows_ends_detect_quietly_too(
    model: Path,
    events: np.ndarray,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Windows reports the closed pipe as EINVAL, not BrokenPipeError: detect still stops
    quietly with exit 1 (it once ended in "[Errno 22] Invalid argument" and exit 2)."""
    pipe = WindowsClosedPipe()
    out = io.TextIOWrapper(io.BufferedWriter(pipe), encoding="utf-8")
    monkeypatch.setattr(sys, "platform", "win32")
    monkeypatch.setattr(sys, "stdout", out)
    monkeypatch.setattr(sys, "stdin", types.SimpleNamespace(buffer=io.BytesIO(events.tobytes())))
    try:
        assert main(detect_argv(model)) == 1
        assert pipe.refused > 0
        err = capsys.readouterr().err
        assert "done" not in err and "Errno" not in err, err
    finally:
        out.close()


# -- 3. options of UDP only --------------------------------------------------------------------


@pytest.mark.parametrize("source", ["-", "recording.npy"])
@pytest.mark.parametrize("flag", [["--max-packets", "1"], ["--idle-timeout", "0.5"]])
def test_udp_only_options_are_refused_for_stdin_and_files(
    source: str, flag: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["detect", source, "-m", "model.npz", *flag]
    line = one_line_exit_2(capsys, argv, f"{flag[0]} applies to UDP")
    assert "udp://" in line


@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "1e300"])
def test_an_idle_timeout_a_socket_cannot_hold_is_refused(
    value: str, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["detect", "udp://127.0.0.1:0", "-m", "model.npz", "--idle-timeout", value]
    one_line_exit_2(capsys, argv, "--idle-timeout must be")
    with pytest.raises(ParameterError, match="idle_timeout"):
        UdpSource(LOOPBACK, 0, sensor_size=SMALL_SENSOR, idle_timeout=float(value))


# -- 4. --realtime over long gaps --------------------------------------------------------------


class _Clock:
    """A stand-in for the ``time`` module: ``sleep`` moves the clock on, instantly."""

    def __init__(self) -> None:
        self.now = 100.0

    def monotonic(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds


def replay(
    path: Path, monkeypatch: pytest.MonkeyPatch, chunk_us: int = 1000
) -> list[tuple[float, np.ndarray]]:
    """The chunks of a ``realtime`` replay of ``path``, each with its release time (seconds
    from the start), on a clock that does not wait."""
    clock = _Clock()
    monkeypatch.setattr(sources_module, "time", clock)
    source = FileSource(path, sensor_size=(240, 180), realtime=True, chunk_us=chunk_us)
    return [(clock.now - 100.0, chunk) for chunk in source]


def old_rule(events: np.ndarray, chunk_us: int) -> list[tuple[float, np.ndarray]]:
    """The chunks as they were cut before: every ``chunk_us`` edge from the first event's time
    to past the last, empty chunks skipped, each released at its edge."""
    t = events["t"]
    first = int(t[0])
    edges = np.arange(first, int(t[-1]) + chunk_us + 1, chunk_us, dtype=np.uint64)
    cuts = np.searchsorted(t, edges[1:], side="left")
    out, begin = [], 0
    for edge, end in zip(edges[1:], cuts, strict=True):
        if end > begin:
            out.append(((int(edge) - first) / 1e6, events[begin:end]))
            begin = int(end)
    return out


def test_realtime_cuts_the_same_chunks_at_the_same_times(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    rng = np.random.default_rng(5)
    ev = np.zeros(3_000, dtype=EVENT_DTYPE)
    # Bursts, gaps of many chunks, equal times, and events on chunk edges.
    steps = rng.choice([0, 1, 7, 250, 999, 1000, 1001, 40_000], size=len(ev))
    ev["t"] = 123_456 + np.cumsum(steps)
    ev["x"] = rng.integers(0, 240, len(ev))
    ev["y"] = rng.integers(0, 180, len(ev))
    np.save(tmp_path / "rec.npy", ev)
    for chunk_us in (1000, 333):
        got = replay(tmp_path / "rec.npy", monkeypatch, chunk_us)
        want = old_rule(ev, chunk_us)
        assert len(got) == len(want) > 100
        for (t_got, c_got), (t_want, c_want) in zip(got, want, strict=True):
            assert t_got == pytest.approx(t_want, abs=1e-9)
            np.testing.assert_array_equal(c_got, c_want)


def test_realtime_searches_the_times_without_copying_them_each_chunk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each chunk's search ran on the recording's time field, a strided view NumPy copies
    whole at every call: a replay was quadratic in the recording's length (2 s of a 640x480
    camera took 47 s to release). The search now runs on contiguous times."""
    ev = np.zeros(5_000, dtype=EVENT_DTYPE)
    ev["t"] = 1_000 + 7 * np.arange(len(ev))
    np.save(tmp_path / "rec.npy", ev)
    searched: list[bool] = []
    search = np.searchsorted

    def watched(a: Any, *args: Any, **kwargs: Any) -> Any:
        searched.append(bool(a.flags.c_contiguous))
        return search(a, *args, **kwargs)

    monkeypatch.setattr(sources_module.np, "searchsorted", watched)
    chunks = replay(tmp_path / "rec.npy", monkeypatch)
    assert len(chunks) == 35 and len(searched) >= 35 and all(searched)
    np.testing.assert_array_equal(np.concatenate([c for _, c in chunks]), ev)


@pytest.mark.parametrize("span_us", [3_600_000_000, 1 << 62])
def test_realtime_over_a_long_gap_holds_nothing_for_it(
    span_us: int, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Four events, the last an hour (or 2^62 µs, the engine's latest time) after the others:
    # one entry per millisecond of the span took 58 MB for the hour, and 2^62 µs failed.
    ev = np.zeros(4, dtype=EVENT_DTYPE)
    ev["t"] = [0, 10, 20, span_us]
    np.save(tmp_path / "gap.npy", ev)
    tracemalloc.start()
    try:
        chunks = replay(tmp_path / "gap.npy", monkeypatch)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1 << 20
    assert [len(c) for _, c in chunks] == [3, 1]
    assert chunks[1][0] == pytest.approx((span_us + 1000 - span_us % 1000) / 1e6)


# -- 5. the kernel's side of a UDP socket ------------------------------------------------------


def rmem_max() -> int:
    return int(Path("/proc/sys/net/core/rmem_max").read_text())


@pytest.mark.skipif(not LINUX, reason="Linux's cap on receive buffers")
def test_a_receive_buffer_smaller_than_asked_is_reported() -> None:
    cap = rmem_max()
    if cap >= 1 << 30:
        pytest.skip(f"net.core.rmem_max is {cap}: no buffer to ask beyond it")
    with UdpSource(LOOPBACK, 0, sensor_size=SMALL_SENSOR, receive_buffer=cap + (1 << 20)) as src:
        note = src.buffer_note
    assert note is not None and "net.core.rmem_max" in note and str(cap + (1 << 20)) in note
    with UdpSource(LOOPBACK, 0, sensor_size=SMALL_SENSOR, receive_buffer=1 << 16) as src:
        assert src.buffer_note is None


@pytest.mark.skipif(not LINUX, reason="Linux's cap on receive buffers")
def test_detect_warns_of_a_small_receive_buffer(
    model: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    cap = rmem_max()
    if cap >= 1 << 30:
        pytest.skip(f"net.core.rmem_max is {cap}: no buffer to ask beyond it")
    monkeypatch.setattr(sources_module, "RECEIVE_BUFFER", cap + (1 << 20))
    argv = ["detect", "udp://127.0.0.1:0", "-m", str(model), "--idle-timeout", "0.05"]
    assert main([*argv, "--summary-every", "0"]) == 0
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("uavsnn detect: listening on udp://")
    assert lines[1].startswith("uavsnn detect: warning: the kernel granted a UDP receive buffer")
    assert "net.core.rmem_max" in lines[1]
    assert lines[-1].startswith("uavsnn detect: done") and lines[-1].endswith(" lost=0")


def udp_packets(n: int, per_packet: int = 100) -> list[bytes]:
    ev = np.zeros(n * per_packet, dtype=EVENT_DTYPE)
    ev["t"] = 1_000 + np.arange(len(ev))
    ev["x"] = np.arange(len(ev)) % SMALL_SENSOR[0]
    return [ev[i : i + per_packet].tobytes() for i in range(0, len(ev), per_packet)]


@pytest.mark.skipif(not LINUX, reason="SO_RXQ_OVFL is Linux's")
def test_datagrams_the_kernel_drops_are_counted_as_lost() -> None:
    packets = udp_packets(61)
    with (
        UdpSource(LOOPBACK, 0, sensor_size=SMALL_SENSOR, idle_timeout=0.2, receive_buffer=1) as src,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s,
    ):
        assert src.stats.lost == 0
        # A burst into the smallest buffer while nobody reads: most of it is dropped.
        for p in packets[:60]:
            s.sendto(p, src.address)
        list(src)
        # The kernel says how many it dropped with the next datagram it queues.
        s.sendto(packets[60], src.address)
        list(src)
    assert src.stats.packets < 60
    assert src.stats.lost == len(packets) - src.stats.packets


@pytest.mark.parametrize("size", [0, 1 << 31])
def test_a_receive_buffer_a_socket_cannot_take_is_refused(size: int) -> None:
    with pytest.raises(ParameterError, match="receive_buffer"):
        UdpSource(LOOPBACK, 0, sensor_size=SMALL_SENSOR, receive_buffer=size)


# -- a sensor that restarts ---------------------------------------------------------------------

HOUR_US = 3_600_000_000


def restarted(n: int = 3_000) -> tuple[np.ndarray, np.ndarray]:
    """A stream an hour in, then the sensor restarted: its clock from 1000 µs again."""
    old = blob_events(21, n)
    old["t"] += np.uint64(HOUR_US)
    return old, blob_events(22, n)


def test_a_udp_source_follows_a_restarted_sensor() -> None:
    from uavsnn import _core

    old, new = restarted()
    per = 100
    packets = [a[i : i + per].tobytes() for a in (old, new) for i in range(0, len(a), per)]
    with (
        UdpSource(LOOPBACK, 0, sensor_size=SMALL_SENSOR, idle_timeout=0.5) as src,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s,
    ):
        for p in packets:
            s.sendto(p, src.address)
        chunks, restarts = [], []
        for chunk in src:
            chunks.append(chunk)
            restarts.append(src.stats.restarts)
    assert src.stats.lost in (None, 0)
    assert src.stats.restarts == 1
    first_new = restarts.index(1)
    assert all(c["t"][0] >= HOUR_US for c in chunks[:first_new])
    after = np.concatenate(chunks[first_new:])
    # The new stream whole and in order: the RESTART_AFTER packets refused before the restart
    # were held and taken back.
    np.testing.assert_array_equal(after, new)
    assert src.stats.dropped == 0
    assert len(chunks[first_new]) == (_core.RESTART_AFTER + 1) * per


def test_live_sources_downsample_each_chunk_as_a_file_is_whole() -> None:
    """`downsample_to` of the live sources: each chunk cropped and scaled from the camera's
    sensor as `filters.downsample` does a recording whole (the crop may empty a packet: no
    empty chunk comes of it, which would read as silence)."""
    from uavsnn.events import Recording
    from uavsnn.filters import downsample
    from uavsnn.sources import StdinSource

    camera, model = (100, 60), SMALL_SENSOR
    events = random_events(2_000, camera, seed=9)
    events["x"][:100] = 0  # a first packet wholly outside the centred crop
    events = events[np.argsort(events["t"], kind="stable")]
    want = downsample(Recording(events, camera), model).events
    with (
        UdpSource(LOOPBACK, 0, sensor_size=camera, idle_timeout=0.5, downsample_to=model) as src,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s,
    ):
        for i in range(0, len(events), 100):
            s.sendto(events[i : i + 100].tobytes(), src.address)
        udp = list(src)
    stdin = list(StdinSource(io.BytesIO(events.tobytes()), sensor_size=camera,
                             read_size=13 * 100, downsample_to=model))  # fmt: skip
    for chunks in (udp, stdin):
        assert all(len(c) for c in chunks)
        np.testing.assert_array_equal(np.concatenate(chunks), want)
    assert src.sensor_size == model and src.camera_size == camera and src.stats.events == 2_000


@pytest.mark.parametrize("fmt", ["packed", "csv"])
@pytest.mark.parametrize("read_size", [13 * 100, 1 << 16])
def test_standard_input_follows_a_restarted_sensor(fmt: str, read_size: int) -> None:
    from uavsnn.sources import STDIN_RESTART_EVENTS, StdinSource

    old, new = restarted()
    glitch = old[-1:].copy()
    glitch["t"] += np.uint64(10**12)  # and a glitch far ahead before the restart
    stream = np.concatenate([old, glitch, new])
    if fmt == "packed":
        data = stream.tobytes()
    else:
        data = "".join(f"{e['t']},{e['x']},{e['y']},{int(e['p'])}\n" for e in stream).encode()
    src = StdinSource(io.BytesIO(data), fmt=fmt, sensor_size=SMALL_SENSOR, read_size=read_size)
    parts = []
    for chunk in src:
        parts.append((src.stats.restarts, chunk))
    assert src.stats.restarts == 1 and src.stats.dropped == 0
    before = np.concatenate([c for r, c in parts if r == 0])
    after = np.concatenate([c for r, c in parts if r == 1])
    np.testing.assert_array_equal(before, np.concatenate([old, glitch]))
    np.testing.assert_array_equal(after, new)  # nothing of the new stream lost
    assert len(new) > STDIN_RESTART_EVENTS


def test_a_few_events_back_on_standard_input_are_dropped_not_a_restart() -> None:
    from uavsnn.sources import STDIN_RESTART_EVENTS, StdinSource

    old, _ = restarted()
    back = old[: STDIN_RESTART_EVENTS - 1].copy()
    back["t"] -= np.uint64(HOUR_US // 2)
    later = old[-10:].copy()
    later["t"] += np.uint64(1_000_000)
    stream = np.concatenate([old, back, later])
    src = StdinSource(io.BytesIO(stream.tobytes()), sensor_size=SMALL_SENSOR, read_size=1 << 12)
    got = np.concatenate(list(src))
    assert src.stats.restarts == 0 and src.stats.dropped == len(back)
    np.testing.assert_array_equal(got, np.concatenate([old, later]))


def test_standard_input_mostly_off_the_sensor_is_said_once(
    model: Path,
    events: np.ndarray,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """A camera of another size on standard input (a 1280x720 stream into a 240x180 model
    dropped 214,543 of 219,596 events, still printed detections and exited 0, the drops one
    count in the summary): when more than half of the first events lie off the sensor,
    detect says so once, with what they reach."""
    from uavsnn.sources import SIZE_CHECK_EVENTS, StdinSource

    wide = np.tile(events, SIZE_CHECK_EVENTS // len(events) + 1)[: SIZE_CHECK_EVENTS + 5].copy()
    wide["t"] = np.sort(wide["t"])
    wide["x"][: len(wide) // 2 + 1] += np.uint16(SMALL_SENSOR[0])  # half and one off
    src = StdinSource(io.BytesIO(wide.tobytes()), sensor_size=SMALL_SENSOR, read_size=1 << 12)
    kept = np.concatenate(list(src))
    off = len(wide) // 2 + 1  # all among the first SIZE_CHECK_EVENTS
    assert src.size_note is not None and src.size_note.startswith(
        f"{off} of the first {SIZE_CHECK_EVENTS} events lie off the 40x30 sensor (x up to "
    )
    assert len(kept) == len(wide) - len(wide) // 2 - 1
    code, _, err = run_in_process(detect_argv(model), wide.tobytes(), monkeypatch, capsys)
    assert code == 0 and err.count("lie off the 40x30 sensor") == 1
    assert "is the sensor size right (--sensor-size)?" in err
    # Half off, or all on the sensor: nothing said; a stream shorter than the check, judged
    # at its end.
    for shifted, said in ((50, None), (0, None), (51, "51 of the first 100 events")):
        part = events[:100].copy()
        part["x"][:shifted] += np.uint16(SMALL_SENSOR[0])
        src = StdinSource(io.BytesIO(part.tobytes()), sensor_size=SMALL_SENSOR)
        list(src)
        assert (src.size_note is None) if said is None else (said in (src.size_note or ""))


def test_detect_reports_the_old_stream_and_starts_again_after_a_restart(
    model: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    old, new = restarted()
    data = np.concatenate([old, new]).tobytes()
    code, lines, err = run_in_process(detect_argv(model, "--json"), data, monkeypatch, capsys)
    assert code == 0, err
    windows = [json.loads(line) for line in lines]
    t0 = [w["t0"] for w in windows]
    back = [i for i in range(1, len(t0)) if t0[i] < t0[i - 1]]
    assert len(back) == 1  # the old stream's windows, every one, then the new stream's
    assert t0[back[0] - 1] >= HOUR_US and t0[back[0]] < HOUR_US
    assert "the sensor restarted (its clock went back to t=" in err
    assert "restarts=1" in err
    # Each line names its stream: window numbers start again at the restart, the run goes on.
    assert [w["run"] for w in windows] == [0] * back[0] + [1] * (len(windows) - back[0])
    assert windows[back[0]]["window"] == 0 < windows[back[0] - 1]["window"]
    # Each stream's windows are those of a detector run on it alone (run 0), but for the run.
    for run, part, stream in ((0, windows[: back[0]], old), (1, windows[back[0] :], new)):
        code, alone, _ = run_in_process(
            detect_argv(model, "--json"), stream.tobytes(), monkeypatch, capsys
        )
        assert [{**json.loads(line), "run": run} for line in alone] == part
    # The text lines say the run after the restart only.
    code, text, _ = run_in_process(detect_argv(model), data, monkeypatch, capsys)
    assert [" run=1 " in line for line in text if line.startswith("window=")] == [
        w["run"] == 1 for w in windows
    ]


# -- StreamDriver: the loop `uavsnn detect` and the Ray workers share ------------------------------


class ListSource(sources_module.EventSource):
    """Chunks given in advance; ``restart_at``: the chunk from which the sensor has restarted."""

    sensor_size = SMALL_SENSOR

    def __init__(self, chunks: list[np.ndarray], restart_at: int | None = None) -> None:
        super().__init__()
        self.chunks, self.restart_at = chunks, restart_at

    def __iter__(self) -> Iterator[np.ndarray]:
        for i, chunk in enumerate(self.chunks):
            if i == self.restart_at:
                self.stats.restarts += 1
            yield chunk


def detections(det: Detector, chunks: list[np.ndarray]) -> np.ndarray:
    return np.concatenate([*(det.push(c) for c in chunks), det.flush()])


@pytest.mark.parametrize("windows", [False, True])
def test_the_stream_driver_skips_a_refused_chunk_and_counts_its_events(
    net: Network, events: np.ndarray, windows: bool
) -> None:
    good = np.array_split(events, 4)
    bad = good[1][:7].copy()
    bad["x"][3] = SMALL_SENSOR[0]  # outside the sensor: the whole chunk is refused
    source = ListSource([good[0], good[1], bad, good[2], good[3]])
    driver = driver_module.StreamDriver(source, Detector(net, window_us=3_000), windows=windows)
    steps = list(driver)
    assert [s.kind for s in steps] == ["found", "found", "refused", "found", "found", "found"]
    assert steps[2].events == len(bad) and "outside" in str(steps[2].error)
    assert driver.rejected == len(bad)
    found = [s.found for s in steps if s.kind == "found"]
    want = Detector(net, window_us=3_000)
    if windows:
        expected = [w for c in good for w in want.push_windows(c)] + want.flush_windows()
        rows = [(w.window, w.t0, w.t1, w.spikes) for f in found for w in f]
        assert rows == [(w.window, w.t0, w.t1, w.spikes) for w in expected]
        assert any(w.spikes for w in expected)
    else:
        expected = detections(want, good)
        assert len(expected) > 0
        np.testing.assert_array_equal(np.concatenate(found), expected)


def test_the_stream_driver_ends_the_old_stream_and_resets_at_a_restart(
    net: Network, events: np.ndarray
) -> None:
    old, new = np.array_split(events, 2)
    old = old.copy()
    old["t"] += np.uint64(HOUR_US)
    parts = [*np.array_split(old, 2), *np.array_split(new, 2)]
    det = Detector(net, window_us=3_000)
    driver = driver_module.StreamDriver(ListSource(parts, restart_at=2), det)
    steps = list(driver)
    kinds = [s.kind for s in steps]
    assert kinds == ["found", "found", "found", "restarted", "found", "found", "found"]
    assert steps[3].t == int(new["t"][0])
    before = np.concatenate([s.found for s in steps[:3]])
    after = np.concatenate([s.found for s in steps[4:]])
    # Each stream's detections are those of a detector run on it alone.
    np.testing.assert_array_equal(before, detections(Detector(net, window_us=3_000), parts[:2]))
    np.testing.assert_array_equal(after, detections(Detector(net, window_us=3_000), parts[2:]))
    assert len(before) and len(after)
    # The counts go on over both streams, where the detector's start again.
    alone = [Detector(net, window_us=3_000) for _ in range(2)]
    for d, stream in zip(alone, (parts[:2], parts[2:]), strict=True):
        detections(d, stream)
    assert (driver.events_seen, det.events_seen) == (len(events), len(new))
    assert driver.windows_opened == sum(d.windows_opened for d in alone) > det.windows_opened
    assert driver.detections_emitted == len(before) + len(after)


def test_the_windows_after_a_restart_carry_the_next_run(net: Network, events: np.ndarray) -> None:
    old, new = np.array_split(events, 2)
    old = old.copy()
    old["t"] += np.uint64(HOUR_US)
    parts = [*np.array_split(old, 2), *np.array_split(new, 2)]
    det = Detector(net, window_us=3_000)
    assert det.run == 0
    steps = list(driver_module.StreamDriver(ListSource(parts, restart_at=2), det, windows=True))
    runs = [[w.run for w in s.found] for s in steps if s.kind == "found"]
    first = [w for s in steps[:3] for w in s.found]
    assert det.run == 1 and first and all(r == 0 for run in runs[:3] for r in run)
    assert runs[3:] and all(r == 1 for run in runs[3:] for r in run)
    # The same reports as a detector of its own on the new stream gives, but for the run.
    alone = Detector(net, window_us=3_000)
    want = [w for c in parts[2:] for w in alone.push_windows(c)] + alone.flush_windows()
    got = [w for s in steps[4:] for w in s.found]
    assert [w.to_dict() for w in got] == [{**w.to_dict(), "run": 1} for w in want]


def test_the_stream_driver_stops_when_the_detector_was_stopped_part_way(
    net: Network, events: np.ndarray, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A refusal from a detector stopped inside its own work is not a chunk refused: the
    stream cannot go on, and the driver says so rather than count every later chunk."""
    parts = np.array_split(events, 3)
    det = Detector(net, window_us=3_000)
    pushed = []

    def stopped(chunk: np.ndarray) -> np.ndarray:
        # The first chunk goes in; the second finds the detector stopped part way before.
        if pushed:
            monkeypatch.setattr(Detector, "interrupted", property(lambda _self: True))
            raise StreamError("push() was interrupted part way; call reset()")
        pushed.append(chunk)
        return Detector.push(det, chunk)

    monkeypatch.setattr(det, "push", stopped)
    driver = driver_module.StreamDriver(ListSource(parts), det)
    steps = iter(driver)
    assert next(steps).kind == "found"
    with pytest.raises(StreamError, match="interrupted part way"):
        next(steps)
    assert driver.rejected == 0


# -- a quiet stream: the stream's time advanced without events -----------------------------------


def test_advancing_between_chunks_decides_sooner_and_changes_nothing(
    net: Network, events: np.ndarray
) -> None:
    plain = Detector(net, window_us=int(WINDOW_MS) * 1000)
    want = [plain.push(events), plain.flush()]
    # Chunks that end at a detection's time: only a later time decides it.
    spike_t = np.unique(np.concatenate(want)["t"])
    assert len(spike_t) > 3
    cuts = sorted({int(i) for i in np.searchsorted(events["t"], spike_t, "right")} - {len(events)})
    bounds = list(zip([0, *cuts], [*cuts, len(events)], strict=True))
    det = Detector(net, window_us=int(WINDOW_MS) * 1000)
    got, early = [], 0
    for a, b in bounds:
        got.append(det.push(events[a:b]))
        if b < len(events):
            found = det.advance(int(events["t"][b]))
            early += len(found)
            got.append(found)
    got.append(det.flush())
    assert early > 0  # some detections came out sooner
    np.testing.assert_array_equal(np.concatenate(got), np.concatenate(want))


def test_advancing_a_quiet_stream_reports_its_last_windows(
    net: Network, events: np.ndarray
) -> None:
    from uavsnn.errors import StreamError

    windows_us = int(WINDOW_MS) * 1000
    whole = Detector(net, window_us=windows_us)
    want = whole.push_windows(events) + whole.flush_windows()
    det = Detector(net, window_us=windows_us)
    got = det.push_windows(events)
    assert len(got) < len(want)  # the last windows wait for a later event...
    quiet = int(events["t"][-1]) + 10 * windows_us
    got += det.advance_windows(quiet)  # ...or for the stream's time to pass their end
    assert [(w.window, w.t0, w.detected, w.objects) for w in got] == [
        (w.window, w.t0, w.detected, w.objects) for w in want
    ]
    assert det.flush_windows() == []
    # A watermark is a promise: refused when it goes back, with nothing changed.
    det2 = Detector(net, window_us=windows_us)
    det2.push(events[:100])
    with pytest.raises(StreamError, match="already at"):
        det2.advance(int(events["t"][50]))
    assert not det2.interrupted
    with pytest.raises(ParameterError, match="t_us"):
        det2.advance(-1)
    det2.advance(int(events["t"][99]) + 5)
    with pytest.raises(StreamError, match="backwards"):
        det2.push(events[99:100])  # before the watermark


@pytest.mark.skipif(sys.platform == "win32", reason="select on a pipe")
def test_idle_flush_reports_a_quiet_streams_last_windows(
    model: Path,
    events: np.ndarray,
    child: Callable[[list[str]], subprocess.Popen[bytes]],
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    data = events.tobytes()
    code, ended, _ = run_in_process(detect_argv(model, "--json"), data, monkeypatch, capsys)
    assert code == 0
    # Live, the stream stays open after its burst: without --idle-flush its last windows wait
    # for a later event; with it they come out once it has been quiet for 0.2 s and more.
    proc = child(detect_argv(model, "--json", "--idle-flush", "0.2"))
    assert proc.stdin is not None and proc.stdout is not None
    proc.stdin.write(data)
    proc.stdin.flush()
    got = [proc.stdout.readline() for _ in range(len(ended))]  # before the stream ends
    assert all(got), got
    assert [json.loads(x) for x in got] == [json.loads(x) for x in ended]
    # An event stamped before the time the stream was taken to reach is dropped; a later one
    # is taken, and ends the stream as any would.
    late = events[-1:].copy()
    later = events[-1:].copy()
    later["t"] += np.uint64(10**9)
    out, err = proc.communicate(np.concatenate([late, later]).tobytes(), timeout=60)
    assert proc.returncode == 0, err.decode()[-2000:]
    assert len(out.decode().splitlines()) >= 1  # the later event's window, at the end
    summary = [line for line in err.decode().splitlines() if "detect: done" in line]
    assert summary and "dropped=0 rejected_events=1 " in summary[0] + " ", err.decode()
    assert f"events={len(events) + 1} " in summary[0]


def test_idle_flush_applies_to_live_sources(
    model: Path, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    path = tmp_path / "r.npy"
    np.save(path, blob_events(1, 50))
    argv = ["detect", str(path), "-m", str(model), "--idle-flush", "0.5"]
    one_line_exit_2(capsys, argv, "--idle-flush applies to live sources")
    # Among several sources it applies to the live ones (the file is not refused; several
    # sources then need Ray).
    argv = ["detect", str(path), "udp://127.0.0.1:0", "-m", str(model), "--idle-flush", "0.5"]
    one_line_exit_2(capsys, argv, "several sources need --ray")
    for bad in ("0", "-1", "inf", "nan"):
        one_line_exit_2(capsys, [*detect_argv(model), "--idle-flush", bad], "--idle-flush must")


def test_a_quiet_udp_source_beats_until_its_idle_timeout() -> None:
    packets = udp_packets(2)
    with (
        UdpSource(LOOPBACK, 0, sensor_size=SMALL_SENSOR, idle_timeout=0.6, heartbeat_s=0.05) as src,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s,
    ):
        for p in packets:
            s.sendto(p, src.address)
        chunks = list(src)
    full = [c for c in chunks if len(c)]
    assert len(full) == 2 and np.array_equal(np.concatenate(full), np.concatenate(
        [np.frombuffer(p, dtype=EVENT_DTYPE) for p in packets]
    ))  # fmt: skip
    beats = len(chunks) - len(full)
    assert 3 <= beats <= 13  # about one every 0.05 s of the 0.6 s of silence
    with pytest.raises(ParameterError, match="heartbeat_s"):
        UdpSource(LOOPBACK, 0, sensor_size=SMALL_SENSOR, heartbeat_s=0)
