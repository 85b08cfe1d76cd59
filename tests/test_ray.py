"""Ray (uavsnn.distributed): on a local cluster of 2 CPUs on the loopback interface, started once
for this module, a build is the serial build array for array, a reproduce gives the serial
figures, and several UDP streams run through one actor each with every event accounted for;
a dead stream is reported while the others finish. Without Ray these tests skip, except
those that check that uavsnn never needs it."""

from __future__ import annotations

import json
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import blob_events

from uavsnn import Network
from uavsnn.cli import main
from uavsnn.dataset import build, load, read_manifest
from uavsnn.dataset.synthetic import SceneSource
from uavsnn.errors import DatasetError, ParameterError
from uavsnn.experiments import NOISE_FRACTIONS

try:
    import ray
except ImportError:  # the extra is not installed
    ray = None

needs_ray = pytest.mark.skipif(
    ray is None, reason="Ray is not installed: pip install '.[test,ray]' (the 'ray' extra)"
)
DVS = SceneSource("dvs", (240, 180), 200.0, 0.3)


@pytest.fixture(scope="module")
def runner() -> Any:
    """A local Ray cluster of 2 CPUs and a 256 MiB object store (Ray spills beyond it) on
    127.0.0.1, for this module only: by default Ray's store takes 30 % of the machine's
    memory, which a test has no business holding."""
    if ray is None:
        pytest.skip("Ray is not installed: pip install '.[test,ray]' (the 'ray' extra)")
    from uavsnn import distributed

    ray.init(
        num_cpus=2,
        object_store_memory=256 * 1024**2,
        include_dashboard=False,
        _node_ip_address="127.0.0.1",
        logging_level="WARNING",
        log_to_driver=False,
    )
    try:
        yield distributed.connect()
    finally:
        ray.shutdown()


# -- without Ray ----------------------------------------------------------------------------


def test_uavsnn_and_its_command_never_import_ray() -> None:
    code = (
        "import sys, contextlib, io\n"
        "import uavsnn, uavsnn.dataset, uavsnn.experiments, uavsnn.distributed\n"
        "from uavsnn.cli import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    for argv in (['--help'], ['dataset', 'build', '--help'], ['detect', '--help'],\n"
        "                 ['reproduce', '--help']):\n"
        "        try:\n"
        "            main(argv)\n"
        "        except SystemExit:\n"
        "            pass\n"
        "print('ray' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_ray_missing_is_one_line_and_exit_2(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` raises ImportError
    argv = ["dataset", "build", str(tmp_path / "d"), "--domain", "dvs", "--ray"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "uavsnn[ray]" in err
    assert not (tmp_path / "d").exists()


def test_several_streams_need_ray(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["detect", "a.npy", "b.npy", "-m", str(tmp_path / "m.npz")]) == 2
    assert "--ray" in capsys.readouterr().err


@needs_ray
def test_unreachable_address_fails_fast_with_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with socket.socket() as s:  # a port where nothing listens
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    started = time.monotonic()
    argv = ["dataset", "build", str(tmp_path / "d"), "--domain", "dvs"]
    assert main([*argv, "--ray", f"127.0.0.1:{port}"]) == 2
    assert time.monotonic() - started < 10
    err = capsys.readouterr().err.strip()
    assert f"cannot reach a Ray cluster at 127.0.0.1:{port}" in err and len(err.splitlines()) == 1
    assert main([*argv, "--ray", "nonsense"]) == 2
    assert "HOST:PORT" in capsys.readouterr().err
    assert not (tmp_path / "d").exists()


@needs_ray
def test_an_address_that_is_no_ray_cluster_fails_fast_with_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """ray.init waited without end (deaf to Ctrl-C) on a port where something else listens:
    a web server (a Ray dashboard), or a listener that never answers."""
    import http.server
    import threading

    class Quiet(http.server.BaseHTTPRequestHandler):
        def log_message(self, *args: object) -> None:
            pass

    web = http.server.HTTPServer(("127.0.0.1", 0), Quiet)
    threading.Thread(target=web.serve_forever, daemon=True).start()
    silent = socket.socket()
    silent.bind(("127.0.0.1", 0))
    silent.listen()
    argv = ["dataset", "build", str(tmp_path / "d"), "--domain", "dvs", "--ray"]
    try:
        for port in (web.server_port, silent.getsockname()[1]):
            started = time.monotonic()
            assert main([*argv, f"127.0.0.1:{port}"]) == 2
            assert time.monotonic() - started < 30
            err = capsys.readouterr().err.strip()
            assert "does not answer as a Ray cluster" in err and len(err.splitlines()) == 1
    finally:
        web.shutdown()
        silent.close()
    assert main([*argv, "[::1"]) == 2  # a ValueError traceback
    assert "bad Ray address" in capsys.readouterr().err
    assert not (tmp_path / "d").exists()


@pytest.mark.parametrize(
    "kwargs",
    [
        {"timeout_s": -1},
        {"timeout_s": float("nan")},
        {"timeout_s": "5"},
        {"timeout_s": True},
        {"num_cpus": "x"},
        {"num_cpus": 0},
        {"num_cpus": 257},
    ],
)
def test_connect_refuses_bad_arguments_before_anything(kwargs: dict[str, Any]) -> None:
    from uavsnn import distributed
    from uavsnn.errors import ParameterError

    with pytest.raises(ParameterError, match=next(iter(kwargs))):
        distributed.connect("127.0.0.1:1", **kwargs)


def test_a_ray_clusters_own_port_passes_the_check(runner: Any) -> None:
    from uavsnn.distributed import cluster

    cluster._check_reachable(ray.get_runtime_context().gcs_address, 5.0)


# -- datasets -------------------------------------------------------------------------------


def _same_dataset(a: Path, b: Path) -> None:
    assert read_manifest(a) == read_manifest(b)
    files = sorted(p.name for p in a.glob("*.npz"))
    assert files == sorted(p.name for p in b.glob("*.npz")) and files
    for name in files:
        with np.load(a / name) as za, np.load(b / name) as zb:
            assert sorted(za.files) == sorted(zb.files)
            for key in za.files:
                x, y = za[key], zb[key]
                assert x.dtype == y.dtype and x.shape == y.shape, key
                assert np.array_equal(x, y, equal_nan=x.dtype.kind == "f"), (name, key)


@pytest.fixture
def ray_tasks(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The names of the functions that ran as Ray tasks (their handle a Ray object reference)
    while the test runs: a run compared with the serial one must have gone through Ray, or the
    comparison shows nothing."""
    from uavsnn.distributed import RayRunner

    names: list[str] = []
    submit = RayRunner.submit

    def counted(self: Any, fn: Callable[..., Any], *args: Any) -> Any:
        handle = submit(self, fn, *args)
        if isinstance(handle, ray.ObjectRef):
            names.append(getattr(fn, "__name__", repr(fn)))
        return handle

    monkeypatch.setattr(RayRunner, "submit", counted)
    return names


def test_ray_build_is_the_serial_build(runner: Any, tmp_path: Path, ray_tasks: list[str]) -> None:
    kwargs: dict[str, Any] = {"n_test": 20, "n_train": 16, "seed": 3, "dvs": DVS}
    serial = build(tmp_path / "serial", "dvs", **kwargs).root
    assert not ray_tasks
    on_ray = build(tmp_path / "ray", "dvs", runner=runner, **kwargs).root
    _same_dataset(serial, on_ray)
    recordings = len(read_manifest(on_ray)["recordings"])
    assert recordings > 2 and len(ray_tasks) >= recordings  # a task a recording, at least


def test_ray_build_of_real_footage_is_the_serial_build(
    runner: Any,
    tmp_path: Path,
    write_clip: Callable[..., None],
    capsys: pytest.CaptureFixture[str],
    ray_tasks: list[str],
) -> None:
    videos = tmp_path / "videos"
    videos.mkdir()
    for i, cls in enumerate(("DRONE", "DRONE", "BIRD", "BIRD", "AIRPLANE")):
        path = [(40 + (4 + i) * k, 60 + 2 * k) for k in range(30)]
        write_clip(videos, f"V_{cls}_{i + 1:03d}", path)
    kwargs: dict[str, Any] = {"videos": videos, "n_test": 10, "n_train": None, "seed": 1}
    serial = build(tmp_path / "serial", "real", **kwargs).root
    on_ray = build(tmp_path / "ray", "real", runner=runner, **kwargs).root
    _same_dataset(serial, on_ray)
    assert len(ray_tasks) >= 5  # a clip a task, at least
    # Its test clips streamed whole, a clip a task: the serial figures.
    from uavsnn.clips import evaluate_clips

    net = Network({"width": 240, "height": 180, "conv2": {"threshold": 10.0}}, seed=0)
    ray_tasks.clear()
    clips = evaluate_clips(net, serial, videos=videos)
    assert not ray_tasks
    assert evaluate_clips(net, serial, videos=videos, runner=runner) == clips
    assert clips["clips"] > 1 and len(ray_tasks) >= clips["clips"]
    net.save(tmp_path / "m.npz")
    argv = ["evaluate", str(tmp_path / "m.npz"), str(serial), "--clips", "--videos", str(videos)]
    ray_tasks.clear()
    assert main([*argv, "--json", "--ray"]) == 0
    assert json.loads(capsys.readouterr().out)["clips"] == clips
    assert len(ray_tasks) >= clips["clips"]


def test_interrupted_ray_build_leaves_no_dataset(
    runner: Any, tmp_path: Path, ray_tasks: list[str]
) -> None:
    calls = []

    def interrupt(msg: str) -> None:
        calls.append(msg)
        if len(calls) == 2:
            raise KeyboardInterrupt

    out = tmp_path / "d"
    with pytest.raises(KeyboardInterrupt):
        build(out, "dvs", n_test=20, n_train=16, seed=3, dvs=DVS, runner=runner, progress=interrupt)
    assert ray_tasks  # interrupted with tasks on the cluster
    assert not (out / "manifest.json").exists()
    with pytest.raises(DatasetError):
        load(out, "test")
    # Nothing is left running for the build: the cluster's CPUs are free again.
    deadline = time.monotonic() + 10
    while ray.available_resources().get("CPU", 0) < 2 and time.monotonic() < deadline:
        time.sleep(0.1)
    assert ray.available_resources().get("CPU", 0) == 2


# -- experiments ----------------------------------------------------------------------------

_TIMINGS = {"seconds", "command", "rate", "events_per_second", "ns_per_event"}


def _figures(obj: Any) -> Any:
    """results.json without what depends on the clock or the command line."""
    if isinstance(obj, dict):
        return {k: _figures(v) for k, v in obj.items() if k not in _TIMINGS}
    if isinstance(obj, list):
        return [_figures(v) for v in obj]
    return obj


def test_ray_reproduce_gives_the_serial_figures(
    runner: Any, tmp_path: Path, ray_tasks: list[str]
) -> None:
    # Tiny datasets, built once and given to both runs (the builds are compared above).
    data = tmp_path / "data"
    build(data / "dvs", "dvs", n_test=20, n_train=30, seed=0, dvs=DVS)
    sim = SceneSource("sim", (320, 240), 30.0, 1.0)
    build(data / "sim", "sim", n_test=10, n_train=30, seed=0, sim=sim)
    build(data / "tune-dvs", "dvs", n_test=2, n_train=30, seed=1, dvs=DVS)
    build(data / "tune-sim", "sim", n_test=2, n_train=30, seed=1, sim=sim)
    figures = []
    for name, extra in (("serial", []), ("ray", ["--ray"])):
        out = tmp_path / name
        shutil.copytree(data, out / "data")
        argv = ["reproduce", "--out", str(out), "--n-train", "30", "--n-test", "20"]
        argv += ["--windows-per-layer", "30", "--no-real", "--quiet", "--free-minutes", "0.05"]
        argv += extra
        ray_tasks.clear()
        assert main(argv) == 0
        assert bool(ray_tasks) == bool(extra), ray_tasks  # the --ray run went through Ray
        figures.append(_figures(json.loads((out / "results.json").read_text())))
        text = (out / "RESULTS.md").read_text()
        assert "## Real footage\n\nNot run: --no-real was given." in text
        for model in ("model-dvs.npz", "model-combined.npz"):
            assert Network.load(out / model) == Network.load(tmp_path / "serial" / model)
    assert figures[0] == figures[1]
    assert len(figures[1]["noise"]) == 2 * len(NOISE_FRACTIONS) and "table2" in figures[1]
    assert figures[1]["false_alarms"]["dvs"]["recordings"] == 3


# -- many streams ---------------------------------------------------------------------------


def _events(n: int, seed: int, t0: int = 0) -> np.ndarray:
    """A blob drifting over sparse noise (``conftest.blob_events``), from ``t0``: the model
    below detects it in most windows, so the streams' detections compared are not empty."""
    return blob_events(seed, n, t0=t0 + 5_000)


@pytest.fixture(scope="module")
def model() -> Network:
    return Network(seed=4)


def test_a_stream_worker_polls_without_touching_the_busy_detector(
    model: Network, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """poll runs in the actor's other thread while push holds the detector (the engine call
    releases the GIL): it must read the counters the worker thread left, never the detector
    (a getter there raised "Already mutably borrowed" once in a while). No Ray needed."""
    import threading

    import uavsnn.detector
    from uavsnn.distributed.streams import _StreamWorker
    from uavsnn.events import Recording
    from uavsnn.io import write_npz

    strangers: list[str] = []

    class Watched(uavsnn.detector.Detector):
        def __getattribute__(self, name: str) -> Any:
            if not name.startswith("_") and not threading.current_thread().name.startswith(
                "uavsnn-"
            ):
                strangers.append(name)
            return super().__getattribute__(name)

    monkeypatch.setattr(uavsnn.detector, "Detector", Watched)
    path = tmp_path / "rec.npz"
    write_npz(Recording(_events(20_000, 9), (240, 180)), path)
    worker = _StreamWorker("cam", str(path), model, {"window_us": 20_000, "overlap": 0.5})
    seen, done, found = 0, False, 0
    while not done:
        part, counts, done = worker.poll(0.05)
        found += len(part)
        seen = counts["events_seen"]
    assert strangers == []
    assert seen == 20_000 and counts["windows"] > 0 and counts["error"] is None


def test_a_stream_worker_drops_a_chunk_stamped_wholly_before_the_idle_mark(
    model: Network,
) -> None:
    """A quiet stream advanced with the wall clock (idle_flush_s): a packet that arrives
    stamped wholly before the time reached is rejected, and the stream goes on (the worker
    once pushed the empty rest and failed). No Ray needed."""
    from uavsnn.distributed.streams import _StreamWorker

    burst = _events(1_000, 12)
    # After the burst's last event (so the packet decoder takes it, in time order) but before
    # the time the quiet stream is then taken to have reached.
    late = burst[-10:].copy()
    late["t"] = burst["t"][-1] + np.arange(1, 11, dtype=np.uint64)
    later = burst[-1:].copy()
    later["t"] += np.uint64(10**9)
    options = {"window_us": 20_000, "overlap": 0.5, "idle_flush_s": 0.1, "max_packets": 3,
               "idle_timeout": 30.0}  # fmt: skip
    worker = _StreamWorker("cam", "udp://127.0.0.1:0", model, options)
    address = worker.bound()
    assert address is not None
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.sendto(burst.tobytes(), address)
        deadline = time.monotonic() + 20
        while worker.driver.idle.reached <= int(late["t"][-1]) and time.monotonic() < deadline:
            time.sleep(0.05)  # until the quiet stream has been advanced past those times
        assert worker.driver.idle.reached > int(late["t"][-1])
        s.sendto(late.tobytes(), address)
        s.sendto(later.tobytes(), address)
        done, counts = False, {}
        while not done and time.monotonic() < deadline + 20:
            _, counts, done = worker.poll(0.2)
    assert done and counts["error"] is None, counts
    assert counts["rejected_events"] == len(late)
    assert counts["events_seen"] == len(burst) + 1


def test_more_streams_than_allowed_are_refused_before_any_actor(
    runner: Any, model: Network
) -> None:
    from uavsnn.distributed import MAX_STREAMS, detect_streams
    from uavsnn.errors import ParameterError

    sources = [f"missing-{i}.npz" for i in range(MAX_STREAMS + 1)]
    with pytest.raises(ParameterError, match=f"{MAX_STREAMS + 1} streams: at most"):
        detect_streams(runner, sources, model)


def test_four_udp_streams_through_four_actors(runner: Any, model: Network) -> None:
    packets, per_packet = 30, 200
    streams = {f"cam{k}": _events(packets * per_packet, k) for k in range(4)}
    sent: dict[str, int] = {}

    def send(addresses: dict[str, Any], _actors: Any) -> None:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            for name, events in streams.items():
                for i in range(packets):
                    chunk = events[i * per_packet : (i + 1) * per_packet]
                    s.sendto(chunk.tobytes(), addresses[name])
                    sent[name] = sent.get(name, 0) + len(chunk)

    from uavsnn.distributed import detect_streams

    got: dict[str, list[np.ndarray]] = {name: [] for name in streams}
    results = detect_streams(
        runner,
        ["udp://127.0.0.1:0"] * 4,
        model,
        names=list(streams),
        window_us=20_000,
        on_ready=send,
        on_detections=lambda name, found: got[name].append(found),
        max_packets=packets,
        idle_timeout=20.0,
    )
    assert set(results) == set(streams)
    for name, r in results.items():
        assert r.ok, r.error
        assert r.packets == packets and r.dropped == 0
        assert r.events == sent[name] == r.events_seen + r.rejected_events
        assert r.rejected_events == 0
        # The same detections as one Detector on the same events, in time order.
        from uavsnn import Detector

        det = Detector(model, window_us=20_000)
        want = np.concatenate([det.push(streams[name]), det.flush()])
        assert np.array_equal(r.detections, want)
        assert np.all(np.diff(r.detections["t"].astype(np.int64)) >= 0)
        both = np.concatenate(got[name]) if got[name] else r.detections[:0]
        assert np.array_equal(both, r.detections)


def test_a_stream_whose_sensor_restarts_starts_its_detector_again(
    runner: Any, model: Network
) -> None:
    from uavsnn import Detector
    from uavsnn.distributed import detect_streams

    per_packet, packets = 200, 30
    old = _events(packets * per_packet, 7, t0=3_600_000_000)  # an hour in
    new = _events(packets * per_packet, 8)  # then restarted: from 0 again

    def send(addresses: dict[str, Any], _actors: Any) -> None:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            for events in (old, new):
                for i in range(packets):
                    s.sendto(events[i * per_packet : (i + 1) * per_packet].tobytes(),
                             addresses["cam"])  # fmt: skip

    updates: list[tuple[int, int]] = []
    results = detect_streams(
        runner, ["udp://127.0.0.1:0"], model, names=["cam"], window_us=20_000,
        on_ready=send, max_packets=2 * packets, idle_timeout=20.0,
        on_update=lambda r: updates.append((r.restarts, r.events_seen)),
    )  # fmt: skip
    r = results["cam"]
    assert r.ok, r.error
    assert (r.restarts, r.dropped, r.rejected_events) == (1, 0, 0)
    # Each poll's result as it stood, the last with the restart; the counts growing.
    assert updates[-1] == (1, r.events_seen)
    assert [u[1] for u in updates] == sorted(u[1] for u in updates)
    # The detections of one detector on the old stream, then of a fresh one on the whole new
    # stream (the packets refused before the restart were held and taken back).
    want = []
    for events in (old, new):
        det = Detector(model, window_us=20_000)
        want += [det.push(events), det.flush()]
    assert np.array_equal(r.detections, np.concatenate(want))
    assert r.events_seen == len(old) + len(new)


def test_a_quiet_stream_on_ray_reports_its_last_windows_with_idle_flush(
    runner: Any, model: Network
) -> None:
    import threading

    from uavsnn import Detector
    from uavsnn.distributed import detect_streams

    per_packet, packets = 200, 10
    burst = _events(packets * per_packet, 9)
    det = Detector(model, window_us=20_000)
    want = np.concatenate([det.push(burst), det.flush()])
    assert len(want)
    later = burst[-1:].copy()
    later["t"] += np.uint64(10**9)  # far after any time the quiet stream is taken to reach
    got: list[np.ndarray] = []
    all_in = threading.Event()
    before_the_end: list[bool] = []

    def found(_name: str, chunk: np.ndarray) -> None:
        got.append(chunk)
        if sum(map(len, got)) >= len(want):
            all_in.set()

    def send(addresses: dict[str, Any], _actors: Any) -> None:
        def run() -> None:
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                for i in range(packets):
                    s.sendto(burst[i * per_packet : (i + 1) * per_packet].tobytes(),
                             addresses["cam"])  # fmt: skip
                # Quiet: the burst's last windows come out without another event...
                before_the_end.append(all_in.wait(30))
                # ... and the stream ends with its next packet.
                s.sendto(later.tobytes(), addresses["cam"])

        threading.Thread(target=run, daemon=True).start()

    results = detect_streams(
        runner, ["udp://127.0.0.1:0"], model, names=["cam"], window_us=20_000,
        on_ready=send, on_detections=found, max_packets=packets + 1, idle_timeout=60.0,
        idle_flush_s=0.2,
    )  # fmt: skip
    r = results["cam"]
    assert r.ok, r.error
    assert before_the_end == [True]
    assert np.array_equal(r.detections[: len(want)], want)
    assert (r.rejected_events, r.events_seen) == (0, len(burst) + 1)


@pytest.mark.parametrize("bad", [0, -1.0, float("inf"), float("nan")])
def test_idle_flush_on_ray_is_checked_before_any_actor(
    runner: Any, model: Network, bad: float
) -> None:
    from uavsnn.distributed import detect_streams

    with pytest.raises(ParameterError, match="idle_flush_s must be"):
        detect_streams(runner, ["udp://127.0.0.1:0"], model, idle_flush_s=bad)


def test_a_killed_stream_is_reported_and_the_others_finish(
    runner: Any, model: Network, tmp_path: Path
) -> None:
    files = []
    for k in range(2):
        files.append(tmp_path / f"f{k}.npy")
        np.save(files[-1], _events(5000, 10 + k))

    def kill_udp(_addresses: dict[str, Any], actors: dict[str, Any]) -> None:
        ray.kill(actors["live"], no_restart=True)

    from uavsnn.distributed import detect_streams

    results = detect_streams(
        runner,
        [str(files[0]), "udp://127.0.0.1:0", str(files[1])],
        model,
        names=["a", "live", "b"],
        on_ready=kill_udp,
        sensor_size=(240, 180),
        idle_timeout=30.0,
    )
    assert not results["live"].ok and "died" in (results["live"].error or "")
    for name in ("a", "b"):
        assert results[name].ok and results[name].events == 5000 == results[name].events_seen


def test_detect_command_over_several_files(
    runner: Any, model: Network, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model.save(tmp_path / "m.npz")
    files = []
    for k in range(2):
        files.append(str(tmp_path / f"s{k}.npy"))
        np.save(files[-1], _events(3000, 20 + k))
    argv = ["detect", *files, "-m", str(tmp_path / "m.npz"), "--json", "--per-spike", "--ray"]
    # An .npy recording's sensor is its events' bounding box unless given: here the blob's
    # corner, which the model refuses, and the stream says why.
    assert main(argv) == 1
    err = capsys.readouterr().err
    # One line per stream, saying what fits (no actor's traceback: it did not fail to start).
    assert f"{files[0]}: failed (ParameterError: {files[0]} records no sensor size" in err
    assert "--sensor-size 240x180" in err and "Traceback" not in err
    assert main([*argv, "--sensor-size", "240x180"]) == 0
    captured = capsys.readouterr()
    lines = [json.loads(line) for line in captured.out.splitlines()]
    from uavsnn import Detector

    for name in files:
        mine = [d["t"] for d in lines if d["stream"] == name]
        # What one Detector finds in the file, in time order (the command's defaults).
        det = Detector(model, window_us=50_000, overlap=0.5)
        events = np.load(name)
        want = np.concatenate([det.push(events), det.flush()])["t"].tolist()
        assert want and mine == want
        assert re.search(rf"{re.escape(name)}: done [0-9.]+s events=3000 ", captured.err)


def _identified(model: Network) -> Network:
    """``model`` with a small identification (two shape features; points set for 1 % and 5 %
    false alarms), so that the window lines carry UAV scores and class guesses."""
    from dataclasses import replace

    from uavsnn.identify import Identifier

    net = model.copy()
    ident = Identifier(
        ("log_width", "log_height"), np.array([0.5, -0.25, 0.1]), np.zeros(2), np.ones(2),
        0.4, 1.0,
    )  # fmt: skip
    net.identification = replace(ident, alarm_thresholds=((0.01, 0.62), (0.05, 0.55)))
    return net


def test_several_files_on_ray_print_one_streams_window_lines(
    runner: Any, model: Network, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """SPEC §6: the same command on Ray gives what one machine gives. Each stream's window
    lines (objects, tracks, UAV scores and classes, at the operating point and confirmation
    rule given) are those ``uavsnn detect`` prints for that file alone, led by its name."""
    _identified(model).save(tmp_path / "m.npz")
    files = []
    for k in range(2):
        files.append(str(tmp_path / f"s{k}.npy"))
        np.save(files[-1], _events(3000, 30 + k))
    opts = ["-m", str(tmp_path / "m.npz"), "--sensor-size", "240x180"]
    opts += ["--false-alarm", "0.05", "--confirm", "2/3"]
    for as_json in (True, False):
        fmt = ["--json"] if as_json else []
        assert main(["detect", *files, *opts, *fmt, "--ray"]) == 0
        captured = capsys.readouterr()
        lines = captured.out.splitlines()
        for name in files:
            assert main(["detect", name, *opts, *fmt]) == 0
            alone = capsys.readouterr().out.splitlines()
            if as_json:
                mine = [json.loads(line) for line in lines if json.loads(line)["stream"] == name]
                assert [m.pop("stream") for m in mine] == [name] * len(mine)
                assert mine == [json.loads(line) for line in alone]
                objects = [o for w in mine for o in w["objects"]]
                # Not a comparison of empty lines: objects scored, classed and tracked.
                assert any(w["detected"] for w in mine)
                assert all(o["uav_score"] is not None and o["class"] for o in objects)
                assert any(o["track_confirmed"] for o in objects)
                spikes = sum(w["spikes"] for w in mine)
                detected = sum(w["detected"] for w in mine)
                assert re.search(
                    rf"{re.escape(name)}: done [0-9.]+s events=3000 \([0-9,]+ ev/s\) "
                    rf"windows={len(mine)} detected={detected} detections={spikes} ",
                    captured.err,
                )
            else:
                assert [line for line in lines if line.startswith(f"[{name}] ")] == [
                    f"[{name}] {line}" for line in alone
                ]


def test_streams_report_their_windows_through_the_python_function(
    runner: Any, model: Network, tmp_path: Path
) -> None:
    """``detect_streams(..., windows=True)``: each stream's window reports are one
    ``Detector.push_windows``' on the same events, with the tracker's parameters given (a copy
    per stream, without its tracks); ``keep=False`` keeps the counts only."""
    from uavsnn import Detector
    from uavsnn.distributed import detect_streams
    from uavsnn.tracks import Tracker

    net = _identified(model)
    events = {str(tmp_path / f"c{k}.npy"): _events(2500, 40 + k) for k in range(2)}
    for path, ev in events.items():
        np.save(path, ev)
    tracker = Tracker(confirm_hits=2, confirm_windows=2)
    # A track of its own, which no stream may inherit.
    from uavsnn.grouping import WindowObject, WindowReport

    obj = (WindowObject((0, 0, 4, 4), 1),)
    tracker.update(WindowReport(0, 0, 20_000, True, np.zeros(0), obj))
    got: dict[str, list[Any]] = {path: [] for path in events}
    kw: dict[str, Any] = {"window_us": 20_000, "sensor_size": (240, 180), "windows": True}
    kept = detect_streams(
        runner, list(events), net, tracker=tracker,
        on_detections=lambda name, found: got[name].extend(found), **kw,
    )  # fmt: skip
    counted = detect_streams(runner, list(events), net, tracker=tracker, keep=False, **kw)
    for path, ev in events.items():
        det = Detector(net, window_us=20_000, tracker=Tracker(confirm_hits=2, confirm_windows=2))
        want = det.push_windows(ev) + det.flush_windows()
        r, c = kept[path], counted[path]
        assert r.ok and c.ok, (r.error, c.error)

        def shown(reports: list[Any]) -> list[Any]:
            return [
                (w.window, w.t0, w.t1, w.detected, w.detections.tolist(),
                 [(o.box, o.spikes, o.track_id, o.track_confirmed, o.uav_score, o.class_guess,
                   o.track_score, o.rotor) for o in w.objects])
                for w in reports
            ]  # fmt: skip

        assert shown(r.reports) == shown(want) == shown(got[path])
        assert any(o.track_confirmed for w in want for o in w.objects)
        assert min(o.track_id for w in want for o in w.objects if o.track_id) == 1
        spikes = np.concatenate([w.detections for w in want])
        assert np.array_equal(r.detections, spikes) and r.spikes == len(spikes)
        assert r.windows_reported == len(want) == c.windows_reported
        assert r.windows_detected == sum(w.detected for w in want) == c.windows_detected
        assert c.spikes == r.spikes and c.reports == [] and len(c.detections) == 0
    with pytest.raises(ParameterError, match="give windows=True"):
        detect_streams(runner, list(events), net, tracker=tracker)
    with pytest.raises(ParameterError, match="must be a uavsnn"):
        detect_streams(runner, list(events), net, windows=True, tracker="2/3")  # type: ignore[arg-type]


def test_detect_streams_checks_its_arguments_before_any_actor(
    runner: Any, model: Network, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """What every stream would refuse is refused once, before any actor starts (each actor
    used to fail alone, with Ray's traceback)."""
    from uavsnn.distributed import detect_streams, streams

    started: list[str] = []
    monkeypatch.setattr(streams, "_gather", lambda *a, **k: started.append("gather"))
    path = str(tmp_path / "r.npy")
    np.save(path, _events(500, 1))
    udp = "udp://127.0.0.1:0"
    cases: list[tuple[Any, dict[str, Any], str]] = [
        (path, {}, "sources must be a list"),
        ([path, 3], {}, "sources must be a list"),
        ([Path(path), b"x"], {}, "sources must be a list"),
        (["-"], {}, "standard input"),
        ([path], {"bogus": 1}, "unknown source option 'bogus'"),
        ([path], {"window_us": 0}, "window_us must be"),
        ([path], {"overlap": 0.999}, "overlap"),
        ([udp], {"realtime": True}, "realtime applies to files, and no stream is one"),
        ([path], {"udp_format": "spif"}, "udp_format applies to UDP sources"),
        ([path], {"max_packets": 3}, "max_packets applies to UDP sources"),
        ([path], {"idle_timeout": 2.0}, "idle_timeout applies to UDP sources"),
        ([path], {"idle_flush_s": 1.0}, "idle_flush_s applies to live streams"),
        ([path], {"model": 3}, "model must be a uavsnn.Network or the path"),
    ]
    for sources, kwargs, match in cases:
        net = kwargs.pop("model", model)
        with pytest.raises(ParameterError, match=re.escape(match)):
            detect_streams(runner, sources, net, **kwargs)
    assert started == []
    # A model file's path is taken as a Detector takes it; a stream's own failure is its
    # result's one-line error, the others go on.
    model.save(tmp_path / "m.npz")
    monkeypatch.undo()
    results = detect_streams(
        runner, [Path(path), str(tmp_path / "none.npz")], tmp_path / "m.npz",
        sensor_size=(240, 180),
    )  # fmt: skip
    # A Path is a file as its text is, and its stream is named by the text.
    assert results[path].ok and results[path].events_seen == 500
    bad = results[str(tmp_path / "none.npz")]
    assert bad.error is not None and bad.error.startswith("RecordingFileError: ")
    assert "\n" not in bad.error


def test_file_options_apply_to_the_files_among_live_streams(
    runner: Any, model: Network, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--downsample and --realtime apply to the files among several sources, whatever their
    order (they were refused when a UDP stream came first)."""
    from uavsnn.events import Recording
    from uavsnn.io import write_npz

    big = _events(3000, 50)
    big["x"] *= 2
    big["y"] *= 2
    path = str(tmp_path / "big.npz")
    write_npz(Recording(big, (480, 360)), path)
    model.save(tmp_path / "m.npz")
    opts = ["-m", str(tmp_path / "m.npz"), "--downsample", "--json"]
    assert main(["detect", path, *opts]) == 0
    alone = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    udp = ["--max-packets", "1", "--idle-timeout", "1"]
    assert main(["detect", "udp://127.0.0.1:0", path, *opts, *udp, "--ray"]) == 0
    captured = capsys.readouterr()
    lines = [json.loads(line) for line in captured.out.splitlines()]
    mine = [line for line in lines if line.pop("stream") == path]
    assert alone and mine == alone
    assert f"{path}: done " in captured.err and "udp://127.0.0.1:0: done " in captured.err


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_stopped_ray_detect_reports_each_stream_and_exits_as_interrupted(
    runner: Any, model: Network, tmp_path: Path, signum: int, code: int
) -> None:
    """SIGTERM exited 15 with Ray's crash dump (ray.init had replaced the command's handler),
    and neither it nor Ctrl-C printed the streams' summaries."""
    from conftest import kill_group

    model.save(tmp_path / "m.npz")
    path = tmp_path / "r.npy"
    np.save(path, _events(2000, 3))
    argv = [sys.executable, "-m", "uavsnn", "detect", "udp://127.0.0.1:0", str(path), "-m",
            str(tmp_path / "m.npz"), "--sensor-size", "240x180", "--summary-every", "0.2",
            "--ray"]  # fmt: skip
    proc = subprocess.Popen(
        argv,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
        # A shell without job control starts background commands with SIGINT ignored, and
        # Python then installs no handler for it: give the command Ctrl-C as a terminal would.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        assert proc.stderr is not None
        seen = b""
        deadline = time.monotonic() + 120
        while b"udp://127.0.0.1:0: live" not in seen and time.monotonic() < deadline:
            line = proc.stderr.readline()
            if not line:
                break
            seen += line
        assert b"udp://127.0.0.1:0: live" in seen, seen.decode()[-2000:]
        proc.send_signal(signum)
        out, rest = proc.communicate(timeout=60)
    finally:
        kill_group(proc)
    err = (seen + rest).decode()
    assert proc.returncode == code, err[-2000:]
    assert "SIGTERM received" not in err
    assert f"{path}: done " in err and "udp://127.0.0.1:0: interrupted " in err
    name = "interrupted" if signum == signal.SIGINT else "interrupted (SIGTERM)"
    assert err.rstrip().splitlines()[-1] == f"uavsnn detect: {name}"
    assert out.decode().count(f"[{path}] window=") >= 1


def test_streams_stopped_by_ctrl_c_report_the_windows_they_hold_open(
    runner: Any, model: Network
) -> None:
    """Stopped by Ctrl-C, detect_streams killed the actors and the windows still open in them
    were lost (one stream's detect flushes them): each stream now stops and reports them, the
    same windows one Detector gives on the same events, flushed."""
    from uavsnn import Detector
    from uavsnn.distributed import detect_streams

    events = _events(3000, 5)
    events = events[events["t"] < 45_000]  # inside the first windows: none closes
    sent, stopped = threading.Event(), threading.Event()

    def send(addresses: dict[str, Any], _actors: Any) -> None:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.sendto(events.tobytes(), addresses["cam"])
        sent.set()

    got: list[Any] = []
    updates: list[Any] = []

    def update(r: Any) -> None:
        updates.append(r.ended)
        if r.events_seen == len(events) and not stopped.is_set():
            stopped.set()
            raise KeyboardInterrupt  # Ctrl-C, once every event is in the stream's detector

    with pytest.raises(KeyboardInterrupt):
        detect_streams(
            runner,
            ["udp://127.0.0.1:0"],
            model,
            names=["cam"],
            on_ready=send,
            on_detections=lambda _name, found: got.extend(found),
            on_update=update,
            windows=True,
            idle_timeout=60.0,
        )
    assert sent.is_set()
    det = Detector(model)
    want = [*det.push_windows(events), *det.flush_windows()]
    assert want and [w.t0 for w in got] == [w.t0 for w in want]
    assert [w.detected for w in got] == [w.detected for w in want]
    assert not updates[-1]  # stopped, not ended
