"""Bad input a new user meets: each case ends in a typed error (the command line: one line on
standard error, exit 2; Ctrl-C: one "interrupted" line, exit 130) and loses nothing."""

from __future__ import annotations

import io
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import one_line_exit_2 as _one_line_exit_2
from conftest import random_events

import uavsnn
import uavsnn.cli.dataset
import uavsnn.cli.demo
import uavsnn.cli.train
from uavsnn import EVENT_DTYPE, ParameterError, RecordingFileError, StreamError
from uavsnn import io as uio
from uavsnn import windows as uwindows
from uavsnn.cli import main
from uavsnn.dataset import SceneSource, build, load
from uavsnn.dataset.format import LOCK, locked_folder
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
    return random_events(n, size, seed)


# -- 1. overlaps that keep too many windows live ------------------------------------------------


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


# -- 2. thread counts ---------------------------------------------------------------------------


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


def test_evaluate_refuses_20000_threads_at_once(
    model: Path, dataset: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    start = time.monotonic()
    _one_line_exit_2(
        capsys, ["evaluate", str(model), str(dataset), "--threads", "20000"], "--threads"
    )
    assert time.monotonic() - start < 10


# -- 3. one line and exit 2, not a traceback ----------------------------------------------------


@pytest.mark.parametrize("value", ["nan", "inf", "1e30", "-1", "0"])
def test_detect_window_ms_must_be_a_sane_number(
    value: str, model: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _one_line_exit_2(
        capsys, ["detect", "x.npz", "-m", str(model), "--window-ms", value], "--window-ms"
    )


def test_detect_summary_every_and_realtime_on_stdin_are_checked(
    model: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _one_line_exit_2(
        capsys, ["detect", "x.npz", "-m", str(model), "--summary-every", "-1"], "--summary-every"
    )
    _one_line_exit_2(capsys, ["detect", "-", "-m", str(model), "--realtime"], "--realtime")


def test_train_config_missing_or_not_json(
    tmp_path: Path, dataset: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = str(tmp_path / "m.npz")
    _one_line_exit_2(
        capsys,
        ["train", str(dataset), "-o", out, "--config", str(tmp_path / "missing.json")],
        "cannot read",
    )
    bad = tmp_path / "bad.json"
    bad.write_text("width: 240\n")
    _one_line_exit_2(capsys, ["train", str(dataset), "-o", out, "--config", str(bad)], "not a JSON")
    assert not Path(out).exists()


def test_output_folders_that_cannot_be_written(
    tmp_path: Path, model: Path, dataset: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A path under a file can be made by nobody, root included.
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    under = str(blocker / "sub")
    _one_line_exit_2(capsys, ["dataset", "build", under, "--domain", "dvs"], "OUT_DIR")
    _one_line_exit_2(capsys, ["demo", "--out", under], "--out")
    _one_line_exit_2(capsys, ["evaluate", str(model), str(dataset), "--report", under], "--report")
    # An existing file given as the report folder.
    _one_line_exit_2(
        capsys,
        ["evaluate", str(model), str(dataset), "--report", str(blocker)],
        "exists and is not a folder",
    )
    assert blocker.read_text() == "x"


@pytest.mark.parametrize(
    ("module", "handler", "argv"),
    [
        (uavsnn.cli.train, "_train", ["train", "D", "-o", "m.npz"]),
        (uavsnn.cli.dataset, "_build", ["dataset", "build", "D", "--domain", "dvs"]),
        (uavsnn.cli.demo, "_demo", ["demo"]),
    ],
)
def test_ctrl_c_is_one_line_and_exit_130(
    module: object,
    handler: str,
    argv: list[str],
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    def interrupted(_args: object) -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(module, handler, interrupted)
    assert main(argv) == 130
    err = capsys.readouterr().err
    name = " ".join(["uavsnn", *argv[:2]] if argv[0] == "dataset" else ["uavsnn", argv[0]])
    assert err == f"{name}: interrupted\n"


def test_ctrl_c_during_a_real_dataset_build(tmp_path: Path) -> None:
    out = tmp_path / "set"
    proc = subprocess.Popen(
        [sys.executable, "-m", "uavsnn", "dataset", "build", str(out), "--domain", "dvs"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # A shell without job control starts background commands with SIGINT ignored, and
        # children inherit that; give the command the terminal's default, as a user's has.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    # Wait until the build has started writing into its folder (it holds its lock).
    deadline = time.monotonic() + 60
    while not (out / LOCK).exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    # Piped, a build reports progress in plain lines; the last line is the interruption.
    lines = err.strip().splitlines()
    assert lines[-1] == "uavsnn dataset build: interrupted", err
    assert not any("Traceback" in line for line in lines), err
    # Nothing half-written: no manifest, no temporary file, no lock left behind.
    assert not out.exists() or not [p.name for p in out.iterdir()]


def test_a_closed_standard_output_is_not_a_traceback(shared_data: Path) -> None:
    read, write = os.pipe()
    os.close(read)  # the reader is gone before anything is written, as with `| head -0`
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "uavsnn",
            "info",
            str(shared_data / "dvs" / "tonic_dvxplorer_person.aedat4"),
        ],
        stdout=write,
        stderr=subprocess.PIPE,
        text=True,
        timeout=120,
        check=False,
    )
    os.close(write)
    assert proc.stderr == ""
    assert proc.returncode == 1


# -- 4. CSV times that go backwards -------------------------------------------------------------


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


# -- 5. one bad event on standard input ---------------------------------------------------------


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


# -- 6. resume with other settings or data ------------------------------------------------------


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


# -- 7. concurrent builds and split files from another build ------------------------------------


def test_a_second_build_into_a_locked_folder_fails_fast(tmp_path: Path) -> None:
    root = tmp_path / "set"
    with locked_folder(root):  # as a running build holds it (flock, or msvcrt on Windows)
        assert (root / LOCK).exists()
        start = time.monotonic()
        with pytest.raises(DatasetError, match="another build is writing"):
            build(root, "dvs", n_test=10, n_train=16, seed=3, dvs=DVS)
        assert time.monotonic() - start < 5
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


# -- 9. recordings larger than memory -----------------------------------------------------------


def test_windowing_beyond_the_memory_limit_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    rec = uavsnn.Recording(_events(10_000), SIZE)
    assert len(make_windows(rec, 5_000, 0.5).t0)
    # 10,000 events at 50 % overlap may take 10,000 * (16 + 2 * 12) bytes, and a window every
    # 2,500 µs over their span 24 bytes each.
    t = rec.events["t"]
    need = 10_000 * 40 + -(-(int(t[-1]) + 1 - int(t[0])) // 2_500) * 24
    monkeypatch.setattr(uwindows, "MEMORY_LIMIT", need - 1)
    with pytest.raises(
        ParameterError,
        match=r"windowing 10,000 events .* uavsnn.Detector .* cuts short the windows",
    ):
        make_windows(rec, 5_000, 0.5)
    monkeypatch.setattr(uwindows, "MEMORY_LIMIT", need)
    assert len(make_windows(rec, 5_000, 0.5).t0)
    # Two events far apart hold few spikes but a window every microsecond between them.
    two = uavsnn.Recording(_events(2)[[0, 1]], SIZE)
    two.events["t"][1] = two.events["t"][0] + 10_000_000
    monkeypatch.setattr(uwindows, "MEMORY_LIMIT", 100_000_000)
    with pytest.raises(ParameterError, match=r"windowing 2 events"):
        make_windows(two, 1)
    monkeypatch.setattr(uwindows, "MEMORY_LIMIT", 300_000_000)
    assert len(make_windows(two, 1).t0) > 0


def test_the_command_line_reports_a_failed_allocation_in_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def hungry(_args: object) -> int:
        raise MemoryError

    monkeypatch.setattr(uavsnn.cli.train, "_train", hungry)
    _one_line_exit_2(capsys, ["train", "D", "-o", "m.npz"], "not enough memory")


# -- a first use, and the small ones ------------------------------------------------------------


def test_a_sensor_mismatch_names_the_downsample_flag(
    shared_data: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = tmp_path / "model.npz"
    Network(seed=0).save(model)  # the README's 240x180 model
    rec = shared_data / "dvs" / "tonic_dvxplorer_person.aedat4"
    line = _one_line_exit_2(capsys, ["detect", str(rec), "--model", str(model)], "--downsample")
    assert "uavsnn.filters" not in line
    assert main(["detect", str(rec), "--model", str(model), "--downsample"]) == 0


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


def test_selecting_windows_beyond_the_memory_limit_is_refused(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    wins = make_windows(uavsnn.Recording(_events(2_000), SIZE), 5_000)
    spikes = int(np.diff(wins.offsets).max())
    busiest = int(np.argmax(np.diff(wins.offsets)))
    monkeypatch.setattr(uwindows, "MEMORY_LIMIT", 1_000 * spikes * 20)
    assert len(wins.select([busiest] * 1_000).t) == 1_000 * spikes
    with pytest.raises(ParameterError, match=r"selecting 1,001 windows copies"):
        wins.select([busiest] * 1_001)


def test_training_snapshots_are_capped() -> None:
    from uavsnn.network import Network
    from uavsnn.training import MAX_SNAPSHOTS, train

    wins = make_windows(uavsnn.Recording(_events(2_000), SIZE), 5_000)
    net = Network({"width": SIZE[0], "height": SIZE[1]})
    for bad in (MAX_SNAPSHOTS + 1, 10**9, -1, "6", 2.5):
        with pytest.raises(ParameterError, match="snapshots"):
            train(net, wins, snapshots=bad, windows_per_layer=1)


def test_reading_a_recording_beyond_the_memory_limit_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "r.csv"
    ev = _events(5_000)
    path.write_text("".join(f"{e['t']},{e['x']},{e['y']},{int(e['p'])}\n" for e in ev))
    assert len(uio.read(path, sensor_size=SIZE)) == 5_000
    # 5,000 events of 13 bytes, held twice while they are joined: 130,000 bytes.
    monkeypatch.setattr(uwindows, "MEMORY_LIMIT", 100_000)
    with pytest.raises(RecordingFileError, match=r"more than [\d,]+ events .* shorter files"):
        uio.read(path, sensor_size=SIZE)
    monkeypatch.setattr(uwindows, "MEMORY_LIMIT", 130_000)
    assert len(uio.read(path, sensor_size=SIZE)) == 5_000


# -- 10. options a first user gets wrong: refused before any work, nothing written --------------


def test_preview_to_a_name_that_is_not_png_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # OpenCV found no writer for '.txt' (or no suffix) and its error ended the command.
    for name in ("sheet.txt", "sheet"):
        out = tmp_path / name
        _one_line_exit_2(capsys, ["dataset", "preview", str(out), "--duration", "0.02"], ".png")
        assert not out.exists()


def _simulate_scene(tmp_path: Path, *extra: str) -> list[str]:
    out = tmp_path / "s.npz"
    return ["simulate", "--scene", "ball", "-o", str(out), "--quiet", *extra]


def test_simulate_refuses_a_bad_preview_before_writing_the_recording(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A preview it cannot write was refused only after the recording and its labels were
    written (over any earlier ones)."""
    for preview in (tmp_path / "s.jpg", tmp_path / "missing" / "s.png"):
        argv = _simulate_scene(tmp_path, "--duration", "0.02", "--preview", str(preview))
        _one_line_exit_2(capsys, argv, "--preview")
        assert sorted(p.name for p in tmp_path.iterdir()) == []
    _one_line_exit_2(capsys, ["simulate", "x.mp4", "-o", str(tmp_path / "no" / "x.npz")], "-o")
    (tmp_path / "d.npz").mkdir()
    _one_line_exit_2(capsys, _simulate_scene(tmp_path, "-o", str(tmp_path / "d.npz")), "a folder")
    assert not (tmp_path / "d.labels.npz").exists()


@pytest.mark.parametrize(
    "extra",
    [
        ["--mode", "sim"],
        ["--threshold", "0.3"],
        ["--pix2nvs-compat"],
        ["--downsample", "events"],
        ["--max-frames", "3"],
        ["--fps", "10"],
    ],
)
def test_simulate_scene_refuses_the_options_of_a_video(
    extra: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # They were ignored: a scene is always recorded through the DVS emulator at its own rate.
    _one_line_exit_2(capsys, _simulate_scene(tmp_path, "--duration", "0.02", *extra), extra[0])
    assert not (tmp_path / "s.npz").exists()


def test_simulate_duration_is_for_a_sampled_scene_only(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from uavsnn.scenes import sample_spec, spec_to_dict

    assert main(_simulate_scene(tmp_path, "--duration", "0.02", "--mode", "dvs")) == 0
    capsys.readouterr()
    scene = tmp_path / "scene.json"
    spec = sample_spec("dvs", "ball", np.random.default_rng(0), duration_s=0.02)
    scene.write_text(json.dumps(spec_to_dict(spec)))
    out = tmp_path / "j.npz"
    argv = ["simulate", "--scene", str(scene), "-o", str(out), "--duration", "5"]
    _one_line_exit_2(capsys, argv, "--duration")
    _one_line_exit_2(capsys, ["simulate", "v.mp4", "-o", str(out), "--duration", "5"], "--duration")
    assert not out.exists()


def test_resume_without_a_checkpoint_folder_is_refused(
    dataset: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # It trained from scratch, as if --resume had not been given.
    out = tmp_path / "m.npz"
    argv = ["train", str(dataset), "-o", str(out), "--resume", "--no-identify", "--quiet"]
    _one_line_exit_2(capsys, argv, "--checkpoint-dir")
    assert not out.exists()
    with pytest.raises(ParameterError, match="checkpoint_dir"):
        train(Network(CONFIG | {"width": 240, "height": 180}), load(dataset, "train").windows,
              resume=True)  # fmt: skip


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"start_us": 1.5}, "start_us must be an integer"),
        ({"start_us": float("nan")}, "start_us must be an integer"),
        ({"start_us": 1 << 70}, "start_us must be in"),
        ({"window_us": 1 << 70}, "window_us must be in"),
    ],
)
def test_detector_times_that_are_no_u64_are_parameter_errors(
    net: Network, kwargs: dict, match: str
) -> None:
    # TypeError and OverflowError came out of the binding.
    with pytest.raises(ParameterError, match=match):
        Detector(net, **kwargs)


@pytest.mark.parametrize(
    "splits",
    [
        {"test": "test.npz"},
        ["test"],
        None,
        {"test": {"file": 3}},
        {"test": {"file": "test.npz", "windows": "10"}},
        {"test": {"file": "test.npz", "windows": True}},
        {"test": {"file": "test.npz", "sha256": ["a"]}},
    ],
)
def test_loading_a_split_of_a_damaged_manifest_is_a_dataset_error(
    splits: object, dataset: Path, tmp_path: Path
) -> None:
    # An AttributeError or TypeError came out of dataset.load (and `uavsnn evaluate`).
    manifest = json.loads((dataset / "manifest.json").read_text())
    manifest["splits"] = splits
    damaged = tmp_path / "damaged"
    damaged.mkdir()
    (damaged / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(DatasetError, match="split"):
        load(damaged, "test")


@pytest.mark.parametrize("version", [np.array([2, 2]), np.array("two"), np.array(2.0)])
def test_a_split_file_whose_format_version_is_no_integer_is_a_dataset_error(
    version: np.ndarray, dataset: Path, tmp_path: Path
) -> None:
    damaged = tmp_path / "damaged"
    damaged.mkdir()
    (damaged / "manifest.json").write_text((dataset / "manifest.json").read_text())
    with np.load(dataset / "test.npz") as z:
        arrays = {k: z[k] for k in z.files}
    np.savez(damaged / "test.npz", **{**arrays, "format_version": version})
    with pytest.raises(DatasetError, match="format_version must be one integer"):
        load(damaged, "test")


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("parameters", None, "no field 'parameters'"),
        ("splits", [], "'splits' must map each split's name"),
    ],
)
def test_dataset_info_of_a_damaged_manifest_is_one_line(
    field: str,
    value: object,
    match: str,
    dataset: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # A KeyError or AttributeError traceback ended `uavsnn dataset info`.
    manifest = json.loads((dataset / "manifest.json").read_text())
    if value is None:
        del manifest[field]
    else:
        manifest[field] = value
    damaged = tmp_path / "damaged"
    damaged.mkdir()
    (damaged / "manifest.json").write_text(json.dumps(manifest))
    for extra in ([], ["--json"]):
        _one_line_exit_2(capsys, ["dataset", "info", str(damaged), *extra], match)


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["evaluate", "m.npz", "data", "--track-score", "max"], "--track-score"),
        (["train", "data", "-o", "m.npz", "--tune", "t", "--no-identify"], "--tune"),
        (["bench", "--model", "m.npz", "--size", "640x480"], "--size"),
    ],
)
def test_an_option_that_would_change_nothing_is_refused(
    argv: list[str], match: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # Each was read and then ignored: --track-score without --tracks, --tune with
    # --no-identify, --size beside a model that brings its own.
    _one_line_exit_2(capsys, argv, match)


def test_demo_refuses_a_negative_seed_before_making_its_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "demo"
    _one_line_exit_2(capsys, ["demo", "--seed", "-1", "--out", str(out)], "--seed")
    assert not out.exists()


def test_detect_on_a_file_without_a_sensor_size_asks_for_one(
    model: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A CSV carries no geometry: faery's 1280x720 stood in, and the advice to --downsample
    # cropped it to the model's aspect, dropping every event of a 40x30 recording (exit 0).
    ev = _events(400)
    rec = tmp_path / "rec.csv"
    rows = [f"{int(e['t'])},{int(e['x'])},{int(e['y'])},{int(e['p'])}" for e in ev]
    rec.write_text("t,x,y,p\n" + "\n".join(rows) + "\n")
    for extra in ([], ["--downsample"]):
        _one_line_exit_2(
            capsys, ["detect", str(rec), "-m", str(model), *extra], "records no sensor size"
        )
    assert main(["detect", str(rec), "-m", str(model), "--sensor-size", "40x30"]) == 0
    assert "events=400" in capsys.readouterr().err


def test_train_output_that_cannot_be_written_is_refused_before_training(
    dataset: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch
) -> None:
    # The model was refused by network.save, after the training and the identification fit.
    def no_training(*args: object, **kwargs: object) -> None:
        raise AssertionError("trained before the output was checked")

    monkeypatch.setattr(uavsnn.cli.train, "train", no_training)
    argv = ["train", str(dataset), "--windows-per-layer", "4", "--quiet", "-o"]
    _one_line_exit_2(capsys, [*argv, str(tmp_path / "missing" / "m.npz")], "does not exist")
    _one_line_exit_2(capsys, [*argv, str(tmp_path)], "is a folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == []


@pytest.mark.parametrize("flag", ["--n-test", "--n-train"])
def test_dataset_build_refuses_absurd_window_counts_before_any_work(
    flag: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 2·10^9 test windows ran until killed.
    argv = ["dataset", "build", str(tmp_path / "d"), "--domain", "dvs", flag, "2000000000"]
    _one_line_exit_2(capsys, argv, "must be at most 1,000,000 windows")
    assert not (tmp_path / "d").exists()


def test_evaluate_checks_roc_and_seed_before_evaluating(
    model: Path, dataset: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch
) -> None:
    # --roc was checked after the whole evaluation (a name without .png raised OpenCV's
    # error, a missing folder failed on writing), and a negative --seed at the noise level
    # that used it (-1 was silently accepted).
    import uavsnn.cli.evaluate

    def no_work(*args: object, **kwargs: object) -> None:
        raise AssertionError("evaluated before the options were checked")

    monkeypatch.setattr(uavsnn.cli.evaluate, "evaluate", no_work)
    argv = ["evaluate", str(model), str(dataset)]
    _one_line_exit_2(capsys, [*argv, "--roc", str(tmp_path / "roc.txt")], "name it .png")
    _one_line_exit_2(capsys, [*argv, "--roc", str(tmp_path / "no" / "roc.png")], "does not exist")
    _one_line_exit_2(capsys, [*argv, "--roc", str(tmp_path / "roc.png")], "identification")
    _one_line_exit_2(capsys, [*argv, "--noise", "--seed", "-1"], "--seed must be >= 0")
    for shares, says in (
        ("0.01,x", "got 'x'"),
        ("0.01,0", "above 0 and at most 1, got 0"),
        ("1.5", "at most 1, got 1.5"),
        ("nan", "got nan"),
        ("0.01,0.01", "0.01 is given twice"),
    ):
        _one_line_exit_2(capsys, [*argv, "--noise", "--noise-shares", shares], says)
    _one_line_exit_2(capsys, [*argv, "--noise-shares", "table3"], "give --noise")
    assert list(tmp_path.iterdir()) == []


def test_a_recording_without_metadata_is_refused_where_it_is_built() -> None:
    # None used to be accepted, and filters.denoise then failed with a raw TypeError.
    from uavsnn.filters import denoise

    events = np.zeros(2, EVENT_DTYPE)
    events["t"] = [1, 2]
    with pytest.raises(ParameterError, match="metadata"):
        uavsnn.Recording(events, SIZE, None)  # type: ignore[arg-type]
    assert len(denoise(uavsnn.Recording(events, SIZE), 1000)) <= 2


def test_library_calls_that_make_a_folder_raise_the_packages_errors(tmp_path: Path) -> None:
    # dataset.build and report.figures raised the OSError of mkdir (a path under a file);
    # the command line checked first, a library caller met NotADirectoryError.
    from uavsnn.network import Network
    from uavsnn.report import figures

    (tmp_path / "afile").write_text("x")
    under = tmp_path / "afile" / "sub"
    source = SceneSource("dvs", (64, 48), 200.0, 0.3, sensor=(64, 48))
    with pytest.raises(uavsnn.DatasetError, match="cannot create the folder"):
        build(under, "dvs", n_test=4, n_train=0, seed=3, sensor=(64, 48), dvs=source)
    with pytest.raises(ParameterError, match="out_dir"):
        figures(under, Network({"width": 64, "height": 48}), None, None)
    assert not under.exists()
