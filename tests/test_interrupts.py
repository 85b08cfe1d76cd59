"""Copies and interruptions: a copy never shares the engine's state, and a call stopped part way
(Ctrl-C, an error that is not one of the package's) leaves nothing silently wrong: a stream
that cannot go on says so, files and datasets are the old ones or the whole new ones."""

from __future__ import annotations

import copy
import importlib
import json
import os
import pickle
import signal
import sys
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import SMALL_SENSOR, blob_events, small_config

import uavsnn.network as network_module
from uavsnn import EventError, ModelFileError, StreamError
from uavsnn.cli import main
from uavsnn.dataset import SceneSource, build, load
from uavsnn.dataset.format import LOCK, MANIFEST
from uavsnn.detector import Detector
from uavsnn.errors import DatasetError
from uavsnn.grouping import WindowGrouper
from uavsnn.network import Network
from uavsnn.signature import RotorSignature, RotorSpectrum
from uavsnn.sim import DvsEmulator, Pix2NvsSimulator

SIZE = SMALL_SENSOR
CONFIG = small_config()
WINDOW_US = 3_000
# Small recordings so that a build takes about a second.
DVS = SceneSource("dvs", (240, 180), 200.0, 0.3)
# The module (``uavsnn.dataset.build`` is also the name of its function ``build``).
dataset_build = importlib.import_module("uavsnn.dataset.build")


@pytest.fixture(scope="module")
def net() -> Network:
    return Network(CONFIG, seed=3)


@pytest.fixture(scope="module")
def events() -> np.ndarray:
    return blob_events(11, 1_500)


def chunks(events: np.ndarray, n: int = 6) -> list[np.ndarray]:
    return np.array_split(events, n)


def window_rows(reports: list[Any]) -> list[tuple[int, int, int, int]]:
    return [(w.window, w.t0, w.t1, w.spikes) for w in reports]


# -- 1. copies --------------------------------------------------------------------------------


def test_a_copy_of_a_network_is_independent(net: Network) -> None:
    # A shallow copy shared the engine's weights.
    original = net.copy()
    original._identification = ["a stand-in identification"]  # type: ignore[assignment]
    original.load_note = "a note"
    for how in (copy.copy, copy.deepcopy):
        twin = how(original)
        assert twin is not original and twin == original
        assert twin.identification == original.identification
        assert twin.load_note == "a note"
        # New weights drop the twin's identification (fitted on the old ones), not the
        # original's.
        with pytest.warns(UserWarning, match="identification"):
            twin.set_weights("conv2", np.zeros_like(twin.weights("conv2")))
        assert (original.weights("conv2") != 0).any()
        assert twin != original
        assert twin.identification is None and original.identification is not None
    # deepcopy copies the identification too; copy shares it, as Network.copy() does.
    assert copy.copy(original).identification is original.identification
    assert copy.deepcopy(original).identification is not original.identification


def test_a_network_pickles_whatever_else_is_imported(net: Network, tmp_path: Path) -> None:
    # It pickled only once uavsnn.distributed (imported by the dataset and evaluation modules)
    # had registered how: a process pool given a network failed or not by what the host had
    # imported. A fresh interpreter with only `import uavsnn`:
    import subprocess

    original = net.copy()
    original._identification = {"a": "stand-in"}  # type: ignore[assignment]
    original.load_note = "a note"
    path = tmp_path / "net.pickle"
    code = (
        "import pickle, sys, uavsnn; net = pickle.load(open(sys.argv[1], 'rb')); "
        "assert 'uavsnn.distributed' not in sys.modules; "
        "pickle.dump((net, pickle.loads(pickle.dumps(net))), open(sys.argv[1], 'wb'))"
    )
    for protocol in (2, pickle.HIGHEST_PROTOCOL):
        path.write_bytes(pickle.dumps(original, protocol=protocol))
        subprocess.run([sys.executable, "-c", code, str(path)], check=True, timeout=120)
        for back in pickle.loads(path.read_bytes()):
            assert back == original and back is not original
            assert back.identification == {"a": "stand-in"} and back.load_note == "a note"
    # A network pickled by an older uavsnn (its copyreg entry in uavsnn.distributed) loads.
    from uavsnn.distributed import _network_from_state

    class Older:
        def __reduce__(self) -> tuple[Any, ...]:
            weights = {layer: net.weights(layer) for layer in ("conv1", "conv2", "conv3")}
            return _network_from_state, (net.config, weights, None)

    assert pickle.loads(pickle.dumps(Older())) == net


@pytest.mark.parametrize("make", ["detector", "signature", "spectrum", "dvs", "pix2nvs"])
@pytest.mark.parametrize("how", [copy.copy, copy.deepcopy, pickle.dumps])
def test_engine_state_is_not_copied_but_refused(
    make: str, how: Any, net: Network, events: np.ndarray
) -> None:
    makers = {
        "detector": lambda: Detector(net, window_us=WINDOW_US, rotor=False),
        "signature": lambda: RotorSignature((0, 0, *SIZE)),
        "spectrum": lambda: RotorSpectrum((0, 0, *SIZE)),
        "dvs": lambda: DvsEmulator(SIZE),
        "pix2nvs": lambda: Pix2NvsSimulator(SIZE),
    }
    obj, fresh = makers[make](), makers[make]()
    name = type(obj).__name__
    with pytest.raises(TypeError, match=f"uavsnn.{name} cannot be copied or pickled") as info:
        how(obj)
    assert f"{name}(...)" in str(info.value)
    # Nothing was shared nor changed: the original goes on by itself.
    if make in ("dvs", "pix2nvs"):
        frames = np.zeros((2, SIZE[1], SIZE[0]), dtype=np.uint8)
        obj.process(frames, np.array([0, 1000], dtype=np.uint64))
        assert obj.frames_seen == 2 and fresh.frames_seen == 0
    elif make == "detector":
        obj.push(events[:100])
        assert obj.events_seen == 100
    else:
        obj.update(events[:100])
        fresh.update(events[:100])
        assert obj.stats == fresh.stats and obj.stats["events"] > 0


# -- 2. a detector's call stopped part way ----------------------------------------------------


class _TakesThenInterrupts:
    """The engine's detector, whose ``push`` takes the chunk and is then stopped by Ctrl-C."""

    def __init__(self, inner: Any) -> None:
        self._real = inner

    def push(self, raw: bytes) -> Any:
        self._real.push(raw)
        raise KeyboardInterrupt

    def __getattr__(self, name: str) -> Any:
        return getattr(self._real, name)


def test_a_push_interrupted_after_the_engine_took_the_chunk_stops_the_stream(
    net: Network, events: np.ndarray, monkeypatch: pytest.MonkeyPatch
) -> None:
    parts = chunks(events)
    det = Detector(net, window_us=WINDOW_US, rotor=False)
    det.push(parts[0])
    real = det._inner
    monkeypatch.setattr(det, "_inner", _TakesThenInterrupts(real))
    with pytest.raises(KeyboardInterrupt):
        det.push(parts[1])
    monkeypatch.setattr(det, "_inner", real)
    assert det.interrupted
    # Neither the chunk again (it was taken: "time goes backwards"), nor the next one (its
    # detections would follow a gap), nor the end of the stream.
    for call, args in ((det.push, (parts[1],)), (det.push, (parts[2],)), (det.flush, ())):
        with pytest.raises(StreamError, match=r"push\(\) was interrupted part way.*reset\(\)"):
            call(*args)
    with pytest.raises(StreamError, match="interrupted part way"):
        det.push_windows(parts[2])
    # reset() starts a new stream, which is the whole stream's as a new detector finds it.
    det.reset()
    assert not det.interrupted
    fresh = Detector(net, window_us=WINDOW_US, rotor=False)
    got = np.concatenate([*(det.push(p) for p in parts), det.flush()])
    want = np.concatenate([*(fresh.push(p) for p in parts), fresh.flush()])
    assert len(want) > 0
    np.testing.assert_array_equal(got, want)


def test_push_windows_interrupted_while_grouping_stops_the_stream(
    net: Network, events: np.ndarray, monkeypatch: pytest.MonkeyPatch
) -> None:
    parts = chunks(events)
    det = Detector(net, window_us=WINDOW_US, rotor=False)
    det.push_windows(parts[0])
    real_add = WindowGrouper.add

    def interrupted(self: WindowGrouper, *args: Any) -> Any:
        raise KeyboardInterrupt

    monkeypatch.setattr(WindowGrouper, "add", interrupted)
    with pytest.raises(KeyboardInterrupt):
        det.push_windows(parts[1])
    monkeypatch.setattr(WindowGrouper, "add", real_add)
    assert det.interrupted
    for call, args in ((det.push_windows, (parts[2],)), (det.flush_windows, ())):
        with pytest.raises(StreamError, match=r"push_windows\(\) was interrupted part way"):
            call(*args)
    det.reset()
    fresh = Detector(net, window_us=WINDOW_US, rotor=False)
    got = [w for p in parts for w in det.push_windows(p)] + det.flush_windows()
    want = [w for p in parts for w in fresh.push_windows(p)] + fresh.flush_windows()
    assert window_rows(got) == window_rows(want)


def test_a_flush_interrupted_after_the_engine_stops_the_stream(
    net: Network, events: np.ndarray, monkeypatch: pytest.MonkeyPatch
) -> None:
    det = Detector(net, window_us=WINDOW_US, rotor=False)
    det.push(events)
    real = det._flush

    def flush_then_interrupt() -> Any:
        real()
        raise KeyboardInterrupt

    monkeypatch.setattr(det, "_flush", flush_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        det.flush()
    monkeypatch.undo()
    with pytest.raises(StreamError, match=r"flush\(\) was interrupted part way"):
        det.flush()


def test_a_refused_chunk_leaves_the_detector_usable(net: Network, events: np.ndarray) -> None:
    """The package's own errors are refusals that change nothing: not an interruption."""
    parts = chunks(events)
    for mode in ("push", "push_windows"):
        det = Detector(net, window_us=WINDOW_US, rotor=False)
        fresh = Detector(net, window_us=WINDOW_US, rotor=False)
        push, flush = getattr(det, mode), getattr(det, mode.replace("push", "flush"))
        got, want = [], []
        for i, part in enumerate(parts):
            got.append(push(part))
            want.append(getattr(fresh, mode)(part))
            if i == 2:
                with pytest.raises(StreamError, match="backwards"):
                    push(parts[0])  # earlier than the stream
                with pytest.raises(EventError):
                    push(part[["t", "x", "y"]])  # not the event dtype
                assert not det.interrupted
        got.append(flush())
        want.append(getattr(fresh, mode.replace("push", "flush"))())
        if mode == "push":
            np.testing.assert_array_equal(np.concatenate(got), np.concatenate(want))
        else:
            flat = [[w for reports in run for w in reports] for run in (got, want)]
            assert window_rows(flat[0]) == window_rows(flat[1])


# -- 3. `uavsnn detect` stopped by Ctrl-C -------------------------------------------------------


class _Stdin:
    """Standard input whose reads give ``pieces`` in turn, then Ctrl-C (or the end, with
    ``interrupt=False``)."""

    def __init__(self, pieces: list[bytes], interrupt: bool) -> None:
        self.buffer = self
        self._pieces = list(pieces)
        self._interrupt = interrupt

    def read1(self, _size: int) -> bytes:
        if self._pieces:
            return self._pieces.pop(0)
        if self._interrupt:
            raise KeyboardInterrupt
        return b""


@pytest.fixture(scope="module")
def model(net: Network, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("model") / "model.npz"
    net.save(path)
    return path


def _detect(
    model: Path,
    pieces: list[bytes],
    interrupt: bool,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> tuple[int, list[str], str]:
    monkeypatch.setattr(sys, "stdin", _Stdin(pieces, interrupt))
    argv = ["detect", "-", "-m", str(model), "--window-ms", "3", "--json"]
    code = main([*argv, "--summary-every", "0"])
    out, err = capsys.readouterr()
    return code, out.splitlines(), err


def test_detect_stopped_by_ctrl_c_reports_what_it_found_and_exits_130(
    model: Path,
    events: np.ndarray,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    pieces = [part.tobytes() for part in chunks(events[:1_000], 4)]
    code, ended, _ = _detect(model, pieces, False, monkeypatch, capsys)
    assert code == 0
    code, stopped, err = _detect(model, pieces, True, monkeypatch, capsys)
    assert code == 130
    assert err.splitlines()[-1] == "uavsnn detect: interrupted"
    # Every window of the events read, the ones still open flushed, as if the stream had ended.
    assert len(ended) > 1
    assert [json.loads(line) for line in stopped] == [json.loads(line) for line in ended]


def test_detect_stopped_inside_the_detector_exits_130_without_a_flush(
    model: Path,
    events: np.ndarray,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    real = Detector._push
    calls = []
    pieces = [part.tobytes() for part in chunks(events, 6)]
    code, whole, _ = _detect(model, pieces, False, monkeypatch, capsys)
    assert code == 0

    def taken_then_interrupted(self: Detector, chunk: np.ndarray) -> np.ndarray:
        found = real(self, chunk)
        calls.append(int(chunk["t"][-1]))
        if len(calls) == 3:
            raise KeyboardInterrupt
        return found

    monkeypatch.setattr(Detector, "_push", taken_then_interrupted)
    code, printed, err = _detect(model, pieces, False, monkeypatch, capsys)
    assert code == 130
    lines = err.splitlines()
    assert lines[-1] == "uavsnn detect: interrupted"
    assert not any("Traceback" in line or "StreamError" in line for line in lines)
    # The message counts the windows lost: those holding an event the detector took, less
    # those printed.
    t, last = events["t"], calls[-1]
    opened = sum(
        bool(np.any((t >= w["t0"]) & (t < w["t1"]) & (t <= last))) for w in map(json.loads, whole)
    )
    assert 0 < len(printed) < opened
    stopped = (
        "Ctrl-C stopped the detector inside a chunk: the windows still open "
        f"({opened - len(printed)} of {opened} opened) are not reported"
    )
    assert any(stopped in line for line in lines), lines


class _SignalledOut:
    """Standard output that sends this process ``signum`` while it writes its ``at``-th line
    (between the line's text and its newline), as a Ctrl-C or a service manager's SIGTERM may
    land while detect prints."""

    def __init__(self, signum: int, at: int) -> None:
        self.signum, self.at, self.lines, self.text = signum, at, 0, []

    def write(self, text: str) -> int:
        self.text.append(text)
        if text == "\n":
            self.lines += 1
            if self.lines == self.at:
                os.kill(os.getpid(), self.signum)
        return len(text)

    def flush(self) -> None:
        pass


@pytest.fixture
def ctrl_c() -> Iterator[None]:
    """Ctrl-C's own handler, whatever this process inherited: a job started in the background
    by a non-interactive shell (a CI runner) ignores SIGINT, and Python then installs none."""
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


@pytest.mark.parametrize(("signum", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
@pytest.mark.usefixtures("ctrl_c")
def test_detect_stopped_while_it_prints_writes_every_line_whole(
    model: Path,
    events: np.ndarray,
    signum: int,
    code: int,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # A stop raised inside print left half a line (the flush's line glued to it) and dropped
    # the rest of the windows push_windows had returned, without a word.
    pieces = [events[:1_000].tobytes()]  # one chunk: its windows are printed in one go
    done, ended, _ = _detect(model, pieces, False, monkeypatch, capsys)
    assert done == 0 and len(ended) > 4
    out = _SignalledOut(signum, at=2)
    monkeypatch.setattr(sys, "stdout", out)
    got, _, err = _detect(model, pieces, False, monkeypatch, capsys)
    assert got == code
    assert err.splitlines()[-1].startswith("uavsnn detect: interrupted")
    lines = "".join(out.text).splitlines()
    # Every line is one JSON object, and every window of the chunk is there.
    assert [json.loads(line) for line in lines] == [json.loads(line) for line in ended]


@pytest.mark.usefixtures("ctrl_c")
def test_a_stop_held_inside_another_hold_waits_for_the_outer_block() -> None:
    from uavsnn.cli import held_stops

    done = []
    with pytest.raises(KeyboardInterrupt):
        with held_stops():
            with held_stops():
                os.kill(os.getpid(), signal.SIGINT)
                done.append("inner")
            done.append("outer")
    assert done == ["inner", "outer"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


# -- 4. a model file with its identification: one atomic write --------------------------------


class _Identification:
    def to_arrays(self) -> dict[str, np.ndarray]:
        return {"identify.coef": np.arange(3.0)}


@pytest.mark.parametrize("failure", [KeyboardInterrupt, OSError(28, "No space left on device")])
def test_a_save_stopped_before_the_identification_leaves_the_old_file(
    failure: BaseException | type[BaseException],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    path = tmp_path / "model.npz"
    Network(seed=1).save(path)
    before = path.read_bytes()
    new = Network(seed=2)
    new._identification = _Identification()  # type: ignore[assignment]

    def stopped(_path: str, _arrays: object, **_source: object) -> None:
        raise failure

    monkeypatch.setattr(network_module, "_add_arrays", stopped)
    expected = KeyboardInterrupt if failure is KeyboardInterrupt else ModelFileError
    with pytest.raises(expected):
        new.save(path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["model.npz"]  # no temporary file


def test_a_save_with_identification_writes_both_parts(tmp_path: Path) -> None:
    path = tmp_path / "model.npz"
    Network(seed=1).save(path)
    new = Network(seed=2)
    new._identification = _Identification()  # type: ignore[assignment]
    new.save(path)
    assert [p.name for p in tmp_path.iterdir()] == ["model.npz"]
    with zipfile.ZipFile(path) as z:
        assert "identify.coef.npy" in z.namelist()
    with np.load(path) as arrays:
        np.testing.assert_array_equal(arrays["identify.coef"], np.arange(3.0))
    # The engine reads its part of the file: the new network.
    assert Network._wrap(network_module._core.NetworkCore.load(str(path))) == new
    # A folder in the way is a typed error, naming the file asked for.
    (tmp_path / "dir.npz").mkdir()
    with pytest.raises(ModelFileError, match=r"dir\.npz"):
        new.save(tmp_path / "dir.npz")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir.npz", "model.npz"]


# -- 5. a dataset build stopped part way ------------------------------------------------------


def _small_build(root: Path, **kw: Any) -> None:
    build(root, "dvs", **({"dvs": DVS, "n_test": 4, "n_train": 4, "seed": 3} | kw))


def _files(root: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(root.iterdir())}


def _stop_at_split(monkeypatch: pytest.MonkeyPatch, failure: BaseException) -> None:
    """The first split file is written, then ``failure`` is raised (Ctrl-C between files)."""
    real = dataset_build.save_split

    def save_split(path: Path, data: Any) -> Path:
        real(path, data)
        raise failure

    monkeypatch.setattr(dataset_build, "save_split", save_split)


@pytest.mark.parametrize("failure", [KeyboardInterrupt(), DatasetError("a failure")])
def test_an_overwrite_stopped_part_way_leaves_the_old_dataset(
    failure: BaseException, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    root = tmp_path / "set"
    _small_build(root)
    old = _files(root)
    _stop_at_split(monkeypatch, failure)
    with pytest.raises(type(failure)):
        _small_build(root, seed=4, n_train=0, overwrite=True)
    assert _files(root) == old
    assert len(load(root, "test")) == 4 and len(load(root, "train")) == 4
    assert [p.name for p in tmp_path.iterdir()] == ["set"]  # no temporary folder


def test_a_new_build_stopped_between_split_files_leaves_no_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    root = tmp_path / "a" / "set"
    _stop_at_split(monkeypatch, KeyboardInterrupt())
    with pytest.raises(KeyboardInterrupt):
        _small_build(root)
    assert list(tmp_path.iterdir()) == []  # neither the folder nor the ones made above it
    monkeypatch.undo()
    _small_build(root)  # nothing half-written in the way
    assert sorted(_files(root)) == [MANIFEST, "test.npz", "train.npz"]


def test_an_overwrite_replaces_the_dataset_once_whole(tmp_path: Path) -> None:
    root = tmp_path / "set"
    _small_build(root)
    _small_build(root, seed=4, n_train=0, overwrite=True)
    # The old train split is gone with the old dataset; no lock nor temporary folder is left.
    assert sorted(_files(root)) == [MANIFEST, "test.npz"]
    assert json.loads((root / MANIFEST).read_text())["seed"] == 4
    assert len(load(root, "test")) == 4
    assert [p.name for p in tmp_path.iterdir()] == ["set"]
    assert not (root / LOCK).exists()


def test_a_failed_rename_into_place_puts_the_old_dataset_back(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    root = tmp_path / "set"
    _small_build(root)
    old = _files(root)
    real = os.replace
    failed = []

    def replace(src: Any, dst: Any) -> None:
        # The last rename of the swap, the new manifest into the dataset's folder, fails once.
        if Path(src).name == MANIFEST and Path(dst) == root / MANIFEST and not failed:
            failed.append(src)
            raise OSError(5, "Input/output error")
        real(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(OSError, match="Input/output"):
        _small_build(root, seed=4, overwrite=True)
    monkeypatch.undo()
    assert failed and Path(failed[0]).parent != root
    assert _files(root) == old
    assert len(load(root, "test")) == 4
    assert [p.name for p in tmp_path.iterdir()] == ["set"]


def test_the_command_line_overwrite_stopped_by_ctrl_c_exits_130_and_keeps_the_old(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    root = tmp_path / "set"
    _small_build(root)
    old = _files(root)
    _stop_at_split(monkeypatch, KeyboardInterrupt())
    argv = ["dataset", "build", str(root), "--domain", "dvs", "--n-test", "4", "--n-train", "4"]
    assert main([*argv, "--quiet", "--overwrite"]) == 130
    assert capsys.readouterr().err.splitlines()[-1] == "uavsnn dataset build: interrupted"
    assert _files(root) == old
    assert [p.name for p in tmp_path.iterdir()] == ["set"]
