"""Bad input a new user meets: each case ends in a typed error (the command line: one line on
standard error, exit 2; Ctrl-C: one "interrupted" line, exit 130) and loses nothing."""

from __future__ import annotations

import fcntl
import io
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import uavsnn
import uavsnn.cli.dataset
import uavsnn.cli.demo
import uavsnn.cli.train
from uavsnn import EVENT_DTYPE, ParameterError, RecordingFileError, StreamError
from uavsnn import io as uio
from uavsnn import windows as uwindows
from uavsnn.cli import main
from uavsnn.dataset import SceneSource, build, load
from uavsnn.dataset.format import LOCK
from uavsnn.detector import MAX_LIVE_WINDOWS, Detector
from uavsnn.errors import DatasetError
from uavsnn.network import MAX_THREADS, Network, _window_columns
from uavsnn.sources import StdinSource
from uavsnn.training import train
from uavsnn.windows import make_windows

SIZE = (40, 30)
CONFIG = {
    "width": SIZE[0],
    "height": SIZE[1],
    "pent": {"mode": "pent", "beta": 2.0, "theta_min": 1.5, "estimate": "preceding"},
    "conv2": {"threshold": 3.0},
    "conv3": {"threshold": 1.5},
}
DVS = SceneSource("dvs", (240, 180), 200.0, 0.3)


@pytest.fixture(scope="module")
def net() -> Network:
    return Network(CONFIG, seed=3)


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory, net: Network) -> Path:
    path = tmp_path_factory.mktemp("model") / "model.npz"
    net.save(path)
    return path


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("data") / "set"
    return build(root, "dvs", n_test=10, n_train=16, seed=3, dvs=DVS).root


def _events(n: int, seed: int = 0, size: tuple[int, int] = SIZE) -> np.ndarray:
    rng = np.random.default_rng(seed)
    ev = np.zeros(n, dtype=EVENT_DTYPE)
    ev["t"] = 1_000 + np.cumsum(rng.integers(0, 30, n))
    ev["x"] = rng.integers(0, size[0], n)
    ev["y"] = rng.integers(0, size[1], n)
    ev["p"] = rng.random(n) < 0.5
    return ev


def _one_line_exit_2(capsys: pytest.CaptureFixture[str], argv: list[str], match: str) -> str:
    """Run the command line; it must exit 2 with one error line that contains ``match``."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "error:" in lines[0] and match in lines[0], lines[0]
    return lines[0]


def test_an_overlap_with_too_many_live_windows_is_refused(net: Network) -> None:
    most = 1 - 1 / MAX_LIVE_WINDOWS
    det = Detector(net, window_us=64_000, overlap=most)
    det.push(_events(2_000))
    assert det.live_windows <= MAX_LIVE_WINDOWS
    for overlap in (0.99, 0.9999, 0.9999999):
        with pytest.raises(ParameterError, match=f"at most {MAX_LIVE_WINDOWS} are allowed"):
            Detector(net, window_us=50_000, overlap=overlap)


def test_detect_refuses_such_an_overlap_in_one_line(
    model: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rec = tmp_path / "r.npz"
    uio.write_npz(uavsnn.Recording(_events(500), SIZE), rec)
    _one_line_exit_2(
        capsys, ["detect", str(rec), "-m", str(model), "--overlap", "0.9999"], "windows live"
    )


def test_thread_counts_are_capped(net: Network) -> None:
    w = make_windows(uavsnn.Recording(_events(800), SIZE), 5_000)
    for threads in (MAX_THREADS + 1, 3000):
        with pytest.raises(ParameterError, match=f"at most {MAX_THREADS}"):
            net.infer(w, threads=threads)
    # The engine refuses on its own too (the check a caller of the binding meets).
    with pytest.raises(ParameterError, match=f"at most {MAX_THREADS}"):
        net._core.infer(**_window_columns(w), threads=MAX_THREADS + 1, record=False)
    # Alternating counts give the same results (pools are reused or replaced, not piled up).
    first = net.infer(w, threads=2).counts
    for threads in (3, 2, 4, 3):
        assert np.array_equal(net.infer(w, threads=threads).counts, first)


@pytest.mark.parametrize("header", ["t,x,y,p\n", ""])
def test_csv_with_times_out_of_order_is_refused_with_its_line(tmp_path: Path, header: str) -> None:
    path = tmp_path / "r.csv"
    path.write_text(header + "100,2,3,1\n120,2,3,1\n50,3,3,0\n")
    line = 3 + bool(header)
    with pytest.raises(RecordingFileError, match=f"line {line}: time 50 is earlier .*120"):
        uio.read(path, sensor_size=(10, 10))


@pytest.mark.parametrize("header", ["t,x,y,p\n", ""])
def test_csv_keeps_every_row_with_or_without_a_header(tmp_path: Path, header: str) -> None:
    path = tmp_path / "r.csv"
    path.write_text(header + "100,2,3,1\n100,4,3,0\n150,3,3,0\n")
    rec = uio.read(path, sensor_size=(10, 10))
    assert rec.events["t"].tolist() == [100, 100, 150]
    assert rec.events["x"].tolist() == [2, 4, 3]


def test_stdin_drops_only_the_offending_events() -> None:
    ev = _events(20_000)
    bad = ev.copy()
    bad["t"][7_000] = 5  # one backwards time
    bad["x"][12_345] = SIZE[0] + 3  # one event off the sensor
    src = StdinSource(io.BytesIO(bad.tobytes()), sensor_size=SIZE, read_size=13 * 1000)
    got = np.concatenate(list(src))
    keep = np.ones(len(ev), bool)
    keep[[7_000, 12_345]] = False
    assert np.array_equal(got, bad[keep])
    assert src.stats.dropped == 2 and src.stats.events == len(ev) - 2


def test_stdin_in_the_wrong_format_is_an_error_not_zero_events() -> None:
    text = "".join(f"{t},{x},{y},1\n" for t, x, y in [(10, 1, 1), (20, 2, 2), (30, 3, 3)] * 50)
    src = StdinSource(io.BytesIO(text.encode()), fmt="packed", sensor_size=SIZE)
    with pytest.raises(StreamError, match="--stdin-format"):
        list(src)
    src = StdinSource(io.BytesIO(_events(100).tobytes()), fmt="csv", sensor_size=SIZE)
    with pytest.raises(StreamError, match="--stdin-format"):
        list(src)


def test_detect_on_stdin_in_the_wrong_format_exits_2(
    model: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    text = "".join(f"{1000 + t},1,1,1\n" for t in range(200)).encode()
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(text)))
    assert main(["detect", "-", "-m", str(model), "--summary-every", "0"]) == 2
    assert "--stdin-format" in capsys.readouterr().err


def test_resume_refuses_changed_settings_or_data(dataset: Path, tmp_path: Path) -> None:
    windows = load(dataset, "train").windows
    ckpt = tmp_path / "ckpt"
    train(Network(CONFIG | {"width": 240, "height": 180}, seed=1), windows, layers=["conv2"],
          windows_per_layer=8, seed=1, checkpoint_dir=ckpt)  # fmt: skip
    base = CONFIG | {"width": 240, "height": 180}
    changed = base | {"conv2": {"threshold": 99.0}}
    with pytest.raises(ParameterError, match="network config"):
        train(Network(changed, seed=1), windows, windows_per_layer=8, seed=1,
              checkpoint_dir=ckpt, resume=True)  # fmt: skip
    with pytest.raises(ParameterError, match="the seed"):
        train(Network(base, seed=1), windows, windows_per_layer=8, seed=2,
              checkpoint_dir=ckpt, resume=True)  # fmt: skip
    other = load(dataset, "test").windows
    with pytest.raises(ParameterError, match="training windows"):
        train(Network(base, seed=1), other, windows_per_layer=8, seed=1,
              checkpoint_dir=ckpt, resume=True)  # fmt: skip
    # The same settings resume, and train the layer that was left.
    result = train(Network(base, seed=1), windows, windows_per_layer=8, seed=1,
                   checkpoint_dir=ckpt, resume=True)  # fmt: skip
    assert result.resumed == ("conv2",) and list(result.layers) == ["conv3"]


def test_a_second_build_into_a_locked_folder_fails_fast(tmp_path: Path) -> None:
    root = tmp_path / "set"
    root.mkdir()
    fd = os.open(root / LOCK, os.O_WRONLY | os.O_CREAT)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)  # as a running build holds it
        start = time.monotonic()
        with pytest.raises(DatasetError, match="another build is writing"):
            build(root, "dvs", n_test=10, n_train=16, seed=3, dvs=DVS)
        assert time.monotonic() - start < 5
    finally:
        os.close(fd)
    assert [p.name for p in root.iterdir()] == [LOCK]  # nothing written


def test_a_split_file_from_another_build_is_refused(dataset: Path, tmp_path: Path) -> None:
    other = build(tmp_path / "other", "dvs", n_test=10, n_train=16, seed=4, dvs=DVS).root
    manifest = json.loads((dataset / "manifest.json").read_text())
    assert len(manifest["splits"]["test"]["sha256"]) == 64
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    for name in ("manifest.json", "train.npz"):
        (mixed / name).write_bytes((dataset / name).read_bytes())
    (mixed / "test.npz").write_bytes((other / "test.npz").read_bytes())
    assert len(load(mixed, "train")) == 16
    with pytest.raises(DatasetError, match="SHA-256 differs"):
        load(mixed, "test")


def test_windowing_beyond_the_memory_limit_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    rec = uavsnn.Recording(_events(10_000), SIZE)
    assert len(make_windows(rec, 5_000, 0.5).t0)
    # 10,000 events at 50 % overlap may take 10,000 * (16 + 2 * 12) bytes.
    monkeypatch.setattr(uwindows, "MEMORY_LIMIT", 400_000 - 1)
    with pytest.raises(ParameterError, match=r"windowing 10,000 events .* uavsnn.Detector"):
        make_windows(rec, 5_000, 0.5)
    monkeypatch.setattr(uwindows, "MEMORY_LIMIT", 400_000)
    assert len(make_windows(rec, 5_000, 0.5).t0)


def test_detector_of_no_network_is_a_parameter_error() -> None:
    with pytest.raises(ParameterError, match="got NoneType"):
        Detector(None)  # type: ignore[arg-type]


def test_garbage_npy_and_folders_are_named_for_what_they_are(tmp_path: Path) -> None:
    garbage = tmp_path / "g.npy"
    garbage.write_bytes(b"garbage" * 10)
    with pytest.raises(RecordingFileError, match=r"not a NumPy \.npy file") as info:
        uio.read(garbage)
    assert "pickled" not in str(info.value)
    folder = tmp_path / "rec.npz"
    folder.mkdir()
    with pytest.raises(RecordingFileError, match="is a folder"):
        uio.read(folder)
    with pytest.raises(RecordingFileError, match="no such file"):
        uio.read(tmp_path / "absent.npz")
