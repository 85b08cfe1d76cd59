"""uavsnn.Detector and ``uavsnn detect``: streaming detections equal the batch path's whatever
the chunking, bad chunks are typed errors that change nothing, the GIL is released, and the
command line reads files, standard input and UDP."""

from __future__ import annotations

import io
import itertools
import json
import math
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import SMALL_SENSOR, blob_events, small_config
from hypothesis import given, settings
from hypothesis import strategies as st

import uavsnn.detector
import uavsnn.grouping
import uavsnn.network
from uavsnn import EVENT_DTYPE, EventError, ParameterError, Recording, ShapeError, StreamError
from uavsnn.detector import WINDOW_DETECTION_DTYPE, Detector
from uavsnn.filters import downsample
from uavsnn.grouping import WindowGrouper, merge_boxes
from uavsnn.io import write_npz
from uavsnn.network import DETECTION_DTYPE, Network
from uavsnn.sources import FileSource, StdinSource
from uavsnn.windows import make_windows

SIZE = SMALL_SENSOR
ORDER = ["window", "t", "map", "row", "col"]


@pytest.fixture(scope="module")
def net() -> Network:
    return Network(small_config(), seed=3)


def stream(
    net: Network, events: np.ndarray, cuts: list[int], window_us: int, overlap: float
) -> np.ndarray:
    det = Detector(net, window_us=window_us, overlap=overlap)
    bounds = [0, *sorted(min(c, len(events)) for c in cuts), len(events)]
    found = [det.push(events[a:b]) for a, b in itertools.pairwise(bounds)]
    found.append(det.flush())
    return np.sort(np.concatenate(found), order=ORDER)


def batch(net: Network, events: np.ndarray, window_us: int, overlap: float) -> np.ndarray:
    windows = make_windows(Recording(events, SIZE), window_us, overlap)
    found = net.infer(windows, threads=1).detections
    return np.sort(found.astype(WINDOW_DETECTION_DTYPE), order=ORDER)


def test_detection_dtype_is_the_batch_paths() -> None:
    assert uavsnn.detector.WINDOW_DETECTION_DTYPE is uavsnn.network.WINDOW_DETECTION_DTYPE
    # One window's detection has no window field; the old name warns and means the windowed one.
    assert DETECTION_DTYPE.names == WINDOW_DETECTION_DTYPE.names[1:]
    with pytest.warns(DeprecationWarning, match="WINDOW_DETECTION_DTYPE"):
        old = uavsnn.detector.DETECTION_DTYPE
    assert old is WINDOW_DETECTION_DTYPE
    with pytest.raises(AttributeError):
        _ = uavsnn.detector.NO_SUCH_NAME


@given(
    seed=st.integers(0, 10_000),
    n=st.integers(0, 700),
    cuts=st.lists(st.integers(0, 700), max_size=12),
    window_us=st.sampled_from([400, 1_000, 3_000]),
    overlap=st.sampled_from([0.0, 0.1, 0.5, 0.9]),
)
def test_stream_equals_batch_whatever_the_chunking(
    net: Network, seed: int, n: int, cuts: list[int], window_us: int, overlap: float
) -> None:
    events = blob_events(seed, n)
    got = stream(net, events, cuts, window_us, overlap)
    np.testing.assert_array_equal(got, batch(net, events, window_us, overlap))


def test_the_equivalence_is_not_vacuous(net: Network) -> None:
    events = blob_events(1, 700)
    found = stream(net, events, [1, 2, 350], 3_000, 0.5)
    assert len(found) > 0
    np.testing.assert_array_equal(found, batch(net, events, 3_000, 0.5))
    # Every chunk size, down to one event at a time, gives the same.
    one_by_one = stream(net, events, list(range(len(events))), 3_000, 0.5)
    np.testing.assert_array_equal(one_by_one, found)


def test_detections_leave_at_once(net: Network) -> None:
    """A detection comes back from the push whose events complete its timestamp, long before
    its window closes."""
    events = blob_events(2, 700)
    det = Detector(net, window_us=100_000, overlap=0.0)
    for i in range(len(events)):
        found = det.push(events[i : i + 1])
        if len(found):
            assert np.all(found["t"] < events["t"][i])
            assert det.last_t < 5_000 + 100_000  # window 0 is still open
            return
    pytest.fail("no detection before the end of the stream")


def reference_after(net: Network, first: np.ndarray, rest: np.ndarray) -> tuple:
    det = Detector(net, window_us=1_000, overlap=0.5)
    found = [det.push(first), det.push(rest), det.flush()]
    return np.concatenate(found), det.events_seen, det.windows_opened


def backwards_chunk(first: np.ndarray) -> np.ndarray:
    """Earlier than the stream so far."""
    return first[:1].copy()


def out_of_order_chunk(first: np.ndarray) -> np.ndarray:
    chunk = np.zeros(2, dtype=EVENT_DTYPE)
    chunk["t"] = [first["t"][-1] + 10, first["t"][-1] + 5]
    return chunk


def outside_chunk(axis: str, size: int):
    def make(first: np.ndarray) -> np.ndarray:
        chunk = np.zeros(2, dtype=EVENT_DTYPE)
        chunk["t"] = first["t"][-1] + 1
        chunk[axis][1] = size
        return chunk

    return make


@pytest.mark.parametrize(
    ("make_bad", "error", "match"),
    [
        (backwards_chunk, StreamError, "backwards across chunks"),
        (out_of_order_chunk, EventError, "event 1: .* goes backwards"),
        (outside_chunk("x", SIZE[0]), EventError, "outside the 40x30 sensor"),
        (outside_chunk("y", SIZE[1]), EventError, "outside the 40x30 sensor"),
        (lambda first: first[["t", "x", "y"]], EventError, "dtype"),
        (lambda first: np.stack([first, first]), EventError, "1-D"),
    ],
)
def test_bad_chunks_raise_and_change_nothing(
    net: Network, make_bad, error: type[Exception], match: str
) -> None:
    events = blob_events(4, 600)
    first, rest = events[:300], events[300:]
    expected, seen, opened = reference_after(net, first, rest)
    det = Detector(net, window_us=1_000, overlap=0.5)
    found = [det.push(first)]
    before = (det.events_seen, det.windows_opened, det.last_t, det.detections_emitted)
    with pytest.raises(error, match=match):
        det.push(make_bad(first))
    assert (det.events_seen, det.windows_opened, det.last_t, det.detections_emitted) == before
    found += [det.push(rest), det.flush()]
    np.testing.assert_array_equal(np.concatenate(found), expected)
    assert (det.events_seen, det.windows_opened) == (seen, opened)


def test_flush_ends_the_stream_until_reset(net: Network) -> None:
    events = blob_events(5, 400)
    det = Detector(net, window_us=1_000, overlap=0.5)
    first = np.concatenate([det.push(events), det.flush()])
    assert len(det.flush()) == 0
    with pytest.raises(StreamError, match="flushed"):
        det.push(events[-1:])
    assert det.busy_seconds > 0
    det.reset()
    assert det.events_seen == 0 and det.busy_seconds == 0.0 and det.rate == 0.0
    again = np.concatenate([det.push(events), det.flush()])
    np.testing.assert_array_equal(again, first)


def test_empty_chunks_and_counters(net: Network) -> None:
    det = Detector(net, window_us=1_000, overlap=0.75)
    assert len(det.push(np.zeros(0, dtype=EVENT_DTYPE))) == 0
    assert det.rate == 0.0 and det.last_t is None
    events = blob_events(6, 500)
    det.push(events)
    assert det.events_seen == len(events)
    assert det.last_t == int(events["t"][-1])
    assert det.step_us == 250
    assert 0 < det.live_windows <= math.ceil(1 / (1 - 0.75))
    assert det.windows_opened >= (int(events["t"][-1]) - int(events["t"][0])) // 250
    assert det.rate == pytest.approx(len(events) / det.busy_seconds)
    assert det.sensor_size == SIZE and det.window_us == 1_000 and det.overlap == 0.75
    assert "events_seen=500" in repr(det)


def test_a_window_too_long_to_measure_its_objects_is_refused_before_any_event(
    net: Network,
) -> None:
    # It was refused by push_windows, with the events already taken and the window's reports
    # lost ("'bins': must be in 1..=4096").
    longest = 4096 * 5000
    with pytest.raises(ParameterError, match=r"longer than 20480000 µs.*rotor=False"):
        Detector(net, window_us=longest + 1)
    det = Detector(net, window_us=longest)
    rng = np.random.default_rng(4)
    ev = np.zeros(3000, EVENT_DTYPE)
    ev["t"] = 5_000 + np.arange(3000) * 16_000
    ev["x"], ev["y"] = rng.integers(0, 40, 3000), rng.integers(0, 30, 3000)
    reports = det.push_windows(ev) + det.flush_windows()
    assert det.events_seen == 3000 and reports
    # Without measuring the objects, any length.
    det = Detector(net, window_us=longest * 2, rotor=False)
    assert det.push_windows(ev) + det.flush_windows()


def test_bad_parameters_are_typed_errors(net: Network, tmp_path: Path) -> None:
    with pytest.raises(ParameterError, match=r"window_us must be in \[1,"):
        Detector(net, window_us=0)
    with pytest.raises(ParameterError, match="integer"):
        Detector(net, window_us=1.5)  # type: ignore[arg-type]
    for overlap in (1.0, -0.1, float("nan"), "0.5", True):
        with pytest.raises(ParameterError, match="overlap"):
            Detector(net, window_us=1_000, overlap=overlap)
    with pytest.raises(ShapeError, match="differs from the network"):
        Detector(net, window_us=1_000, sensor_size=(240, 180))
    with pytest.raises(ParameterError, match="start_us"):
        Detector(net, window_us=1_000, start_us=-1)


def test_a_model_file_and_a_copy_of_the_weights(net: Network, tmp_path: Path) -> None:
    path = tmp_path / "model.npz"
    net.save(path)
    events = blob_events(7, 600)
    from_file = stream(Network.load(path), events, [], 3_000, 0.5)
    det = Detector(path, window_us=3_000, overlap=0.5)
    found = np.sort(np.concatenate([det.push(events), det.flush()]), order=ORDER)
    np.testing.assert_array_equal(found, from_file)
    # Changing the network afterwards does not reach a detector built from it.
    changed = net.copy()
    det = Detector(changed, window_us=3_000, overlap=0.5)
    changed.set_weights("conv3", np.zeros_like(changed.weights("conv3")))
    found = np.sort(np.concatenate([det.push(events), det.flush()]), order=ORDER)
    np.testing.assert_array_equal(found, from_file)


def test_push_releases_the_gil() -> None:
    """While one thread pushes a large chunk, another keeps running Python: its longest stall
    is a small part of the engine's time (a push holding the GIL would stall it for all of
    it; counting the loop's turns instead passed with one, as the turns before and after the
    call were enough)."""
    rng = np.random.default_rng(0)
    n = 400_000
    events = np.zeros(n, dtype=EVENT_DTYPE)
    events["t"] = np.cumsum(rng.integers(0, 3, n))
    events["x"] = rng.integers(0, 240, n)
    events["y"] = rng.integers(0, 180, n)
    det = Detector(Network(seed=0), window_us=20_000, overlap=0.9)
    started, done = threading.Event(), threading.Event()

    def work() -> None:
        started.set()
        det.push(events)
        done.set()

    worker = threading.Thread(target=work)
    stall, last = 0.0, time.perf_counter()
    worker.start()
    while not done.is_set():
        now = time.perf_counter()
        stall, last = max(stall, now - last), now
    worker.join()
    assert started.is_set() and det.busy_seconds > 0.05, det.busy_seconds
    assert stall < 0.5 * det.busy_seconds, (stall, det.busy_seconds)


# ---------------------------------------------------------------- sources: file, standard input


def test_file_source_fast_and_at_the_recordings_pace(tmp_path: Path) -> None:
    events = blob_events(12, 300)
    events["t"] = 5_000 + (events["t"] - 5_000) * 40  # about 0.15 s of event time
    path = tmp_path / "rec.npz"
    write_npz(Recording(events, SIZE), path)
    fast = list(FileSource(path, chunk_events=64))
    assert [len(c) for c in fast[:-1]] == [64] * (len(fast) - 1)
    np.testing.assert_array_equal(np.concatenate(fast), events)
    paced = FileSource(path, realtime=True, chunk_us=10_000)
    start = time.monotonic()
    chunks = list(paced)
    elapsed = time.monotonic() - start
    np.testing.assert_array_equal(np.concatenate(chunks), events)
    assert all(int(c["t"][-1]) - int(c["t"][0]) < 10_000 for c in chunks)
    # Released no earlier than the recording's own clock allows.
    assert elapsed >= (int(events["t"][-1]) - int(events["t"][0])) / 1e6
    assert paced.stats.events == len(events) and paced.stats.packets == len(chunks)
    for bad in ({"chunk_events": 0}, {"chunk_us": 0}):
        with pytest.raises(ParameterError, match="chunk"):
            FileSource(path, **bad)


def test_paced_chunks_end_before_their_edge(tmp_path: Path) -> None:
    """A paced chunk holds ``[first + k·chunk_us, first + (k+1)·chunk_us)``: an event right on
    an edge opens the next chunk."""
    events = blob_events(13, 4)
    events["t"] = [0, 1_000, 1_999, 2_000]
    path = tmp_path / "edges.npz"
    write_npz(Recording(events, SIZE), path)
    chunks = list(FileSource(path, realtime=True, chunk_us=1_000))
    assert [c["t"].tolist() for c in chunks] == [[0], [1_000, 1_999], [2_000]]


class Trickle(io.RawIOBase):
    """A binary stream that hands out at most ``step`` bytes per read, like a slow pipe."""

    def __init__(self, data: bytes, step: int) -> None:
        self.data, self.step, self.at = data, step, 0

    def readable(self) -> bool:
        return True

    def read1(self, size: int = -1) -> bytes:
        n = self.step if size < 0 else min(size, self.step)
        out = self.data[self.at : self.at + n]
        self.at += len(out)
        return out


def test_stdin_packed_records_split_across_reads() -> None:
    events = blob_events(8, 300)
    source = StdinSource(Trickle(events.tobytes(), step=17), fmt="packed", sensor_size=SIZE)
    np.testing.assert_array_equal(np.concatenate(list(source)), events)
    assert source.stats.dropped == 0
    assert source.stats.events == len(events)
    assert source.stats.packets == math.ceil(len(events.tobytes()) / 17)


def test_stdin_truncated_last_record_is_a_drop() -> None:
    events = blob_events(9, 10)
    source = StdinSource(io.BytesIO(events.tobytes()[:-3]), sensor_size=SIZE)
    np.testing.assert_array_equal(np.concatenate(list(source)), events[:-1])
    assert source.stats.dropped == 1


def test_stdin_csv_with_header_and_a_malformed_line() -> None:
    events = blob_events(10, 50)
    lines = ["t,x,y,p"] + [f"{e['t']},{e['x']},{e['y']},{1 if e['p'] else -1}" for e in events]
    lines.insert(20, "12,not-a-number,3,1")
    text = ("\n".join(lines)).encode()  # no final newline: the last line still counts
    source = StdinSource(Trickle(text, step=64), fmt="csv", sensor_size=SIZE)
    np.testing.assert_array_equal(np.concatenate(list(source)), events)
    assert source.stats.dropped == 1
    assert source.stats.events == len(events)


def test_stdin_csv_columns_in_the_order_the_header_names_them() -> None:
    events = blob_events(11, 30)
    lines = ["Y, polarity, x, timestamp, extra"] + [
        f"{e['y']},{1 if e['p'] else 0},{e['x']},{e['t']},9" for e in events
    ]
    lines.insert(5, f"{events[0]['t']},1,1,1")  # the usual order: a line of the wrong width
    source = StdinSource(Trickle("\n".join(lines).encode(), step=50), fmt="csv", sensor_size=SIZE)
    np.testing.assert_array_equal(np.concatenate(list(source)), events)
    assert source.stats.dropped == 1


def test_stdin_csv_negative_time_is_a_drop() -> None:
    text = b"5,1,2,1\n-3,1,2,1\n7,2,2,0\n"
    source = StdinSource(io.BytesIO(text), fmt="csv", sensor_size=SIZE)
    got = np.concatenate(list(source))
    assert got["t"].tolist() == [5, 7] and got["p"].tolist() == [1, 0]
    assert source.stats.dropped == 1


def test_stdin_parameters() -> None:
    with pytest.raises(ParameterError, match="stdin format"):
        StdinSource(io.BytesIO(), fmt="json", sensor_size=SIZE)
    # A read must be able to hold one whole 13-byte record.
    with pytest.raises(ParameterError, match="read_size"):
        StdinSource(io.BytesIO(), sensor_size=SIZE, read_size=12)
    assert StdinSource(io.BytesIO(), sensor_size=SIZE, read_size=13).read_size == 13


# ---------------------------------------------------------------- the command line


def detect_cmd(*args: str) -> list[str]:
    return [sys.executable, "-m", "uavsnn", "detect", *args]


def run_cli(args: list[str], stdin: bytes | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        args, input=stdin, capture_output=True, timeout=120, check=False, env=dict(os.environ)
    )


def parse_json_lines(text: bytes) -> list[tuple]:
    rows = [json.loads(line) for line in text.decode().splitlines() if line.strip()]
    return sorted((r["window"], r["t"], r["map"], r["row"], r["col"], *r["box"]) for r in rows)


def as_rows(found: np.ndarray) -> list[tuple]:
    return sorted(
        tuple(int(d[f]) for f in ["window", "t", "map", "row", "col", "x0", "y0", "x1", "y1"])
        for d in found
    )


@pytest.fixture(scope="module")
def model_file(net: Network, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("model") / "model.npz"
    net.save(path)
    return path


@pytest.fixture(scope="module")
def expected(net: Network) -> tuple[np.ndarray, list[tuple]]:
    events = blob_events(11, 700)
    found = stream(net, events, [], 3_000, 0.5)
    assert len(found) > 0
    return events, as_rows(found)


def test_cli_reads_a_recording_file(model_file: Path, expected, tmp_path: Path) -> None:
    events, rows = expected
    path = tmp_path / "rec.npz"
    write_npz(Recording(events, SIZE), path)
    done = run_cli(
        detect_cmd(
            str(path), "--model", str(model_file), "--json", "--per-spike", "--window-ms", "3"
        )
    )
    assert done.returncode == 0, done.stderr.decode()
    assert parse_json_lines(done.stdout) == rows
    assert b"done" in done.stderr and b"events=700" in done.stderr
    # The model has no identification stage: detect says that only the any-spike rule decides.
    assert b"note: " in done.stderr and b"only the any-spike rule decides" in done.stderr


def test_cli_downsamples_a_larger_recording(model_file: Path, net: Network, tmp_path: Path) -> None:
    events = blob_events(13, 700)
    events["x"] *= 2
    events["y"] *= 2
    big = Recording(events, (2 * SIZE[0], 2 * SIZE[1]))
    path = tmp_path / "big.npz"
    write_npz(big, path)
    args = [str(path), "--model", str(model_file), "--json", "--per-spike", "--window-ms", "3"]
    refused = run_cli(detect_cmd(*args))
    assert refused.returncode == 2 and b"downsample" in refused.stderr
    done = run_cli(detect_cmd(*args, "--downsample"))
    assert done.returncode == 0, done.stderr.decode()
    rows = as_rows(stream(net, downsample(big, SIZE).events, [], 3_000, 0.5))
    assert rows and parse_json_lines(done.stdout) == rows


@pytest.mark.parametrize("fmt", ["packed", "csv"])
def test_cli_reads_standard_input(model_file: Path, expected, fmt: str) -> None:
    events, rows = expected
    if fmt == "packed":
        data = events.tobytes()
    else:
        data = "".join(f"{e['t']},{e['x']},{e['y']},{int(e['p'])}\n" for e in events).encode()
    args = ["-", "--model", str(model_file), "--json", "--per-spike", "--window-ms", "3"]
    done = run_cli(detect_cmd(*args, "--stdin-format", fmt), stdin=data)
    assert done.returncode == 0, done.stderr.decode()
    assert parse_json_lines(done.stdout) == rows


def test_cli_plain_lines_and_errors(model_file: Path, expected, tmp_path: Path) -> None:
    events, rows = expected
    args = ["-", "--model", str(model_file), "--window-ms", "3"]
    done = run_cli(detect_cmd(*args, "--per-spike"), stdin=events.tobytes())
    lines = done.stdout.decode().splitlines()
    assert len(lines) == len(rows) and all(line.startswith("t=") for line in lines)
    bad = run_cli(detect_cmd(*args[:-2], "--window-ms", "0"), stdin=b"")
    assert bad.returncode == 2 and b"window-ms" in bad.stderr
    missing = run_cli(detect_cmd(str(tmp_path / "nope.npz"), "--model", str(model_file)))
    assert missing.returncode == 2


def test_cli_receives_udp_and_prints_detections(model_file: Path, expected) -> None:
    """Events sent over a real loopback socket come out as the same detections; a malformed
    packet in the middle is counted as a drop."""
    events, rows = expected
    packets = [events[i : i + 50].tobytes() for i in range(0, len(events), 50)]
    packets.insert(3, b"\x00" * 7)  # not a whole number of 13-byte records
    proc = subprocess.Popen(
        detect_cmd(
            "udp://127.0.0.1:0",
            "--model",
            str(model_file),
            "--json",
            "--per-spike",
            "--window-ms",
            "3",
            "--max-packets",
            str(len(packets)),
            "--idle-timeout",
            "30",
        ),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    try:
        assert proc.stderr is not None
        line = proc.stderr.readline().decode()
        assert "listening on udp://127.0.0.1:" in line, line
        port = int(line.rsplit(":", 1)[1])
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            for p in packets:
                s.sendto(p, ("127.0.0.1", port))
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 0, err.decode()
    assert parse_json_lines(out) == rows
    assert b"dropped=1" in err


def test_cli_on_a_real_recording(shared_data: Path, tmp_path: Path) -> None:
    """A real DAVIS346 recording (AEDAT4), fitted to the default 240x180 network: the command
    line streams every event and prints what the Detector finds in process."""
    from uavsnn.io import read

    path = shared_data / "dvs" / "aestream_davis346_lab.aedat4"
    model = tmp_path / "model.npz"
    network = Network(seed=0)
    network.save(model)
    events = downsample(read(path), (240, 180)).events
    det = Detector(network, window_us=50_000, overlap=0.5)
    rows = as_rows(np.concatenate([det.push(events), det.flush()]))
    done = run_cli(
        detect_cmd(str(path), "--model", str(model), "--json", "--per-spike", "--downsample")
    )
    assert done.returncode == 0, done.stderr.decode()
    assert parse_json_lines(done.stdout) == rows
    assert f"events={len(events)} ".encode() in done.stderr


# ---------------------------------------------------------------- one decision per window


def grouped(net: Network, events: np.ndarray, cuts: list[int], window_us: int, overlap: float):
    det = Detector(net, window_us=window_us, overlap=overlap)
    windows = WindowGrouper.of(det)
    bounds = [0, *sorted(min(c, len(events)) for c in cuts), len(events)]
    reports = []
    for a, b in itertools.pairwise(bounds):
        reports += windows.add(events[a:b], det.push(events[a:b]))
    reports += windows.finish(det.flush())
    return det, reports


@given(
    cuts=st.lists(st.integers(0, 900), max_size=12),
    seed=st.integers(0, 3),
    overlap=st.sampled_from([0.0, 0.5, 0.8]),
)
def test_windows_group_every_spike_once_whatever_the_chunking(net, cuts, seed, overlap) -> None:
    events = blob_events(seed, 900)
    # A silent gap: the windows wholly inside it are neither opened nor reported.
    events["t"][450:] += 40_000
    det, reports = grouped(net, events, cuts, 3_000, overlap)
    assert len(reports) == det.windows_opened
    indices = [r.window for r in reports]
    assert indices == sorted(set(indices))
    every = np.sort(np.concatenate([r.detections for r in reports]), order=ORDER)
    np.testing.assert_array_equal(every, stream(net, events, [], 3_000, overlap))
    step = det.step_us
    for r in reports:
        assert r.t0 == int(events["t"][0]) + r.window * step and r.t1 == r.t0 + 3_000
        assert np.all(r.detections["window"] == r.window)
        assert r.detected == (r.spikes >= 1)
        assert r.objects == merge_boxes(r.detections)
        # Every reported window holds an event.
        assert np.any((events["t"] >= r.t0) & (events["t"] < r.t1))


@pytest.mark.parametrize("start", [None, 20])
def test_a_chunk_is_grouped_a_slice_at_a_time(net, monkeypatch, start) -> None:
    # The grouper reads a large chunk in slices (bounded memory); the windows are the same.
    events = blob_events(1, 900)
    events["t"][450:] += 40_000
    start_us = None if start is None else int(events["t"][start])

    def reports() -> list[tuple]:
        det = Detector(net, window_us=3_000, overlap=0.5, start_us=start_us)
        windows = WindowGrouper.of(det)
        found = windows.add(events, det.push(events)) + windows.finish(det.flush())
        return [(r.window, r.t0, r.spikes, r.objects, r.detections.tobytes()) for r in found]

    whole = reports()
    monkeypatch.setattr(uavsnn.grouping, "_GROUP_SLICE", 7)
    assert reports() == whole and len(whole) > 5


def test_push_and_push_windows_are_not_mixed_on_one_stream(net) -> None:
    # Mixed, the windows were numbered from the wrong event and their detections lost.
    events = blob_events(1, 900)
    det = Detector(net, window_us=3_000, overlap=0.5)
    det.push(events[:300])
    for call in (lambda: det.push_windows(events[300:]), det.flush_windows):
        with pytest.raises(StreamError, match="cannot be mixed"):
            call()
    det.push(events[300:])  # the stream goes on as before
    det.reset()
    det.push(events[:0])  # an empty push reads nothing
    reports = det.push_windows(events[:300])
    for call in (lambda: det.push(events[300:]), det.flush):
        with pytest.raises(StreamError, match="cannot be mixed"):
            call()
    reports += det.push_windows(events[300:]) + det.flush_windows()
    _, whole = grouped(net, events, [], 3_000, 0.5)
    assert [(r.window, r.spikes) for r in reports] == [(r.window, r.spikes) for r in whole]
    det.reset()
    det.push(events)  # a new stream may use either


def test_a_window_is_reported_by_the_push_that_passes_its_end(net) -> None:
    events = blob_events(2, 900)
    det = Detector(net, window_us=3_000, overlap=0.5)
    windows = WindowGrouper.of(det)
    seen: list[int] = []
    for i in range(len(events)):
        for r in windows.add(events[i : i + 1], det.push(events[i : i + 1])):
            # Closed by this event, and not by the one before.
            assert r.t1 <= events["t"][i] and (i == 0 or events["t"][i - 1] < r.t1)
            seen.append(r.window)
    tail = windows.finish(det.flush())
    assert seen and len(seen) + len(tail) == det.windows_opened
    assert all(r.t1 > events["t"][-1] for r in tail)


def test_windows_from_a_given_start_and_a_higher_minimum(net) -> None:
    events = blob_events(3, 900)
    # One lone event much later: a window with no spike.
    lone = events[-1:].copy()
    lone["t"] += 50_000
    events = np.concatenate([events, lone])
    det = Detector(net, window_us=3_000, overlap=0.5, start_us=1_000)
    windows = WindowGrouper(3_000, det.step_us, start_us=1_000, min_detections=4)
    reports = windows.add(events, det.push(events)) + windows.finish(det.flush())
    assert det.start_us == 1_000 and reports[0].t0 == 1_000 + reports[0].window * det.step_us
    assert len(reports) == det.windows_opened
    assert reports[-1].spikes == 0 and not reports[-1].detected and reports[-1].objects == ()
    assert all(r.detected == (r.spikes >= 4) for r in reports)
    assert any(r.detected for r in reports)
    higher = WindowGrouper(3_000, det.step_us, start_us=1_000, min_detections=5)
    det.reset()
    assert not any(r.detected for r in higher.add(events, det.push(events)))
    with pytest.raises(ParameterError):
        WindowGrouper(0, 1)


def box_rows(n: int) -> st.SearchStrategy:
    corner = st.tuples(
        st.integers(0, 60), st.integers(0, 60), st.integers(1, 12), st.integers(1, 12)
    )
    return st.lists(corner, min_size=0, max_size=n)


def as_detections(boxes: list[tuple[int, int, int, int]]) -> np.ndarray:
    d = np.zeros(len(boxes), dtype=WINDOW_DETECTION_DTYPE)
    b = np.array(boxes, dtype=np.int64).reshape(-1, 4)
    d["x0"], d["y0"] = b[:, 0], b[:, 1]
    d["x1"], d["y1"] = b[:, 0] + b[:, 2], b[:, 1] + b[:, 3]
    return d


def touch(a: tuple, b: tuple) -> bool:
    return a[0] <= b[2] and b[0] <= a[2] and a[1] <= b[3] and b[1] <= a[3]


@given(boxes=box_rows(40), seed=st.integers(0, 9))
def test_merged_boxes_cover_every_box_and_never_touch(boxes, seed) -> None:
    d = as_detections(boxes)
    objects = merge_boxes(d)
    assert sum(o.spikes for o in objects) == len(boxes)
    for i, a in enumerate(objects):
        x0, y0, x1, y1 = a.box
        cx, cy = a.centre
        assert x0 <= cx < x1 and y0 <= cy < y1
        assert all(not touch(a.box, b.box) for b in objects[i + 1 :])
    for r in d:
        box = (int(r["x0"]), int(r["y0"]), int(r["x1"]), int(r["y1"]))
        holders = [
            o
            for o in objects
            if o.box[0] <= box[0]
            and box[2] <= o.box[2]
            and o.box[1] <= box[1]
            and box[3] <= o.box[3]
        ]
        assert len(holders) == 1
    shuffled = d[np.random.default_rng(seed).permutation(len(d))]
    assert merge_boxes(shuffled) == objects
    assert all(
        o.uav_score is None and o.class_guess is None and o.track_id is None for o in objects
    )


def merge_reference(d: np.ndarray) -> list[tuple[tuple[int, int, int, int], int]]:
    """merge_boxes's rule written another way: each detection a group; join at once every
    group whose bounding box overlaps or touches another's (connected components, by label
    propagation over the pairwise matrix), and again over the joined groups' boxes, until no
    two boxes touch. The final groups do not depend on the order of the joins: a join only
    puts together boxes that any grouping without two touching boxes holds together."""
    if len(d) == 0:
        return []
    boxes = np.stack([d[f].astype(np.int64) for f in ("x0", "y0", "x1", "y1")], axis=1)
    counts = np.ones(len(d), dtype=np.int64)
    while True:
        x0, y0, x1, y1 = (boxes[:, k] for k in range(4))
        touch = (
            (x0[:, None] <= x1[None, :])
            & (x0[None, :] <= x1[:, None])
            & (y0[:, None] <= y1[None, :])
            & (y0[None, :] <= y1[:, None])
        )
        label = np.arange(len(boxes))
        while True:
            joined = np.where(touch, label[None, :], len(boxes)).min(axis=1)
            if np.array_equal(joined, label):
                break
            label = joined
        groups = np.unique(label)
        if len(groups) == len(boxes):
            break
        boxes = np.array(
            [
                [*boxes[label == g, :2].min(axis=0), *boxes[label == g, 2:].max(axis=0)]
                for g in groups
            ]
        )
        counts = np.array([counts[label == g].sum() for g in groups])
    order = sorted(range(len(boxes)), key=lambda i: (-counts[i], *boxes[i][:2].tolist()))
    return [(tuple(int(v) for v in boxes[i]), int(counts[i])) for i in order]


@given(boxes=box_rows(40))
def test_merge_boxes_equals_the_reference_rule_for_a_few_boxes(boxes) -> None:
    d = as_detections(boxes)
    assert [(o.box, o.spikes) for o in merge_boxes(d)] == merge_reference(d)


@settings(max_examples=30, deadline=None)
@given(
    boxes=st.lists(
        st.tuples(st.integers(0, 300), st.integers(0, 300), st.integers(1, 6), st.integers(1, 6)),
        min_size=uavsnn.grouping._MERGE_IN_NUMPY_FROM + 1,
        max_size=300,
        unique=True,
    ),
    repeat=st.integers(1, 3),
)
def test_merge_boxes_equals_the_reference_rule_for_many_boxes(boxes, repeat) -> None:
    # More distinct boxes than merge_boxes merges in plain Python: its NumPy passes.
    d = as_detections(boxes * repeat)
    assert [(o.box, o.spikes) for o in merge_boxes(d)] == merge_reference(d)


def test_merge_rule_by_hand() -> None:
    # Two overlapping boxes, one touching them by an edge, one apart (twice).
    d = as_detections([(0, 0, 4, 4), (2, 2, 4, 4), (6, 0, 2, 2), (20, 20, 2, 2), (20, 20, 2, 2)])
    assert [(o.box, o.spikes) for o in merge_boxes(d)] == [
        ((0, 0, 8, 6), 3),
        ((20, 20, 22, 22), 2),
    ]
    # Corners touch; a box apart stays apart.
    d = as_detections([(0, 0, 2, 2), (2, 2, 2, 2), (10, 10, 2, 2), (12, 12, 2, 2), (0, 10, 2, 2)])
    assert [(o.box, o.spikes) for o in merge_boxes(d)] == [
        ((0, 0, 4, 4), 2),
        ((10, 10, 14, 14), 2),
        ((0, 10, 2, 12), 1),
    ]
    # The first box touches neither of the other two, but their union's box swallows it.
    d = as_detections([(1, 1, 2, 2), (1, 8, 9, 2), (8, 0, 2, 10)])
    assert [(o.box, o.spikes) for o in merge_boxes(d)] == [((1, 0, 10, 10), 3)]
    assert merge_boxes(as_detections([])) == ()


def test_cli_prints_one_line_per_window(model_file: Path, net: Network, expected) -> None:
    events, _ = expected
    det, reports = grouped(net, events, [], 3_000, 0.5)
    args = ["-", "--model", str(model_file), "--window-ms", "3"]
    done = run_cli(detect_cmd(*args, "--json"), stdin=events.tobytes())
    assert done.returncode == 0, done.stderr.decode()
    rows = [json.loads(line) for line in done.stdout.decode().splitlines()]
    assert [r["window"] for r in rows] == [r.window for r in reports]
    assert len(rows) == det.windows_opened and any(r["detected"] for r in rows)
    for row, rep in zip(rows, reports, strict=True):
        assert (row["t0"], row["t1"], row["detected"], row["spikes"]) == (
            rep.t0,
            rep.t1,
            rep.detected,
            rep.spikes,
        )
        assert [o["box"] for o in row["objects"]] == [list(o.box) for o in rep.objects]
        for o in row["objects"]:
            x0, y0, x1, y1 = o["box"]
            assert x0 <= o["centre"][0] < x1 and y0 <= o["centre"][1] < y1
            assert o["uav_score"] is None and o["class"] is None  # no identification yet
            assert isinstance(o["track"], int)  # tracks: tests/test_tracks.py
    text = run_cli(detect_cmd(*args), stdin=events.tobytes()).stdout.decode().splitlines()
    assert len(text) == len(rows) and all(line.startswith("window=") for line in text)
    hit = next(line for line in text if "DETECTED" in line)
    assert " | box=" in hit and "uav_score=- class=- track=" in hit


def _classes_at(net, ident, tmp_path, events, flag, values):
    """``net`` with identification ``ident`` saved, and ``detect --json`` run at ``flag`` of
    each of ``values``: the detect arguments and each value's class guesses."""
    model = net.copy()
    model.identification = ident
    path = tmp_path / "ident.npz"
    model.save(path)
    args = ["-", "--model", str(path), "--window-ms", "3", "--json"]
    classes = {}
    for value in values:
        done = run_cli(detect_cmd(*args, flag, value), stdin=events.tobytes())
        assert done.returncode == 0, done.stderr.decode()
        rows = [json.loads(line) for line in done.stdout.decode().splitlines()]
        classes[value] = [o["class"] for r in rows for o in r["objects"]]
    return args, classes


def test_cli_false_alarm_sets_the_operating_point(net: Network, expected, tmp_path: Path) -> None:
    """--false-alarm SHARE scores with the threshold the model was tuned to for that share:
    one near 1 calls no object a UAV, 0.0 calls every one; a share the model was not tuned
    for, or a model without identification, is refused with why."""
    from uavsnn.identify import Identifier

    events, _ = expected
    ident = Identifier(
        ("log_width", "log_height"), np.array([0.2, 0.1, 0.1]), np.zeros(2), np.ones(2), 0.5,
        1.0, alarm_thresholds=((0.01, 0.999999), (0.05, 0.0)),
    )  # fmt: skip
    args, classes = _classes_at(net, ident, tmp_path, events, "--false-alarm", ("0.01", "0.05"))
    assert classes["0.01"] and "uav" not in classes["0.01"]
    assert set(classes["0.05"]) == {"uav"}
    # A point of 0.0 calls more than the default threshold: said on stderr; the other not.
    for share, said in (("0.05", True), ("0.01", False)):
        done = run_cli(detect_cmd(*args, "--false-alarm", share), stdin=b"")
        note = b"--false-alarm %s is the threshold 0.0" % share.encode()
        assert (note in done.stderr) is said, done.stderr
    refused = run_cli(detect_cmd(*args, "--false-alarm", "0.02"), stdin=b"")
    assert (
        refused.returncode == 2 and b"not tuned for a false-alarm share of 0.02" in refused.stderr
    )
    bare = tmp_path / "bare.npz"
    net.save(bare)
    none = run_cli(detect_cmd("-", "--model", str(bare), "--false-alarm", "0.01"), stdin=b"")
    assert none.returncode == 2 and b"has no identification" in none.stderr


def test_cli_false_tracks_sets_the_track_operating_point(
    net: Network, expected, tmp_path: Path
) -> None:
    """--false-tracks RATE scores with the threshold the model was tuned to for that many
    false tracks per minute; a rate it was not tuned for, or with --false-alarm, is refused."""
    from uavsnn.identify import Identifier

    events, _ = expected
    ident = Identifier(
        ("log_width", "log_height"), np.array([0.2, 0.1, 0.1]), np.zeros(2), np.ones(2), 0.5,
        1.0, alarm_thresholds=((0.01, 0.5),), track_alarm_thresholds=((0.1, 0.999999), (1.0, 0.0)),
        track_alarm_minutes=10.0,
    )  # fmt: skip
    args, classes = _classes_at(net, ident, tmp_path, events, "--false-tracks", ("0.1", "1"))
    assert classes["0.1"] and "uav" not in classes["0.1"]
    assert set(classes["1"]) == {"uav"}
    refused = run_cli(detect_cmd(*args, "--false-tracks", "0.5"), stdin=b"")
    assert refused.returncode == 2 and b"not tuned for 0.5 false tracks" in refused.stderr
    both = run_cli(detect_cmd(*args, "--false-tracks", "1", "--false-alarm", "0.01"), stdin=b"")
    assert both.returncode == 2 and b"give one" in both.stderr
    # The points were set with the default 3 of 5: another rule is refused with why.
    other = run_cli(detect_cmd(*args, "--false-tracks", "1", "--confirm", "2/5"), stdin=b"")
    assert other.returncode == 2 and b"set with --confirm 3/5, not 2/5" in other.stderr
    same = run_cli(
        detect_cmd(*args, "--false-tracks", "1", "--confirm", "3/5"), stdin=events.tobytes()
    )
    assert same.returncode == 0, same.stderr.decode()


def test_printed_centre_lies_in_its_box(shared_data: Path, tmp_path: Path) -> None:
    """The field centre (x, y) of a conv3 spike is the middle of its receptive field, which
    covers most of the sensor: on a real recording it mostly lies outside the spike's causal
    box. What detect prints as the centre is the box's middle."""
    from uavsnn.io import read

    path = shared_data / "dvs" / "aestream_davis346_lab.aedat4"
    model = tmp_path / "model.npz"
    network = Network(seed=0)
    network.save(model)
    events = downsample(read(path), (240, 180)).events
    det = Detector(network)
    found = np.concatenate([det.push(events), det.flush()])
    outside = (found["x"] < found["x0"]) | (found["x"] >= found["x1"])
    outside |= (found["y"] < found["y0"]) | (found["y"] >= found["y1"])
    assert len(found) and outside.any()  # what users saw
    for extra in (["--per-spike"], []):
        done = run_cli(detect_cmd(str(path), "-m", str(model), "--json", "--downsample", *extra))
        assert done.returncode == 0, done.stderr.decode()
        rows = [json.loads(line) for line in done.stdout.decode().splitlines()]
        items = rows if extra else [o for r in rows for o in r["objects"]]
        assert len(items) > 0
        for o in items:
            x0, y0, x1, y1 = o["box"]
            assert x0 <= o["centre"][0] < x1 and y0 <= o["centre"][1] < y1
