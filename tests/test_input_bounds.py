"""Inputs that would choose the memory or the time: a compressed ``.npz`` that expands a
thousandfold, ``.npy`` and split-file headers that claim more than their files hold, CSV lines
without end and times of thousands of digits, motion searches over huge boxes, scenes of
thousands of objects and benches repeated without end. Each is refused with the package's
typed error before the work or the allocation, and what is valid is still read.

The hostile files are small (compressed, or headers that lie); where a refusal must come before
an allocation, the test watches the peak of what is allocated (``tracemalloc``, which NumPy
reports its arrays to) or lowers ``uavsnn.windows.MEMORY_LIMIT``.
"""

from __future__ import annotations

import copy
import io
import json
import tracemalloc
import zipfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import pytest
from conftest import one_line_exit_2, random_events

from uavsnn import DatasetError, ParameterError, RecordingFileError, SimulationError, StreamError
from uavsnn import bench as ubench
from uavsnn import io as uio
from uavsnn import signature as usig
from uavsnn import windows as uwindows
from uavsnn.dataset.format import (
    FORMAT_NAME,
    FORMAT_VERSION,
    LabelledWindows,
    load,
    save_split,
    write_manifest,
)
from uavsnn.events import EVENT_DTYPE, Recording
from uavsnn.network import MAX_THREADS, Network
from uavsnn.scenes import sample_spec, spec_from_dict, spec_to_dict
from uavsnn.scenes.spec import MAX_HARMONICS, MAX_OBJECTS, PathSpec
from uavsnn.signature import MAX_COARSE_STEPS, MAX_PIXELS, estimate_motion
from uavsnn.sources import StdinSource
from uavsnn.windows import Windows

SIZE = (64, 48)
_T = TypeVar("_T")


def _events(n: int, seed: int = 0) -> np.ndarray:
    return random_events(n, SIZE, seed)


def _peak(call: Callable[[], _T]) -> tuple[_T | BaseException, int]:
    """What ``call`` returns or raises, and the most bytes allocated while it ran."""
    tracemalloc.start()
    try:
        result: _T | BaseException = call()
    except Exception as exc:
        result = exc
    finally:
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    return result, peak


def _npy_header(dtype: Any, shape: tuple[int, ...]) -> bytes:
    """The header of an ``.npy`` array of ``shape`` and ``dtype`` (no data)."""
    out = io.BytesIO()
    header = np.lib.format.header_data_from_array_1_0(np.empty(0, dtype))
    np.lib.format.write_array_header_1_0(out, header | {"shape": shape})
    return out.getvalue()


def _npy(array: np.ndarray) -> bytes:
    out = io.BytesIO()
    np.save(out, array)
    return out.getvalue()


def _zeros_member(archive: zipfile.ZipFile, name: str, dtype: Any, n: int) -> None:
    """A compressed member of ``n`` zero items of ``dtype``, written in small pieces (a few
    kilobytes on disk, ``n * itemsize`` bytes when read)."""
    with archive.open(name, "w", force_zip64=True) as member:
        member.write(_npy_header(dtype, (n,)))
        left = n * np.dtype(dtype).itemsize
        piece = bytes(1 << 16)
        while left:
            member.write(piece[: min(left, len(piece))])
            left -= min(left, len(piece))


def _bomb_npz(path: Path, n: int) -> Path:
    """An ``.npz`` recording of ``n`` events (all zero: valid) compressed to a few KB."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        _zeros_member(archive, "events.npy", EVENT_DTYPE, n)
        archive.writestr("sensor_size.npy", _npy(np.array(SIZE, dtype=np.int64)))
    return path


# -- 1. compressed .npz, lying .npy headers ----------------------------------------------------


def test_a_compressed_npz_beyond_the_memory_limit_is_refused_before_it_is_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    n = 200_000  # 2.6 MB of events when read, about 3 KB on disk
    path = _bomb_npz(tmp_path / "bomb.npz", n)
    assert path.stat().st_size < 50_000
    limit = 1_000_000
    monkeypatch.setattr(uwindows, "MEMORY_LIMIT", limit)
    result, peak = _peak(lambda: uio.read(path))
    assert isinstance(result, RecordingFileError), result
    assert "bomb.npz" in str(result) and "MEMORY_LIMIT" in str(result)
    assert peak < limit // 4, peak  # refused from the header, before the data
    # With room for the events and their canonical copy, it is read.
    monkeypatch.setattr(uwindows, "MEMORY_LIMIT", 2 * n * EVENT_DTYPE.itemsize + 1_000)
    assert len(uio.read(path)) == n


def test_an_npz_whose_header_claims_more_than_its_member_holds_is_corrupt(
    tmp_path: Path,
) -> None:
    path = tmp_path / "liar.npz"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("events.npy", _npy_header(EVENT_DTYPE, (10**9,)) + bytes(130))
        archive.writestr("sensor_size.npy", _npy(np.array(SIZE, dtype=np.int64)))
    result, peak = _peak(lambda: uio.read(path))
    assert isinstance(result, RecordingFileError), result
    assert "liar.npz" in str(result) and "claims 13,000,000,000 bytes" in str(result)
    assert peak < 1 << 20


def test_an_npz_array_of_empty_items_is_counted_by_its_items(tmp_path: Path) -> None:
    # 10^12 items of 0 bytes hold nothing, yet .tolist() would make 10^12 objects.
    path = tmp_path / "void.npz"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("events.npy", _npy(np.zeros(0, EVENT_DTYPE)))
        archive.writestr("sensor_size.npy", _npy_header("V0", (10**12,)))
    with pytest.raises(RecordingFileError, match=r"void\.npz: .*MEMORY_LIMIT"):
        uio.read(path)


def test_an_npz_member_of_objects_or_no_array_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "odd.npz"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("events.npy", b"not an array")
        archive.writestr("sensor_size.npy", _npy(np.array(SIZE, dtype=np.int64)))
    with pytest.raises(RecordingFileError, match=r"odd\.npz: cannot read as \.npz"):
        uio.read(path)


def test_an_npy_whose_header_claims_more_than_the_file_holds_is_refused_unallocated(
    tmp_path: Path,
) -> None:
    path = tmp_path / "liar.npy"
    path.write_bytes(_npy_header(EVENT_DTYPE, (10**7,)) + bytes(13 * 10))
    result, peak = _peak(lambda: uio.read(path, sensor_size=SIZE))
    assert isinstance(result, RecordingFileError), result
    assert "liar.npy: truncated or corrupt: its header claims 130,000,000 bytes" in str(result)
    assert peak < 1 << 20, peak  # NumPy would have allocated the 130 MB first


def test_an_npy_beyond_the_memory_limit_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "big.npy"
    np.save(path, _events(10_000))
    monkeypatch.setattr(uwindows, "MEMORY_LIMIT", 100_000)  # 10,000 * 13 * 2 = 260,000 needed
    with pytest.raises(RecordingFileError, match=r"big\.npy: 10,000 events .*MEMORY_LIMIT"):
        uio.read(path)
    monkeypatch.setattr(uwindows, "MEMORY_LIMIT", 260_000)
    assert len(uio.read(path)) == 10_000


@pytest.mark.parametrize("suffix", [".npz", ".npy"])
def test_running_out_of_memory_while_reading_is_a_file_error(
    suffix: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / f"r{suffix}"
    if suffix == ".npz":
        uio.write_npz(Recording(_events(50), SIZE), path)
    else:
        np.save(path, _events(50))

    def hungry(_array: object) -> np.ndarray:
        raise MemoryError

    monkeypatch.setattr(uio, "convert", hungry)
    with pytest.raises(RecordingFileError, match=rf"r\{suffix}: not enough memory"):
        uio.read(path)


# -- 1b. split files ----------------------------------------------------------------------------


def _split(root: Path, extra: Callable[[zipfile.ZipFile], None] | None = None) -> Path:
    """A one-window dataset in ``root`` whose split file ``test.npz`` gets ``extra`` members
    (its manifest hashing the result)."""
    root.mkdir()
    windows = Windows(SIZE, 1_000, [0], [0, 2], [5, 7], [1, 2], [1, 2], [0])
    data = LabelledWindows(windows, [True], ["drone"], [0], np.zeros((1, 4), np.float32))
    path = save_split(root / "test.npz", data)
    if extra is not None:
        with zipfile.ZipFile(path, "a", zipfile.ZIP_DEFLATED) as archive:
            extra(archive)
    manifest = {
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "splits": {"test": {"file": "test.npz", "windows": 1}},
    }
    write_manifest(root, manifest)
    return root


def _replaced(root: Path, name: str, data: bytes) -> None:
    """Replace split member ``name`` and rehash the manifest."""
    path = root / "test.npz"
    with zipfile.ZipFile(path) as archive:
        members = {i.filename: archive.read(i) for i in archive.infolist()}
    with zipfile.ZipFile(path, "w") as archive:
        for member, content in members.items():
            archive.writestr(member, data if member == name else content)
    write_manifest(root, json.loads((root / "manifest.json").read_text()))


def test_a_split_file_member_it_does_not_need_is_not_read(tmp_path: Path) -> None:
    root = _split(
        tmp_path / "set",
        lambda archive: _zeros_member(archive, "junk.npy", np.uint8, 16_000_000),
    )
    result, peak = _peak(lambda: load(root, "test"))
    assert isinstance(result, LabelledWindows), result
    # The 16 MB member was skipped (the file's hash is read in 1 MB blocks).
    assert len(result) == 1 and peak < 4_000_000, peak


def test_a_split_file_beyond_the_memory_limit_is_refused_before_it_is_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    root = _split(tmp_path / "set")
    _replaced(
        root, "t.npy", _npy_header(np.uint64, (10**8,)) + bytes(16)
    )  # claims 800 MB, holds 16 bytes
    result, peak = _peak(lambda: load(root, "test"))
    assert isinstance(result, DatasetError), result
    assert "'t.npy' claims 800,000,000 bytes" in str(result) and peak < 1 << 20, peak
    root = _split(tmp_path / "set2")
    assert len(load(root, "test")) == 1
    # 10^12 items of no byte are counted by their items.
    _replaced(root, "cls.npy", _npy_header("V0", (10**12,)))
    with pytest.raises(DatasetError, match=r"test\.npz would take .*MEMORY_LIMIT"):
        load(root, "test")
    root = _split(tmp_path / "set3")
    monkeypatch.setattr(uwindows, "MEMORY_LIMIT", 100)
    with pytest.raises(DatasetError, match=r"test\.npz would take .*MEMORY_LIMIT"):
        load(root, "test")


# -- 2. motion search ---------------------------------------------------------------------------


def test_a_motion_box_above_max_pixels_is_refused() -> None:
    empty = np.zeros(0, dtype=EVENT_DTYPE)
    with pytest.raises(ParameterError, match=r"20000x20000 = 400000000 pixels .*MAX_PIXELS"):
        estimate_motion(empty, (0, 0, 20_000, 20_000))
    side = int(MAX_PIXELS**0.5)
    assert estimate_motion(empty, (0, 0, side, side)).events == 0


def test_coarse_steps_above_their_maximum_are_refused() -> None:
    empty = np.zeros(0, dtype=EVENT_DTYPE)
    with pytest.raises(ParameterError, match=rf"coarse_steps must be at most {MAX_COARSE_STEPS}"):
        estimate_motion(empty, (0, 0, 8, 8), coarse_steps=MAX_COARSE_STEPS + 1)
    assert estimate_motion(empty, (0, 0, 8, 8), coarse_steps=MAX_COARSE_STEPS).events == 0


def _spread(n: int, side: int) -> np.ndarray:
    rng = np.random.default_rng(5)
    ev = np.zeros(n, dtype=EVENT_DTYPE)
    ev["t"] = np.arange(n) * 100
    ev["x"] = rng.integers(0, side, n)
    ev["y"] = rng.integers(0, side, n)
    ev["x"][:2], ev["y"][:2] = (0, side - 1), (0, side - 1)
    return ev


def test_a_motion_search_over_a_large_box_costs_what_its_events_cost() -> None:
    # 32 events spread over a 2048x2048 box: a dense image would take 33 MB per contrast
    # (and 13 s over the search); a sparse one, kilobytes.
    events = _spread(32, 2048)
    result, peak = _peak(lambda: estimate_motion(events, (0, 0, 2048, 2048), coarse_steps=1))
    assert isinstance(result, usig.MotionEstimate), result
    assert peak < 4_000_000, peak


def test_the_sparse_and_dense_contrast_agree(monkeypatch: pytest.MonkeyPatch) -> None:
    # An edge moving at 400 px/s, few events over a 64x32 box: sparse unless forced dense.
    rng = np.random.default_rng(1)
    n = 60
    ev = np.zeros(n, dtype=EVENT_DTYPE)
    ev["t"] = np.sort(rng.integers(0, 50_000, n))
    ev["x"] = 10 + (ev["t"] * 400 // 1_000_000) + rng.integers(0, 2, n)
    ev["y"] = rng.integers(4, 28, n)
    x = ev["x"].astype(np.float64)
    y = ev["y"].astype(np.float64)
    dt = (ev["t"].astype(np.float64) - 25_000) * 1e-6
    sparse = usig._contrast(x, y, dt, 300.0, 10.0)
    monkeypatch.setattr(usig, "_DENSE_PIXELS", 1 << 40)
    dense = usig._contrast(x, y, dt, 300.0, 10.0)
    assert sparse == pytest.approx(dense, rel=1e-12)
    forced = estimate_motion(ev, (0, 0, 64, 32))
    monkeypatch.setattr(usig, "_DENSE_PIXELS", 0)
    assert estimate_motion(ev, (0, 0, 64, 32)) == pytest.approx(forced)
    assert abs(forced.vx - 400.0) < 60.0, forced


# -- 3. standard input: a CSV line without end --------------------------------------------------


class _Endless(io.RawIOBase):
    """``head`` bytes, then ``digits`` digits without a newline, then ``tail``."""

    def __init__(self, head: bytes, digits: int, tail: bytes) -> None:
        self.parts: Iterator[bytes] = iter(
            [p for p in (head, *(b"7" * 4096 for _ in range(digits // 4096)), tail) if p]
        )

    def readable(self) -> bool:
        return True

    def read1(self, _size: int = -1) -> bytes:
        return next(self.parts, b"")


def test_a_stdin_csv_line_without_end_is_dropped_not_held() -> None:
    src = StdinSource(
        _Endless(b"1,1,1,1\n", 1 << 20, b"\n2,2,2,1\n3,3,3,0"),  # type: ignore[arg-type]
        fmt="csv",
        sensor_size=SIZE,
        read_size=4096,
    )
    result, peak = _peak(lambda: list(src))
    assert not isinstance(result, BaseException), result
    assert sum(len(c) for c in result) == 3
    assert src.stats.dropped == 1 and src.stats.events == 3
    assert peak < 256 * 1024, peak  # the 1 MB line was never gathered


def test_a_stdin_stream_of_one_endless_line_holds_no_event() -> None:
    src = StdinSource(
        _Endless(b"", 1 << 18, b""),  # type: ignore[arg-type]
        fmt="csv",
        sensor_size=SIZE,
        read_size=4096,
    )
    with pytest.raises(StreamError, match=r"no usable csv event \(1 dropped\)"):
        list(src)


# -- 4. CSV recordings --------------------------------------------------------------------------


def test_a_csv_time_of_thousands_of_digits_is_a_file_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "long.csv"
    path.write_text("1,1,1,1\n" + "9" * 5000 + ",1,1,1\n")
    with pytest.raises(RecordingFileError, match=r"long\.csv: line 2: a time of 5,000 digits"):
        uio.read(path, sensor_size=SIZE)
    one_line_exit_2(capsys, ["info", str(path), "--sensor-size", "64x48"], "5,000 digits")
    bom = tmp_path / "bom.csv"
    bom.write_bytes(b"\xef\xbb\xbf1," + b"9" * 5000 + b",1,1\n2,1,1,1\n")
    with pytest.raises(RecordingFileError, match=r"bom\.csv: line 1: not an event"):
        uio.read(bom, sensor_size=SIZE)


def test_a_csv_line_longer_than_the_cap_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "endless.csv"
    path.write_bytes(b"1,1,1,1\n2," + b"x" * (uio.CSV_MAX_LINE + 10))
    with pytest.raises(RecordingFileError, match=r"endless\.csv: line 2 is longer than 4,096"):
        uio.read(path, sensor_size=SIZE)
    short = tmp_path / "short.csv"
    short.write_bytes(b"1,1,1,1\n2,2,2,0")  # a last line without newline is still read
    assert len(uio.read(short, sensor_size=SIZE)) == 2


# -- 5. scenes ---------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def scene() -> dict[str, Any]:
    spec = sample_spec("dvs", "uav", np.random.default_rng(3), duration_s=0.02, size=(64, 48))
    return spec_to_dict(spec)


def test_a_scene_of_too_many_objects_is_refused(scene: dict[str, Any]) -> None:
    d = copy.deepcopy(scene)
    d["objects"] = [d["objects"][0]] * (MAX_OBJECTS + 1)
    with pytest.raises(SimulationError, match=rf"at most {MAX_OBJECTS} objects"):
        spec_from_dict(d)
    d["objects"] = d["objects"][:MAX_OBJECTS]
    assert len(spec_from_dict(d).objects) == MAX_OBJECTS


def test_a_path_of_too_many_harmonics_is_refused(scene: dict[str, Any]) -> None:
    d = copy.deepcopy(scene)
    k = MAX_HARMONICS + 1
    d["objects"][0]["path"].update(
        amplitudes=[[0.1, 0.1, 0.1]] * k, freqs=[1.0] * k, phases=[0.0] * k
    )
    with pytest.raises(SimulationError, match=rf"{k} terms, more than {MAX_HARMONICS}"):
        spec_from_dict(d)
    with pytest.raises(SimulationError, match="MAX_HARMONICS"):
        PathSpec("hover", (0.0, 0.0, 5.0), amplitudes=((0.1,) * 3,) * k, freqs=(1.0,) * k,
                 phases=(0.0,) * k)  # fmt: skip


def test_a_scene_file_of_too_many_objects_is_one_line(
    scene: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    d = copy.deepcopy(scene)
    d["objects"] = [d["objects"][0]] * 2000
    path = tmp_path / "crowd.json"
    path.write_text(json.dumps(d))
    argv = ["simulate", "--scene", str(path), "-o", str(tmp_path / "o.npz"), "--size", "64x48"]
    one_line_exit_2(capsys, argv, "at most 64 objects")
    assert not (tmp_path / "o.npz").exists()


# -- 6. uavsnn bench ----------------------------------------------------------------------------


@pytest.fixture
def no_bench_run(monkeypatch: pytest.MonkeyPatch) -> None:
    """Any bench work fails the test: the refusals must come first."""

    def ran(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("the bench ran")

    monkeypatch.setattr(ubench, "synthetic_windows", ran)
    monkeypatch.setattr(Network, "infer", ran)


@pytest.mark.usefixtures("no_bench_run")
@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"repeat": ubench.MAX_BENCH_REPEAT + 1}, "repeat must be in"),
        ({"repeat": 0}, "repeat must be in"),
        ({"repeat": 2.5}, "repeat must be an integer"),
        ({"threads": MAX_THREADS + 1}, "threads must be in"),
        ({"threads": 100_000}, "threads must be in"),
        ({"threads": 0}, "threads must be in"),
    ],
)
def test_bench_repeat_and_threads_are_capped_before_any_run(
    kwargs: dict[str, Any], match: str
) -> None:
    net = Network({"width": 16, "height": 12}, seed=0)
    with pytest.raises(ParameterError, match=match):
        ubench.bench_density(net, 0.05, windows=2, **kwargs)


@pytest.mark.usefixtures("no_bench_run")
@pytest.mark.parametrize(("option", "value"), [("--repeat", "1000000000"), ("--threads", "100000")])
def test_the_bench_command_refuses_them_in_one_line(
    option: str, value: str, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["bench", "--size", "16x12", "--windows", "2", "--quiet", option, value]
    one_line_exit_2(capsys, argv, option.lstrip("-"))
