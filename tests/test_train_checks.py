"""What `uavsnn train` checks and says that a new user's walk found missing: a tuning set of the
training recordings, another sensor size, --epochs beside --windows-per-layer, a resume with
nothing to resume, a checkpoint folder in a folder that does not exist, resume errors that named
settings nobody changed, operating points that could not be set or were set on too little, and
a model file not named .npz."""

from __future__ import annotations

import json
import shutil
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from conftest import one_line_exit_2, symlink

import uavsnn.cli.train
import uavsnn.identify
import uavsnn.network
from uavsnn import ModelFileError, ParameterError
from uavsnn.cli import main
from uavsnn.dataset import SceneSource, build, load
from uavsnn.identifier import Identifier
from uavsnn.network import Network, default_config
from uavsnn.training import train

SOURCE = SceneSource("dvs", (240, 180), 200.0, 0.3)
CONFIG = {"conv2": {"threshold": 10.0}, "pent": {"max_density": 0.7}}


class _Reached(Exception):
    """Raised by a stand-in for the work a command does once its options are accepted."""


def _stop_at(module: object, name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    def reached(*_args: Any, **_kwargs: Any) -> None:
        raise _Reached

    monkeypatch.setattr(module, name, reached)


@pytest.fixture(scope="module")
def sets(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """``d0``: a dvs set of seed 11; ``more``: one of the same seed with more windows (its
    train recordings begin with ``d0``'s); ``copy``: ``d0`` copied; ``other``: seed 12."""
    root = tmp_path_factory.mktemp("sets")
    out = {}
    for name, seed, n_train in (("d0", 11, 40), ("more", 11, 48), ("other", 12, 20)):
        build(root / name, "dvs", n_test=4, n_train=n_train, seed=seed, dvs=SOURCE)
        out[name] = root / name
    shutil.copytree(root / "d0", root / "copy")
    out["copy"] = root / "copy"
    return out


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("model") / "m.npz"
    Network(default_config(), seed=0).save(path)
    return path


# -- 1. a tuning set of the training recordings ---------------------------------------------------


@pytest.mark.parametrize("tune", ["d0", "copy", "more", "link"])
def test_a_tuning_set_of_the_training_recordings_is_refused(
    tune: str,
    sets: dict[str, Path],
    model: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # Each was accepted and reported as "tuned on ... (a separate tuning set)".
    if tune == "link":
        symlink(tmp_path / "link", sets["d0"])
        path = tmp_path / "link"
    else:
        path = sets[tune]
    _stop_at(uavsnn.identify, "fit_network", monkeypatch)
    _stop_at(uavsnn.cli.train, "train", monkeypatch)
    out = tmp_path / "q.npz"
    only = ["train", str(sets["d0"]), "-o", str(out), "--identify-only", str(model)]
    line = one_line_exit_2(capsys, [*only, "--tune", str(path)], "--tune")
    assert "another --seed" in line
    full = ["train", str(sets["d0"]), "-o", str(out), "--tune", str(path), "--quiet"]
    assert "another --seed" in one_line_exit_2(capsys, full, "--tune")
    assert not out.exists()
    # A set of another seed holds other recordings: accepted.
    with pytest.raises(_Reached):
        main([*only, "--tune", str(sets["other"])])


def test_a_tuning_set_of_the_same_clips_is_refused() -> None:
    # Real clips: a tuning set of another seed splits the same videos again.
    def data(seed: int, split: dict[str, list[str]], used: list[int]) -> SimpleNamespace:
        recordings = [
            {"id": i, "name": Path(v).stem, "domain": "real", "split": s, "video": v}
            for i, (s, v) in enumerate((s, v) for s, vs in split.items() for v in vs)
        ]
        splits = {
            s: {"recordings": [r["id"] for r in recordings if r["split"] == s]} for s in split
        }
        manifest = {"domain": "real", "seed": seed, "recordings": recordings, "splits": splits}
        return SimpleNamespace(manifest=manifest, recording=np.array(used))

    trained = data(0, {"test": ["A.mp4", "B.mp4"], "train": ["C.mp4", "D.mp4"]}, [2, 3])
    tuning = data(1, {"test": ["C.mp4"], "train": ["A.mp4", "E.mp4"]}, [1, 2])
    with pytest.raises(ParameterError, match=r"A\.mp4") as info:
        uavsnn.cli.train.check_tuning_set(Path("d"), trained, Path("t"), tuning)
    assert "test split" in str(info.value) and "other videos" in str(info.value)
    apart = data(1, {"test": ["X.mp4"], "train": ["Y.mp4", "Z.mp4"]}, [1, 2])
    uavsnn.cli.train.check_tuning_set(Path("d"), trained, Path("t"), apart)


# -- 2. a dataset of another sensor size ----------------------------------------------------------


@pytest.fixture(scope="module")
def set346(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("s346") / "set"
    source = SceneSource("dvs", (346, 260), 200.0, 0.3, sensor=(346, 260))
    build(root, "dvs", n_test=2, n_train=6, seed=3, dvs=source, sensor=(346, 260))
    return root


def test_the_network_takes_the_datasets_sensor_size(
    set346: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # It failed: "shape mismatch for 'sensor_size': expected 240x180 (the network's input)".
    out = tmp_path / "m.npz"
    argv = ["train", str(set346), "-o", str(out), "--windows-per-layer", "4", "--no-identify"]
    assert main([*argv, "--layers", "conv2", "--quiet"]) == 0
    config = Network.load(out).config
    assert (config["width"], config["height"]) == (346, 260)
    # A size given that is not the dataset's is refused before training, with the fix.
    out.unlink()
    line = one_line_exit_2(capsys, [*argv, "--set", "width=240"], "240x260")
    assert "--set width=346 --set height=260" in line
    table1 = tmp_path / "table1.json"
    table1.write_text(json.dumps(default_config()))
    line = one_line_exit_2(capsys, [*argv, "--config", str(table1)], "240x180")
    assert "--set width=346 --set height=260" in line and "--config" in line
    assert not out.exists()
    # The help and the size the summary reports say so.
    with pytest.raises(SystemExit):
        main(["train", "--help"])
    assert "the dataset's sensor size" in " ".join(capsys.readouterr().out.split())


# -- 3. --epochs with --windows-per-layer ---------------------------------------------------------


def test_epochs_beside_windows_per_layer_is_refused(
    sets: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # --epochs 3 --windows-per-layer 20 trained 21 windows: --epochs was dropped.
    out = tmp_path / "m.npz"
    argv = ["train", str(sets["d0"]), "-o", str(out), "--epochs", "3", "--windows-per-layer", "20"]
    line = one_line_exit_2(capsys, argv, "--epochs")
    assert "--windows-per-layer" in line and "give one" in line
    assert not out.exists()
    windows = load(sets["d0"], "train").windows
    with pytest.raises(ParameterError, match="give one"):
        train(Network(CONFIG, seed=0), windows, windows_per_layer=20, epochs=3)


# -- 4. --resume with nothing to resume; a checkpoint folder in a folder that does not exist ------


def test_resume_with_nothing_to_resume_says_so(
    sets: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out, ckpt = tmp_path / "m.npz", tmp_path / "ck"
    argv = [
        "train",
        str(sets["d0"]),
        "-o",
        str(out),
        "--windows-per-layer",
        "4",
        "--layers",
        "conv2",
        "--no-identify",
        "--quiet",
        "--checkpoint-dir",
        str(ckpt),
        "--resume",
    ]
    assert main(argv) == 0  # a folder not made yet
    assert f"nothing to resume in {ckpt}: training from the start" in capsys.readouterr().err
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main([*argv[:-2], str(empty), "--resume"]) == 0
    assert f"nothing to resume in {empty}: training from the start" in capsys.readouterr().err
    # With a checkpoint there is something: no note.
    assert main(argv) == 0
    assert "nothing to resume" not in capsys.readouterr().err


def test_a_checkpoint_folder_needs_its_parent_folder(
    sets: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # --checkpoint-dir /nonexist/ck made /nonexist/ck, while -o /nonexist/m.npz is refused.
    ckpt = tmp_path / "nonexist" / "ck"
    out = tmp_path / "m.npz"
    argv = ["train", str(sets["d0"]), "-o", str(out), "--checkpoint-dir", str(ckpt), "--quiet"]
    line = one_line_exit_2(capsys, argv, f"the folder {ckpt.parent} does not exist")
    assert "--checkpoint-dir" in line
    assert list(tmp_path.iterdir()) == []


# -- 5. a resume refused names only what changed --------------------------------------------------


def _refusal(**kwargs: Any) -> str:
    with pytest.raises(ParameterError, match="made with other settings") as info:
        train(Network(CONFIG, seed=3), layers=["conv2"], resume=True, **kwargs)
    return str(info.value).split(": ", 1)[1]


def test_a_refused_resume_names_only_what_changed(sets: dict[str, Path], tmp_path: Path) -> None:
    data = load(sets["d0"], "train")
    w8, w4 = data.select(np.arange(8)).windows, data.select(np.arange(4)).windows
    ckpt = tmp_path / "per-layer"
    train(Network(CONFIG, seed=3), w8, layers=["conv2"], windows_per_layer=10, checkpoint_dir=ckpt)
    # Only the dataset changed: it said "the training windows (dataset or split), the epochs".
    said = _refusal(windows=w4, windows_per_layer=10, checkpoint_dir=ckpt)
    assert said.startswith("the training windows (dataset or split) changed since")
    # Only --windows-per-layer: it said "the windows per layer, the reporting interval".
    said = _refusal(windows=w8, windows_per_layer=20, checkpoint_dir=ckpt)
    assert said.startswith("the windows per layer changed since")
    both = _refusal(windows=w4, windows_per_layer=20, checkpoint_dir=ckpt)
    assert both.startswith("the training windows (dataset or split), the windows per layer ")
    # In passes (no windows per layer): the dataset alone, the epochs alone.
    ckpt = tmp_path / "passes"
    train(Network(CONFIG, seed=3), w8, layers=["conv2"], checkpoint_dir=ckpt)
    said = _refusal(windows=w4, checkpoint_dir=ckpt)
    assert said.startswith("the training windows (dataset or split) changed since")
    said = _refusal(windows=w8, epochs=2, checkpoint_dir=ckpt)
    assert said.startswith("the epochs changed since")
    # The reporting interval alone (snapshots) is still named.
    said = _refusal(windows=w8, snapshots=0, checkpoint_dir=ckpt)
    assert said.startswith("the reporting interval (snapshots) changed since")


# -- 6. operating points that cannot be set, or are set on too few windows ------------------------


@pytest.fixture(scope="module")
def trained(sets: dict[str, Path]) -> Network:
    net = Network(CONFIG, seed=0)
    train(net, load(sets["d0"], "train").windows, windows_per_layer=100)
    return net


def test_operating_points_that_cannot_be_set_say_why(
    trained: Network, sets: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    # Tuned on windows without a UAV-free one: "threshold 1.000" and "alarm_thresholds": [].
    data = load(sets["d0"], "train")
    other = load(sets["other"], "train")
    uav_only = other.select(np.flatnonzero(np.asarray(other.label, bool)))
    _, summary = uavsnn.identify.fit_network(trained, data, uav_only, model="logistic")
    assert summary["alarm_thresholds"] == []
    note = summary["alarm_note"]
    assert "no UAV-free window" in note and "no false-alarm point" in note
    uavsnn.cli.train._print_identification(summary)
    assert f"note: {note}" in capsys.readouterr().out
    # Ten UAV-free windows: 5 % is 0.5 of one, 1 % a tenth; both are set, and said to be thin.
    _, summary = uavsnn.identify.fit_network(trained, data, other, model="logistic")
    assert [rate for rate, _ in summary["alarm_thresholds"]] == [0.01, 0.05]
    note = summary["alarm_note"]
    assert "10 UAV-free" in note and "1 % and 5 %" in note and "100" in note
    uavsnn.cli.train._print_identification(summary)
    assert f"note: {note}" in capsys.readouterr().out


def test_alarm_note_rule() -> None:
    from uavsnn.identify import alarm_note

    assert alarm_note(np.array([True, True]), ()) is not None
    label = np.arange(400) % 2 == 0  # 200 UAV-free windows: enough for 1 % (100) and 5 % (20)
    assert alarm_note(label, ((0.01, 0.9), (0.05, 0.5))) is None
    note = alarm_note(label[:100], ((0.01, 0.9), (0.05, 0.5)))  # 50: enough for 5 % only
    assert note is not None and "1 %" in note and "5 %" not in note


# -- 7. track alarm rates from too short a span ---------------------------------------------------


def test_track_rates_from_too_short_a_span_are_warned(
    sets: dict[str, Path],
    model: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # 0.02 minutes gave "0.1 false tracks per minute at 0.987, 1 false tracks per minute at
    # 0.987" without a word: both thresholds only keep the span's few tracks from alarming.
    ident = Identifier(("log_width",), np.zeros(2), np.zeros(1), np.ones(1), 0.5, 1.0)
    fitted = {
        "train_windows": 30,
        "tune_windows": 10,
        "tune": "a separate tuning set",
        "tune_lacks": [],
        "model": "logistic",
        "l2": 1.0,
        "threshold": 0.5,
        "alarm_thresholds": [],
        "alarm_note": None,
    }

    def streamed(minutes: float) -> Any:
        def tune(network: Network, **_kwargs: Any) -> tuple[Identifier, dict[str, Any]]:
            pairs = ((0.1, 0.987), (1.0, 0.5))
            tuned = Identifier(
                ("log_width",),
                np.zeros(2),
                np.zeros(1),
                np.ones(1),
                0.5,
                1.0,
                track_alarm_thresholds=pairs,
                track_alarm_minutes=minutes,
            )
            summary = {
                "seed": 1,
                "minutes": minutes,
                "recordings": 1,
                "confirmed_tracks": 2,
                "confirm": "3/5",
                "track_alarm_thresholds": [list(p) for p in pairs],
            }
            return tuned, summary

        return tune

    monkeypatch.setattr(uavsnn.identify, "fit_network", lambda *_a, **_k: (ident, dict(fitted)))
    argv = [
        "train",
        str(sets["d0"]),
        "-o",
        str(tmp_path / "q.npz"),
        "--identify-only",
        str(model),
        "--tune",
        str(sets["other"]),
        "--track-minutes",
    ]
    monkeypatch.setattr(uavsnn.cli.train, "tune_track_alarms", streamed(0.02))
    assert main([*argv, "0.02"]) == 0
    text = capsys.readouterr().out
    assert "0.1 and 1 false tracks per minute" in text and "at least 10 and 1 minutes" in text
    assert main([*argv, "0.02", "--json"]) == 0
    note = json.loads(capsys.readouterr().out)["identify"]["tracks"]["note"]
    assert "0.1 and 1 false tracks per minute" in note
    # 2 minutes hold enough for 1 per minute, not for 0.1; 10 minutes for both.
    monkeypatch.setattr(uavsnn.cli.train, "tune_track_alarms", streamed(2.0))
    assert main([*argv, "2", "--json"]) == 0
    note = json.loads(capsys.readouterr().out)["identify"]["tracks"]["note"]
    assert "0.1 false tracks per minute" in note and " 1 false" not in note
    monkeypatch.setattr(uavsnn.cli.train, "tune_track_alarms", streamed(10.0))
    assert main([*argv, "10", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["identify"]["tracks"]["note"] is None


# -- 8. a model file not named .npz ---------------------------------------------------------------


@pytest.mark.parametrize("only", [False, True])
def test_a_model_file_must_end_in_npz(
    only: bool,
    sets: dict[str, Path],
    model: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # -o mx.txt wrote a model named mx.txt; `uavsnn simulate -o a.txt` is refused.
    out = tmp_path / "mx.txt"
    argv = ["train", str(sets["d0"]), "-o", str(out), "--quiet", "--windows-per-layer", "4"]
    if only:
        argv = ["train", str(sets["d0"]), "-o", str(out), "--identify-only", str(model)]
    one_line_exit_2(capsys, argv, f"output must end in .npz, got {out}")
    assert not out.exists()


@pytest.mark.parametrize("domain", ["real", "dvs", None])
def test_the_tuning_advice_fits_the_dataset_s_domain(
    domain: str | None, capsys: pytest.CaptureFixture[str]
) -> None:
    """A dataset of real footage is advised to tune on other videos: `--stratify`, which the
    notes advised for every dataset, is refused for real footage."""
    ident = {
        "model": "logistic", "train_windows": 10, "tune_windows": 4, "l2": 1.0,
        "threshold": 0.5, "tune": uavsnn.identify.HELD_OUT_TUNING, "tune_lacks": ["airplane"],
    }  # fmt: skip
    manifest = None if domain is None else {"domain": domain}
    uavsnn.cli.train._print_identification(ident, manifest)
    out = capsys.readouterr().out
    notes = [line for line in out.splitlines() if line.startswith("note: ")]
    assert len(notes) == 2
    # A class the guess never gives is said; without a class guess, that is said.
    for classes, note in ((["uav", "bird"], "never gives airplane"), ([], "no class guess")):
        uavsnn.cli.train._print_identification(
            {**ident, "classes": classes, "classes_left_out": ["airplane"]}, manifest
        )
        assert note in capsys.readouterr().out
    stratify = "--stratify" in out
    assert stratify is (domain != "real"), out
    assert ("--domain real --videos OTHER_VIDEOS" in out) is (domain == "real"), out


# -- what a model was trained on ------------------------------------------------------------------


def test_a_trained_model_records_its_windows_and_recordings(
    sets: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`uavsnn train` records the windows and recordings it trained on: `info` shows them,
    `evaluate` says when the split it scores holds one (its figures on them are no test: a
    dataset of the same seed with more recordings holds the training recordings again), and a
    Detector windows as the model was trained."""
    from uavsnn import Detector

    out = tmp_path / "m.npz"
    argv = ["train", str(sets["d0"]), "-o", str(out), "--windows-per-layer", "8"]
    assert main([*argv, "--no-identify", "--quiet", "--set", "conv2.threshold=10"]) == 0
    capsys.readouterr()
    net = Network.load(out)
    trained = net.trained_on
    assert trained is not None and (trained.window_us, trained.overlap) == (50_000, 0.5)
    d0 = load(sets["d0"], "train")
    names = {str(e["name"]) for e in d0.manifest["recordings"] if e["split"] == "train"}
    assert {name for _, name in trained.recordings} == names and names
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "trained on:  windows of 50 ms, overlap 0.5" in text
    # What one window's state takes (the engine's count), and a detector's live windows.
    mib = net.state_bytes / 2**20
    assert f"memory:      {mib:.3g} MiB a window's state; a detector keeps 2 live" in text
    assert f"{64 * mib:.3g} MiB: an overlap of 0.984)" in text
    # The same dataset's test split: other recordings, nothing said.
    assert main(["evaluate", str(out), str(sets["d0"]), "--json"]) == 0
    done = capsys.readouterr()
    assert json.loads(done.out)["trained_on_split"] == [] and "warning" not in done.err
    # A dataset of the same seed with more recordings: its train split holds d0's.
    assert main(["evaluate", str(out), str(sets["more"]), "--split", "train", "--json"]) == 0
    done = capsys.readouterr()
    shared = json.loads(done.out)["trained_on_split"]
    assert set(shared) == names
    assert f"warning: {len(names)} of the train split's recordings trained" in done.err
    # A Detector and detect window as the model was trained, unless told otherwise.
    net.trained_on = replace(trained, window_us=20_000, overlap=0.0)
    net.save(out)
    det = Detector(out)
    assert (det.window_us, det.overlap) == (20_000, 0.0)
    assert Detector(out, window_us=30_000, overlap=0.5).window_us == 30_000
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "windows of 20 ms, overlap 0" in text and "a detector keeps 1 live" in text
    # Evaluated on windows of another length: said.
    assert main(["evaluate", str(out), str(sets["d0"])]) == 0
    assert "was trained on windows of 20 ms, overlap 0; " in capsys.readouterr().err


def test_a_model_without_its_training_record_keeps_the_defaults(tmp_path: Path) -> None:
    from uavsnn import Detector
    from uavsnn.provenance import ARRAY, TrainedOn

    path = tmp_path / "m.npz"
    net = Network(CONFIG, seed=0)
    net.save(path)
    loaded = Network.load(path)
    assert loaded.trained_on is None
    assert (Detector(loaded).window_us, Detector(loaded).overlap) == (50_000, 0.5)
    # Saved and loaded, copied and pickled whole.
    net.trained_on = TrainedOn(25_000, 0.25, ((("clip", "V_DRONE_001.mp4"), "V_DRONE_001"),))
    net.save(path)
    import copy
    import pickle

    for other in (
        Network.load(path),
        net.copy(),
        copy.deepcopy(net),
        pickle.loads(pickle.dumps(net)),
    ):
        assert other.trained_on == net.trained_on
    # A damaged or later entry is refused with the file's name.
    for bad in (b'{"version": 2}', b"not json", b'{"version": 1, "window_us": 0}'):
        with np.load(path) as arrays:
            kept = {name: arrays[name] for name in arrays.files}
        kept[ARRAY] = np.frombuffer(bad, dtype=np.uint8)
        uavsnn.network._add_arrays(str(path), kept)
        with pytest.raises(ModelFileError, match=f"{ARRAY} entry is damaged"):
            Network.load(path)


def test_detect_notes_a_window_the_model_was_not_trained_on(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # detect --window-ms 20 --overlap 0.9 on a model of 50 ms windows said nothing (evaluate
    # notes a dataset windowed otherwise).
    from conftest import random_events

    from uavsnn.events import Recording
    from uavsnn.io import write_npz
    from uavsnn.provenance import TrainedOn

    net = Network(CONFIG, seed=0)
    net.trained_on = TrainedOn(50_000, 0.5)
    net.save(tmp_path / "m.npz")
    size = (int(net.config["width"]), int(net.config["height"]))
    write_npz(Recording(random_events(500, size), size), tmp_path / "r.npz")
    argv = ["detect", str(tmp_path / "r.npz"), "-m", str(tmp_path / "m.npz"), "--summary-every"]
    for extra, said in (([], False), (["--window-ms", "50"], False), (["--overlap", "0.9"], True)):
        assert main([*argv, "0", *extra]) == 0
        err = capsys.readouterr().err
        assert ("was trained on windows of 50 ms, overlap 0.5; these are" in err) == said, err
    assert main([*argv, "0", "--window-ms", "20", "--overlap", "0"]) == 0
    assert "overlap 0.5; these are 20 ms, overlap 0:" in capsys.readouterr().err
    assert TrainedOn(50_000, 0.5).windowed_otherwise(50_000, 0.5) is None


def test_a_stratified_tuning_set_lacking_a_kind_is_told_to_hold_more_windows(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # The note advised --stratify for a tuning set built with it, too small to hold every kind.
    from uavsnn.cli.train import _print_identification

    ident = {"model": "logistic", "train_windows": 60, "tune_windows": 60, "tune": "tune set"}
    ident |= {"l2": 1.0, "threshold": 0.5, "tune_lacks": ["leaf"]}
    advice = {
        None: "`uavsnn dataset build --stratify` makes a tuning set",
        "stratified": "a tuning set of more windows (--n-train) has them",
    }
    for scenes, said in advice.items():
        tune = {"domain": "dvs", "parameters": {"object_scenes": scenes}}
        _print_identification(ident, {"domain": "dvs"}, tune)
        out = capsys.readouterr().out
        assert "the tuning windows hold no leaf object" in out and said in out
    _print_identification(ident, {"domain": "real"}, None)
    assert "a tuning set built from videos of every class has them" in capsys.readouterr().out


# -- continuing STDP from a model file (--from) ---------------------------------------------------


def test_train_from_a_model_continues_its_stdp(
    sets: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """There was no way to continue a trained model's STDP on new recordings (one's own footage)
    from the command line: `--from MODEL` starts from its config and weights, keeps what
    `--layers` leaves alone, changes settings by `--set` but not the shape or the input size,
    and records both sets of recordings."""
    first, later = tmp_path / "first.npz", tmp_path / "later.npz"
    base = ["--windows-per-layer", "8", "--no-identify", "--quiet"]
    argv = ["train", str(sets["other"]), "-o", str(first), *base, "--set", "conv2.threshold=10"]
    assert main(argv) == 0
    start = Network.load(first)
    # Only conv3 goes on: conv1 and conv2 are MODEL's, and conv2's threshold is MODEL's too.
    argv = ["train", str(sets["d0"]), "-o", str(later), *base, "--from", str(first)]
    assert main([*argv, "--layers", "conv3", "--set", "conv3.threshold=2.5"]) == 0
    assert f"wrote {later} (from {first})" in capsys.readouterr().out
    net = Network.load(later)
    for layer in ("conv1", "conv2"):
        assert np.array_equal(net.weights(layer), start.weights(layer))
    assert not np.array_equal(net.weights("conv3"), start.weights("conv3"))
    assert net.config["conv2"]["threshold"] == 10.0 and net.config["conv3"]["threshold"] == 2.5
    fresh = Network(net.config, seed=0)
    assert not np.array_equal(fresh.weights("conv2"), net.weights("conv2"))
    assert start.trained_on is not None and net.trained_on is not None
    recorded = set(net.trained_on.recordings)
    assert set(start.trained_on.recordings) < recorded
    d0 = load(sets["d0"], "train").manifest["recordings"]
    assert {name for _, name in recorded} >= {str(e["name"]) for e in d0 if e["split"] == "train"}
    # The JSON names where it started, and an identification MODEL had is not kept: it was
    # fitted on the old weights.
    start.identification = Identifier(
        ("log_width",), np.zeros(2), np.zeros(1), np.ones(1), 0.5, 1.0
    )
    start.save(first)
    assert main([*argv, "--layers", "conv3", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert (
        summary["from"] == str(first) and "identification was fitted on its old" in summary["note"]
    )
    assert Network.load(later).identification is None
    later.unlink()
    # What --from leaves no room for is refused before any work, in one line.
    one_line_exit_2(capsys, [*argv, "--set", "conv2.maps=8"], "changes the shape of conv2")
    one_line_exit_2(capsys, [*argv, "--set", "width=320"], "keeps MODEL's input size")
    config = tmp_path / "c.json"
    config.write_text(json.dumps(default_config()))
    one_line_exit_2(capsys, [*argv, "--config", str(config)], "not with --config")
    checkpoints = ["--checkpoint-dir", str(tmp_path / "ck"), "--resume"]
    one_line_exit_2(capsys, [*argv, *checkpoints], "--resume continues from --checkpoint-dir")
    only = ["train", str(sets["d0"]), "-o", str(later), "--identify-only", str(first)]
    one_line_exit_2(capsys, [*only, "--from", str(first)], "--from")
    wide = tmp_path / "wide.npz"
    Network({**default_config(), "width": 320, "height": 240}).save(wide)
    line = one_line_exit_2(capsys, [*argv[:-1], str(wide)], "input is 320x240")
    assert "the dataset's sensor 240x180" in line
    assert not later.exists()
