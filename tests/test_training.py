"""Layer-wise training: windows per layer, snapshots, checkpoints that survive an interruption
and resume to the same weights, config overrides, and that training learns something."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import one_line_exit_2, symlink

import uavsnn
import uavsnn.cli.train
from uavsnn.cli import main
from uavsnn.dataset import SceneSource, build, load
from uavsnn.errors import DatasetError, ModelFileError, ParameterError
from uavsnn.training import STATE_FILE, ProgressFn, apply_overrides, parse_override, train

CONFIG = {"conv2": {"threshold": 15.0}}


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("train") / "set"
    build(
        root, "dvs", n_test=20, n_train=40, seed=7, dvs=SceneSource("dvs", (240, 180), 200.0, 0.3)
    )
    return root


@pytest.fixture(scope="module")
def windows(dataset: Path) -> uavsnn.windows.Windows:
    return load(dataset, "train").windows


def _weights(net: uavsnn.Network) -> dict[str, np.ndarray]:
    return {layer: net.weights(layer) for layer in ("conv1", "conv2", "conv3")}


def test_each_layer_sees_the_windows_asked_for(windows: uavsnn.windows.Windows) -> None:
    net = uavsnn.Network(CONFIG, seed=1)
    conv1 = net.weights("conv1")
    result = train(net, windows, windows_per_layer=100, snapshots=4)
    assert list(result.layers) == ["conv2", "conv3"]
    for layer, r in result.layers.items():
        # Progress reports every 100 // 4 = 25 windows: training stops at the one at 100.
        assert r.report.windows_seen == 100
        seen = [s for s, _ in r.snapshots]
        assert seen[0] == 0 and seen[-1] == r.report.windows_seen and seen == sorted(seen)
        np.testing.assert_array_equal(r.snapshots[-1][1], net.weights(layer))
    np.testing.assert_array_equal(net.weights("conv1"), conv1)  # Gabor stays fixed


def test_training_stops_at_the_first_report_at_or_past_the_count(
    windows: uavsnn.windows.Windows,
) -> None:
    # 40 windows: 77 asks for two passes (80 windows) with reports every 64 and at the end;
    # 130 with 6 snapshots, reports every 21 windows (126 < 130 <= 147).
    for asked, snapshots, seen in [(77, 0, 80), (130, 6, 147), (5, 2, 6)]:
        net = uavsnn.Network(CONFIG, seed=1)
        result = train(net, windows, layers=["conv2"], windows_per_layer=asked, snapshots=snapshots)
        assert result.layers["conv2"].report.windows_seen == seen, asked


def test_training_learns_weights_settle_towards_0_or_1(windows: uavsnn.windows.Windows) -> None:
    net = uavsnn.Network(CONFIG, seed=1)
    before = _weights(net)
    result = train(net, windows, windows_per_layer=8000, snapshots=0)
    for layer in ("conv2", "conv3"):
        c = result.layers[layer].report.convergence
        assert c[-1] < 0.5 * c[0], (layer, c[0], c[-1])
        assert not np.array_equal(before[layer], net.weights(layer))


def test_layers_must_be_known_and_in_order(windows: uavsnn.windows.Windows) -> None:
    net = uavsnn.Network(CONFIG, seed=1)
    with pytest.raises(ParameterError, match="cannot train 'pool1'"):
        train(net, windows, layers=["pool1"])
    with pytest.raises(ParameterError, match="in the network's order"):
        train(net, windows, layers=["conv3", "conv2"])
    with pytest.raises(ParameterError, match="distinct"):
        train(net, windows, layers=["conv2", "conv2"])
    with pytest.raises(ParameterError, match="windows_per_layer must be an integer >= 1"):
        train(net, windows, windows_per_layer=0)
    with pytest.raises(DatasetError, match="no training windows"):
        train(net, windows.select([]))


class _Stop(Exception):
    """A run stopped part way, as Ctrl-C stops one."""


def _stop_in(layer: str, *, after: int) -> ProgressFn:
    """A progress function that stops the run in ``layer`` once it has seen ``after`` windows."""

    def stop(name: str, done: int, total: int, convergence: float) -> None:
        if name == layer and done > after:
            raise _Stop

    return stop


def test_checkpoint_survives_an_interruption_and_resume_gives_the_same_model(
    windows: uavsnn.windows.Windows, tmp_path: Path
) -> None:
    whole = uavsnn.Network(CONFIG, seed=3)
    train(whole, windows, windows_per_layer=200, seed=4, snapshots=0)
    ckpt = tmp_path / "ckpt"
    net = uavsnn.Network(CONFIG, seed=3)
    with pytest.raises(_Stop):
        train(net, windows, windows_per_layer=200, seed=4, checkpoint_dir=ckpt,
              progress=_stop_in("conv3", after=64))  # fmt: skip
    state = json.loads((ckpt / STATE_FILE).read_text())
    assert state["done"] == ["conv2"]
    assert sorted(p.name for p in ckpt.iterdir()) == ["after-conv2.npz", STATE_FILE]
    saved = uavsnn.Network.load(ckpt / "after-conv2.npz")
    np.testing.assert_array_equal(saved.weights("conv2"), whole.weights("conv2"))

    fresh = uavsnn.Network(CONFIG, seed=3)
    result = train(fresh, windows, windows_per_layer=200, seed=4, checkpoint_dir=ckpt, resume=True)
    assert result.resumed == ("conv2",) and list(result.layers) == ["conv3"]
    assert fresh == whole
    assert json.loads((ckpt / STATE_FILE).read_text())["done"] == ["conv2", "conv3"]


def test_resume_before_any_checkpoint_trains_every_layer(
    windows: uavsnn.windows.Windows, tmp_path: Path
) -> None:
    # A run stopped in its first layer has written nothing: resuming it raised KeyError 'done'.
    whole = uavsnn.Network(CONFIG, seed=3)
    train(whole, windows, windows_per_layer=100, seed=4, snapshots=0)
    ckpt = tmp_path / "ckpt"
    with pytest.raises(_Stop):
        train(uavsnn.Network(CONFIG, seed=3), windows, windows_per_layer=100, seed=4,
              snapshots=0, checkpoint_dir=ckpt, progress=_stop_in("conv2", after=32))  # fmt: skip
    assert not (ckpt / STATE_FILE).exists()
    for folder in (ckpt, tmp_path / "never-made"):
        net = uavsnn.Network(CONFIG, seed=3)
        result = train(net, windows, windows_per_layer=100, seed=4, snapshots=0,
                       checkpoint_dir=folder, resume=True)  # fmt: skip
        assert result.resumed == () and list(result.layers) == ["conv2", "conv3"]
        assert net == whole
        assert json.loads((folder / STATE_FILE).read_text())["done"] == ["conv2", "conv3"]


def test_resume_refuses_a_checkpoint_of_other_layers(
    windows: uavsnn.windows.Windows, tmp_path: Path
) -> None:
    net = uavsnn.Network(CONFIG, seed=3)
    train(net, windows, layers=["conv2"], windows_per_layer=10, checkpoint_dir=tmp_path)
    with pytest.raises(ParameterError, match="not a start of the layers"):
        train(net, windows, layers=["conv3"], checkpoint_dir=tmp_path, resume=True)


def _checkpoint(windows: uavsnn.windows.Windows, ckpt: Path, **kwargs: object) -> dict:
    """A checkpoint of conv2 in ``ckpt``; its state."""
    train(uavsnn.Network(CONFIG, seed=3), windows, layers=["conv2"], windows_per_layer=10,
          checkpoint_dir=ckpt, **kwargs)  # fmt: skip
    state: dict = json.loads((ckpt / STATE_FILE).read_text())
    return state


@pytest.mark.parametrize(
    "old", ['{"done": ', '{"done": ["conv2"], "model": "after-conv2.npz"}', "[]"]
)
def test_a_run_that_does_not_resume_starts_a_fresh_state(
    windows: uavsnn.windows.Windows, tmp_path: Path, old: str
) -> None:
    # The old state was merged into the new one after conv2 had trained: a JSONDecodeError,
    # KeyError or TypeError lost the run.
    (tmp_path / STATE_FILE).write_text(old)
    net = uavsnn.Network(CONFIG, seed=3)
    result = train(net, windows, windows_per_layer=10, checkpoint_dir=tmp_path)
    assert list(result.layers) == ["conv2", "conv3"]
    state = json.loads((tmp_path / STATE_FILE).read_text())
    assert state["done"] == ["conv2", "conv3"] and state["model"] == "after-conv3.npz"
    assert sorted(state["layers"]) == ["conv2", "conv3"]


def test_a_resume_rebuilds_damaged_layer_summaries(
    windows: uavsnn.windows.Windows, tmp_path: Path
) -> None:
    # "layers": [] failed with a TypeError after conv3 had trained.
    state = _checkpoint(windows, tmp_path)
    (tmp_path / STATE_FILE).write_text(json.dumps(state | {"layers": []}))
    net = uavsnn.Network(CONFIG, seed=3)
    result = train(net, windows, windows_per_layer=10, checkpoint_dir=tmp_path, resume=True)
    assert result.resumed == ("conv2",) and list(result.layers) == ["conv3"]
    state = json.loads((tmp_path / STATE_FILE).read_text())
    assert state["done"] == ["conv2", "conv3"] and list(state["layers"]) == ["conv3"]


@pytest.mark.parametrize(
    ("change", "error", "match"),
    [
        ({"model": "../outside.npz"}, ModelFileError, "'model' must be 'after-conv2.npz'"),
        ({"model": "OUTSIDE"}, ModelFileError, "'model' must be 'after-conv2.npz'"),
        ({"done": []}, ModelFileError, "'done' must be a non-empty list"),
        ({"done": "conv2"}, ModelFileError, "'done' must be a non-empty list"),
        ({"done": ["conv9"]}, ModelFileError, "'conv9' is not a layer"),
        ({"done": ["conv3", "conv2"]}, ModelFileError, "not in training order"),
        ({"fingerprint": {}}, ParameterError, "no complete fingerprint"),
        ({"fingerprint": "x"}, ParameterError, "no complete fingerprint"),
        ({"fingerprint": None}, ParameterError, "no complete fingerprint"),
    ],
)
def test_resume_refuses_a_damaged_state(
    windows: uavsnn.windows.Windows,
    tmp_path: Path,
    change: dict,
    error: type[Exception],
    match: str,
) -> None:
    # Each was taken as it was: a model from outside the folder was loaded, an empty
    # fingerprint skipped every check, "done": [] loaded the model into a run that retrained
    # everything, and "done": "conv2" finished c, o, n, v, 2.
    ckpt = tmp_path / "ckpt"
    state = _checkpoint(windows, ckpt)
    outside = tmp_path / "outside.npz"
    shutil.copy(ckpt / "after-conv2.npz", outside)
    if change.get("model") == "OUTSIDE":
        change = {"model": str(outside)}
    (ckpt / STATE_FILE).write_text(json.dumps(state | change))
    net = uavsnn.Network(CONFIG, seed=3)
    with pytest.raises(error, match=match) as info:
        train(net, windows, windows_per_layer=10, checkpoint_dir=ckpt, resume=True)
    assert "without resume" in str(info.value)
    assert net == uavsnn.Network(CONFIG, seed=3)  # nothing copied in


def test_resume_refuses_another_reporting_interval(
    windows: uavsnn.windows.Windows, tmp_path: Path
) -> None:
    # The reports (every windows_per_layer // snapshots windows) are where training stops:
    # with snapshots=6 conv2 saw 112 windows of 120, with 0 an uninterrupted run sees 120.
    ckpt = tmp_path / "ckpt"
    net = uavsnn.Network(CONFIG, seed=3)
    train(net, windows, layers=["conv2"], windows_per_layer=120, snapshots=6, checkpoint_dir=ckpt)
    with pytest.raises(ParameterError, match="the reporting interval"):
        train(uavsnn.Network(CONFIG, seed=3), windows, windows_per_layer=120, snapshots=0,
              checkpoint_dir=ckpt, resume=True)  # fmt: skip
    # snapshots=7 reports every 120 // 7 = 17 windows: another interval too; 6 resumes.
    with pytest.raises(ParameterError, match="the reporting interval"):
        train(uavsnn.Network(CONFIG, seed=3), windows, windows_per_layer=120, snapshots=7,
              checkpoint_dir=ckpt, resume=True)  # fmt: skip
    result = train(uavsnn.Network(CONFIG, seed=3), windows, windows_per_layer=120, snapshots=6,
                   checkpoint_dir=ckpt, resume=True)  # fmt: skip
    assert result.resumed == ("conv2",)


def test_a_checkpoint_folder_that_cannot_be_one_is_refused_before_training(
    windows: uavsnn.windows.Windows,
    dataset: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # FileExistsError, NotADirectoryError and IsADirectoryError reached the caller.
    afile = tmp_path / "afile"
    afile.write_text("x")
    trained: list[str] = []

    def progress(layer: str, *_args: object) -> None:
        trained.append(layer)

    def run(ckpt: Path, resume: bool = False) -> None:
        train(uavsnn.Network(CONFIG, seed=3), windows, windows_per_layer=10,
              checkpoint_dir=ckpt, resume=resume, progress=progress)  # fmt: skip

    with pytest.raises(ParameterError, match="afile: exists and is not a folder"):
        run(afile)
    with pytest.raises(ParameterError, match="afile/sub: cannot create the folder"):
        run(afile / "sub")
    (tmp_path / "ckpt" / STATE_FILE).mkdir(parents=True)
    for resume in (True, False):
        with pytest.raises(ParameterError, match=f"{STATE_FILE}: is a folder"):
            run(tmp_path / "ckpt", resume)
    assert trained == []
    out = tmp_path / "m.npz"
    argv = ["train", str(dataset), "-o", str(out), "--windows-per-layer", "10", "--no-identify",
            "--quiet", "--checkpoint-dir", str(afile)]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--checkpoint-dir {afile}: exists and is not a folder" in err
    assert not out.exists()


def test_a_refused_train_leaves_no_checkpoint_folder(
    windows: uavsnn.windows.Windows,
    dataset: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # --checkpoint-dir was made before the later checks, which left it behind, empty (its
    # parent must exist, as -o's must).
    out, ckpt = tmp_path / "m.npz", tmp_path / "ckpt"
    base = ["train", str(dataset), "-o", str(out), "--windows-per-layer", "10", "--quiet",
            "--checkpoint-dir", str(ckpt)]  # fmt: skip
    for extra, match in [
        (["--no-identify", "--set", "width=120"], "120x180"),  # refused as training starts
        (["--no-identify", "--layers", "conv3,conv2"], "layers must be distinct"),
        (["--no-identify", "--split", "nothing"], "no split 'nothing'"),
    ]:
        one_line_exit_2(capsys, [*base, *extra], match)
        assert list(tmp_path.iterdir()) == [], extra

    def unreachable(address: str | None, **_kwargs: object) -> object:
        raise ParameterError(f"cannot reach a Ray cluster at {address}")

    with monkeypatch.context() as patch:
        patch.setattr(uavsnn.cli.train, "runner_for", unreachable)
        ray = ["--track-minutes", "0.1", "--ray", "127.0.0.1:9"]
        one_line_exit_2(capsys, [*base, *ray], "cannot reach a Ray cluster")
    assert list(tmp_path.iterdir()) == []

    # train() makes the folder with the first checkpoint: not for a run stopped before it.
    class Stop(Exception):
        pass

    def interrupt(layer: str, *_args: object) -> None:
        raise Stop

    with pytest.raises(Stop):
        train(uavsnn.Network(CONFIG, seed=3), windows, windows_per_layer=10, checkpoint_dir=ckpt,
              progress=interrupt)  # fmt: skip
    assert list(tmp_path.iterdir()) == []
    assert main([*base, "--no-identify"]) == 0
    written = sorted(p.name for p in ckpt.iterdir())
    assert written == ["after-conv2.npz", "after-conv3.npz", STATE_FILE]


def test_a_bad_checkpoint_folder_is_refused_before_the_data_is_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def no_reading(*_args: object, **_kwargs: object) -> object:
        raise AssertionError("read the dataset before checking --checkpoint-dir")

    monkeypatch.setattr(uavsnn.cli.train, "load", no_reading)
    afile = tmp_path / "afile"
    afile.write_text("x")
    symlink(tmp_path / "link", tmp_path / "nowhere")
    argv = ["train", str(tmp_path / "no-dataset"), "-o", str(tmp_path / "m.npz"), "--quiet",
            "--checkpoint-dir"]  # fmt: skip
    for ckpt, match in [
        (afile, "exists and is not a folder"),
        (afile / "sub", f"{afile} is not a folder"),
        (tmp_path / "link", "a link to nothing"),
    ]:
        line = one_line_exit_2(capsys, [*argv, str(ckpt)], match)
        assert f"--checkpoint-dir {ckpt}: " in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "link"]


def test_train_connects_to_ray_before_any_training(
    dataset: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # The runner was resolved after STDP and identification: an unreachable address lost both.
    def unreachable(address: str | None, **_kwargs: object) -> object:
        raise ParameterError(f"cannot reach a Ray cluster at {address}")

    def no_training(*_args: object, **_kwargs: object) -> object:
        raise AssertionError("trained before connecting to Ray")

    monkeypatch.setattr(uavsnn.cli.train, "runner_for", unreachable)
    monkeypatch.setattr(uavsnn.cli.train, "train", no_training)
    monkeypatch.setattr(uavsnn.identify, "fit_network", no_training)
    out = tmp_path / "m.npz"
    base = ["train", str(dataset), "-o", str(out), "--quiet", "--track-minutes", "0.1"]
    for extra in (["--ray", "127.0.0.1:9"], ["--identify-only", str(out), "--ray", "127.0.0.1:9"]):
        if "--identify-only" in extra:
            uavsnn.Network(CONFIG, seed=3).save(out)
        assert main(base + extra) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "cannot reach a Ray cluster at 127.0.0.1:9" in err
    # --ray where nothing runs on it is refused, as other options that change nothing are.
    out.unlink()
    assert main(["train", str(dataset), "-o", str(out), "--ray"]) == 2
    assert "give --track-minutes" in capsys.readouterr().err
    assert not out.exists()


def test_overrides() -> None:
    assert parse_override("conv2.threshold=15") == (["conv2", "threshold"], 15)
    assert parse_override("pent.mode=static") == (["pent", "mode"], "static")
    # Spaces around a plain string are not part of it; a JSON string keeps what it quotes.
    assert parse_override(" pent.mode = static ") == (["pent", "mode"], "static")
    assert parse_override('name=" a b "') == (["name"], " a b ")
    config = apply_overrides(
        uavsnn.network.default_config(), ["conv2.threshold=15", "seedless.x=1"]
    )
    assert config["conv2"]["threshold"] == 15 and config["seedless"] == {"x": 1}
    assert uavsnn.network.default_config()["conv2"]["threshold"] == 45.0
    with pytest.raises(ParameterError, match="KEY=VALUE"):
        parse_override("conv2.threshold")
    with pytest.raises(ParameterError, match="not a section"):
        apply_overrides({"width": 240}, ["width.x=1"])
    with pytest.raises(ParameterError):
        uavsnn.Network(apply_overrides(uavsnn.network.default_config(), ["conv2.thresold=1"]))
