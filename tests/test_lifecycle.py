"""The package in a program's lifecycle: arrays changed by another thread during an engine
call, engine calls in a forked child, and the size of rayon's pool from the environment. Each
case runs in a fresh interpreter under a timeout, so that a crash or a hang fails the test
rather than the suite."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from conftest import kill_group

from uavsnn import Detector, Network, RotorSignature, StreamError
from uavsnn.events import EVENT_DTYPE

EVENTS = """
import numpy as np
import uavsnn
from uavsnn.network import Network
from uavsnn.windows import make_windows


def events(n, seed):
    # A blob crossing the sensor over noise: conv1 fires in every window.
    r = np.random.default_rng(seed)
    e = np.zeros(n, uavsnn.EVENT_DTYPE)
    e["t"] = np.sort(r.integers(0, 1_000_000, n))
    k = r.random(n) < 0.7
    e["x"] = np.where(k, (40 + e["t"] // 10_000 + r.integers(0, 8, n)) % 240, r.integers(0, 240, n))
    e["y"] = np.where(k, 90 + r.integers(0, 8, n), r.integers(0, 180, n))
    e["p"] = r.random(n) < 0.5
    return uavsnn.Recording(e, (240, 180))


def interrupted(name, call, busy):
    # Run call(); as soon as another thread sees it hold its object (busy() raises a
    # StreamError), send SIGINT. Returns the seconds the call ran until Ctrl-C stopped it.
    # Ctrl-C's own handler, whatever this process inherited: a job started in the background
    # by a non-interactive shell (a CI runner) ignores SIGINT, and Python then installs none.
    import os, signal, threading, time
    signal.signal(signal.SIGINT, signal.default_int_handler)
    done = threading.Event()
    def watch():
        while not done.is_set():
            try:
                busy()
            except uavsnn.StreamError:  # the call holds the object: it runs
                os.kill(os.getpid(), signal.SIGINT)
                return
            time.sleep(0.001)
    watcher = threading.Thread(target=watch)
    watcher.start()
    began = time.monotonic()
    try:
        call()
    except KeyboardInterrupt:
        return time.monotonic() - began
    finally:
        done.set()
        watcher.join()
    raise SystemExit(f"{name}: not interrupted")


def infer_stops_part_way(net, w):
    # net.infer(w) on one thread whole, then interrupted: it stops in under half the whole
    # call's time, and the network is unchanged.
    import time
    began = time.monotonic()
    whole = net.infer(w, threads=1).counts
    full = time.monotonic() - began
    same = net.weights("conv2")
    took = interrupted(
        "infer", lambda: net.infer(w, threads=1), lambda: net.set_weights("conv2", same)
    )
    assert took < 0.5 * full, (took, full)
    assert (net.infer(w, threads=1).counts == whole).all()


def job(seed, threads=None):
    # More than 250,000 events: make_windows works on rayon's global pool.
    w = make_windows(events(300_000, seed), 50_000)
    out = Network().infer(w, threads=threads)
    return len(w), out.counts.sum(axis=0).tolist()
"""


def run(code: str, timeout: float = 180, **env: str) -> subprocess.CompletedProcess[str]:
    """``code`` after :data:`EVENTS` in a fresh interpreter of its own process group, killed
    whole (forked children included) when it runs past ``timeout`` seconds."""
    script = textwrap.dedent(EVENTS) + textwrap.dedent(code)
    with subprocess.Popen(
        [sys.executable, "-c", script],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, **env},
        start_new_session=True,
    ) as proc:
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            kill_group(proc)
            proc.communicate()
            pytest.fail(f"still running after {timeout} s (a hang)")
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="os.fork is a POSIX call")
def test_the_engine_works_in_a_forked_child_after_the_parent_used_its_pools() -> None:
    # The parent's rayon pools (global, and one of 2 workers) are copied into a forked child
    # without their threads: work handed to them there waited forever.
    out = run(
        """
        import multiprocessing as mp
        parent = [job(1), job(2, threads=2)]
        assert parent[0][1][0] > 0, parent  # conv1 fired
        with mp.get_context("fork").Pool(2) as p:
            children = p.starmap(job, [(1,), (2, 2)])
        assert children == parent, (children, parent)
        print("ok")
        """
    )
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="counts threads in /proc")
def test_a_forked_child_takes_as_many_workers_as_rayon_num_threads_says() -> None:
    # RAYON_NUM_THREADS=1 is how a pool of worker processes keeps each to one thread; a
    # forked child's own pool took one worker per core whatever it said.
    out = run(
        """
        import multiprocessing as mp, os

        def threads():
            return len(os.listdir("/proc/self/task"))

        def child_job(_):
            before = threads()
            job(3)
            return threads() - before

        job(1)  # the parent's pools started
        with mp.get_context("fork").Pool(1) as p:
            print(p.map(child_job, [0])[0])
        """,
        RAYON_NUM_THREADS="1",
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert int(out.stdout.strip()) == 1  # one worker started in the child


def test_arrays_rewritten_by_another_thread_during_a_call_cannot_crash_the_engine() -> None:
    # The engine checks a window's coordinates once and trusts them; it reads them without the
    # GIL. A thread rewriting the caller's arrays meanwhile made checked coordinates out of
    # range (a segmentation fault): the engine reads its own copy now.
    out = run(
        """
        import threading, time
        net = Network()
        n = 4000
        r = np.random.default_rng(0)
        t = np.sort(r.integers(0, 50_000, n)).astype(np.uint64)
        good_x = r.integers(0, 240, n).astype(np.uint16)
        good_y = r.integers(0, 180, n).astype(np.uint16)
        x, y = good_x.copy(), good_y.copy()
        stop = time.monotonic() + 3
        def rewrite():
            while time.monotonic() < stop:
                x[:] = 65535; y[:] = 65535; x[:] = good_x; y[:] = good_y
        writer = threading.Thread(target=rewrite)
        writer.start()
        refused = ran = 0
        while time.monotonic() < stop:
            try:
                net.run_window(t, x, y, 0)
                ran += 1
            except uavsnn.EventError:
                refused += 1  # seen out of the sensor when copied: a typed refusal
        writer.join()
        print(ran, refused)
        """
    )
    assert out.returncode == 0, (out.returncode, out.stderr)
    # Both outcomes were seen: calls ran while the other thread rewrote the arrays.
    ran, refused = map(int, out.stdout.split())
    assert ran > 0 and refused > 0, (ran, refused)


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="counts threads in /proc")
def test_rayon_num_threads_beyond_the_cap_is_capped() -> None:
    # RAYON_NUM_THREADS=100000 failed to start the pool and every parallel call then raised
    # an internal error; 2000 started 2000 threads for a call of milliseconds.
    out = run(
        """
        import os
        from uavsnn.network import MAX_THREADS
        assert job(3)[0] == 20
        print(len(os.listdir("/proc/self/task")) <= MAX_THREADS + 32)
        """,
        RAYON_NUM_THREADS="100000",
    )
    assert out.returncode == 0 and out.stdout.strip() == "True", out.stderr[-2000:]


def _collisions(call: Callable[[], object], read: Callable[[], object]) -> list[type]:
    """The exception types ``read`` raised while ``call`` ran on another thread."""
    seen: list[type] = []
    worker = threading.Thread(target=call)
    worker.start()
    while worker.is_alive():
        try:
            read()
        except Exception as exc:
            seen.append(type(exc))
    worker.join()
    return seen


def _blob(n: int) -> np.ndarray:
    r = np.random.default_rng(5)
    e = np.zeros(n, dtype=EVENT_DTYPE)
    e["t"] = np.sort(r.integers(0, 20_000_000, n))
    e["x"] = r.integers(0, 240, n)
    e["y"] = r.integers(0, 180, n)
    return e


def test_a_call_while_another_thread_holds_the_object_is_a_typed_error() -> None:
    # push and update let the GIL go holding their object; a monitoring thread reading it
    # meanwhile got pyo3's untyped RuntimeError("Already mutably borrowed").
    events = _blob(3_000_000)
    det = Detector(Network(), window_us=50_000)
    seen = _collisions(lambda: det.push(events), lambda: det.events_seen)
    assert seen and set(seen) == {StreamError}, seen
    assert det.events_seen == len(events)  # the push went through
    est = RotorSignature((0, 0, 240, 180))
    seen = _collisions(lambda: est.update(events), lambda: est.stats)
    assert seen and set(seen) == {StreamError}, seen


def test_ctrl_c_stops_a_long_engine_call_part_way() -> None:
    # Ctrl-C waited for the whole call (11 s for a long batch of frames); the engine now
    # checks Python's signals between parts of its work. Each call below runs for tenths of a
    # second or more: the SIGINT comes as soon as another thread sees the call hold its object
    # (a StreamError from a probe), and the call stops part way through its input.
    out = run(
        """
        from uavsnn.sim.dvs import DvsEmulator

        # The emulator: 400 frames of 640x480, a moving gradient.
        n = 400
        ys, xs = np.mgrid[0:480, 0:640].astype(np.float32)
        frames = np.stack([(xs + 7 * k) % 256 for k in range(n)]).astype(np.uint8)
        times = np.arange(n, dtype=np.uint64) * 1000
        emu = DvsEmulator((640, 480))
        interrupted("emulator", lambda: emu.process(frames, times), lambda: emu.frames_seen)
        assert 0 < emu.frames_seen < n, emu.frames_seen
        try:
            emu.process(frames[:1], times[-1:] + 1000)
        except uavsnn.SimulationError as exc:
            assert "interrupted part way" in str(exc)
        else:
            raise SystemExit("an interrupted emulator went on")

        # A push of a long chunk: the detector stops between slices, and says so after.
        det = uavsnn.Detector(Network(), window_us=50_000)
        chunk = events(6_000_000, 5).events  # tenths of a second of the engine's work
        interrupted("push", lambda: det.push(chunk), lambda: det.events_seen)
        assert det.interrupted and 0 < det.events_seen < len(chunk), det.events_seen
        try:
            det.push(chunk[-1:])
        except uavsnn.StreamError as exc:
            assert "interrupted" in str(exc)
        else:
            raise SystemExit("an interrupted detector went on")

        # Inference: the same batch whole, then interrupted; the network is unchanged. Each
        # event is in 20 windows (about 12 million input spikes).
        w = make_windows(events(2_000_000, 4), 5_000, overlap=0.95)
        net = Network()
        infer_stops_part_way(net, w)  # a part or two of about 0.1 s, of 1 s or more
        print("ok")
        """
    )
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-3000:]


def test_ctrl_c_stops_inference_over_a_few_slow_windows() -> None:
    # The engine checks Python's signals between parts of a batch; a part was at least 64
    # windows per worker, so over fewer windows than that, each slow (a static network under
    # heavy noise at 1280x720 takes tens of seconds a window), Ctrl-C waited for the whole
    # call. The first part is a window per worker now: it stops after about one.
    out = run(
        """
        from uavsnn.network import default_config
        from uavsnn.training import apply_overrides

        r = np.random.default_rng(4)
        n = 3_000_000
        e = np.zeros(n, uavsnn.EVENT_DTYPE)
        e["t"] = np.sort(r.integers(0, 1_500_000, n))
        e["x"], e["y"] = r.integers(0, 240, n), r.integers(0, 180, n)
        e["p"] = r.random(n) < 0.5
        w = make_windows(uavsnn.Recording(e, (240, 180)), 25_000)
        assert len(w) < 64, len(w)
        # Static thresholds on dense input: every layer fires widely, milliseconds a window.
        net = Network(apply_overrides(default_config(), ["pent.mode=static"]))
        infer_stops_part_way(net, w)
        print("ok")
        """
    )
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-3000:]
