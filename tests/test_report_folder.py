"""``uavsnn evaluate MODEL DATASET --report DIR``: a DIR that cannot be written is refused before
any work, and DIR is made only when the report is written, so that a run refused later (a bad
option checked once the model is read, a model and a dataset of different sizes) leaves no
empty folder behind."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import one_line_exit_2, symlink, unwritable_folder

from uavsnn.cli import main
from uavsnn.dataset import SceneSource, build
from uavsnn.network import Network

SENSOR = (240, 180)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("data") / "set"
    dvs = SceneSource("dvs", SENSOR, 200.0, 0.3)
    return build(root, "dvs", n_test=4, n_train=0, seed=3, dvs=dvs).root


@pytest.fixture(scope="module")
def models(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A model of the dataset's size and one of another size, neither with identification."""
    folder = tmp_path_factory.mktemp("models")
    paths = {"fits": folder / "fits.npz", "small": folder / "small.npz"}
    Network({"width": SENSOR[0], "height": SENSOR[1]}, seed=3).save(paths["fits"])
    Network({"width": 40, "height": 30}, seed=3).save(paths["small"])
    return paths


def test_a_refused_evaluate_leaves_no_report_folder(
    tmp_path: Path,
    dataset: Path,
    models: dict[str, Path],
    capsys: pytest.CaptureFixture[str],
) -> None:
    # Each left an empty DIR (and the folders above it) behind.
    report = tmp_path / "out" / "report"
    fits, small = str(models["fits"]), str(models["small"])
    for argv, match in [
        ([small, str(dataset)], "the model's input is 40x30"),
        ([fits, str(dataset), "--roc", str(tmp_path / "roc.png")], "--roc needs a model"),
        ([fits, str(dataset), "--tracks", "--confirm", "2/3+3/5"], "score-aware rule"),
        ([fits, str(tmp_path / "no-dataset")], "no-dataset"),
        ([str(tmp_path / "no-model.npz"), str(dataset)], "no-model.npz"),
    ]:
        one_line_exit_2(capsys, ["evaluate", *argv, "--report", str(report)], match)
        assert sorted(p.name for p in tmp_path.iterdir()) == [], argv


def test_a_bad_report_folder_is_refused_before_the_model_is_read(
    tmp_path: Path,
    dataset: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The model does not exist: a refusal that names --report came before reading it."""
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    evaluate = ["evaluate", str(tmp_path / "no-model.npz"), str(dataset), "--report"]
    one_line_exit_2(capsys, [*evaluate, str(blocker)], "exists and is not a folder")
    one_line_exit_2(capsys, [*evaluate, str(blocker / "sub" / "report")], "a-file is not a folder")
    symlink(tmp_path / "link", tmp_path / "nowhere")
    one_line_exit_2(capsys, [*evaluate, str(tmp_path / "link")], "--report")
    assert blocker.read_text() == "x"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file", "link"]

    # Folders that cannot be written (os.access says so; root may write anywhere).
    locked = unwritable_folder(monkeypatch, tmp_path / "locked")
    one_line_exit_2(capsys, [*evaluate, str(locked)], "not writable")
    one_line_exit_2(capsys, [*evaluate, str(locked / "new" / "report")], "not writable")
    assert list(locked.iterdir()) == []


def test_the_report_folder_is_made_when_the_report_is_written(
    tmp_path: Path, dataset: Path, models: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    report = tmp_path / "new" / "report"
    assert main(["evaluate", str(models["fits"]), str(dataset), "--report", str(report)]) == 0
    assert f"wrote {report / 'report.md'}" in capsys.readouterr().out
    assert (report / "report.md").is_file() and (report / "confusion.png").is_file()
    # An existing folder is written into as before.
    assert main(["evaluate", str(models["fits"]), str(dataset), "--report", str(report)]) == 0
    assert (report / "report.md").is_file()
