"""What a new user met on the command line: options accepted that did nothing (reproduce's real
footage options beside --no-real, evaluate's --track-score on a model without identification,
bench's --events beside --windows), a clip left out quietly (a video that is a link to
nothing) and FFmpeg's line before an empty video's error, a caption that was not true of a
trained conv1, --roc refused inside the --report folder that was about to be made, and texts
that said "1 recordings", mixed "6-12.0 px" and "object_scenes": "drawn" for real footage."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import one_line_exit_2, symlink

import uavsnn.cli.bench
import uavsnn.cli.reproduce as reproduce
import uavsnn.report as report
import uavsnn.track_eval
from uavsnn.cli import _results_text, main
from uavsnn.cli.evaluate import _print_identification, _print_tracks
from uavsnn.dataset import SceneSource, build
from uavsnn.identify import Identifier
from uavsnn.network import Network

SENSOR = (240, 180)


class Reached(Exception):
    """A stand-in for the work a command does once its options are accepted was called."""


def _stop_at(monkeypatch: pytest.MonkeyPatch, module: object, name: str) -> list[Any]:
    """``module.name`` made to record its keyword arguments and raise :class:`Reached`."""
    calls: list[Any] = []

    def reached(*_args: Any, **kwargs: Any) -> None:
        calls.append(kwargs)
        raise Reached

    monkeypatch.setattr(module, name, reached)
    return calls


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("data") / "set"
    dvs = SceneSource("dvs", SENSOR, 200.0, 0.3)
    return build(root, "dvs", n_test=8, n_train=0, seed=3, dvs=dvs).root


def _identifier() -> Identifier:
    names = ("log_width", "log_height")
    return Identifier(names, np.array([0.5, -0.25, 0.1]), np.zeros(2), np.ones(2), 0.4, 1.0)


@pytest.fixture(scope="module")
def models(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A model without identification ("plain"), one with ("ident"), and one whose conv1 is
    no longer the Gabor bank of its config ("conv1"), as after `uavsnn train --layers
    conv1,...`."""
    folder = tmp_path_factory.mktemp("models")
    paths = {name: folder / f"{name}.npz" for name in ("plain", "ident", "conv1")}
    config = {"width": SENSOR[0], "height": SENSOR[1]}
    Network(config, seed=3).save(paths["plain"])
    net = Network(config, seed=3)
    net.identification = _identifier()
    net.save(paths["ident"])
    trained = Network(config, seed=3)
    w = trained.weights("conv1")
    trained.set_weights("conv1", np.clip(1.0 - w, 0.0, 1.0).astype(np.float32))
    trained.save(paths["conv1"])
    return paths


# ------------------------------------------------------------------ 1. reproduce --no-real


@pytest.fixture
def no_build(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """reproduce's dataset builder replaced by one that stops the run (every check passed)."""
    return _stop_at(monkeypatch, reproduce, "build")


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--videos", "vids"], "--videos sets the real-footage experiment, which --no-real"),
        (["--real-sensors", "640x480"], "--real-sensors sets the real-footage experiment"),
        (
            ["--videos", "vids", "--real-sensors", "240x180"],
            "--videos and --real-sensors set the real-footage experiment",
        ),
    ],
)
def test_reproduce_refuses_real_footage_options_beside_no_real(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    no_build: list[Any],
    extra: list[str],
    message: str,
) -> None:
    out = tmp_path / "a" / "repro"
    argv = ["reproduce", "--out", str(out), "--quiet", "--no-real", *extra]
    one_line_exit_2(capsys, argv, message)
    assert not no_build and not (tmp_path / "a").exists()


def test_reproduce_refuses_real_sensors_where_there_is_no_footage(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    no_build: list[Any],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # No --videos and no default folder: the run would go on without real footage, and
    # --real-sensors would change nothing.
    monkeypatch.setattr(reproduce, "_DEFAULT_VIDEOS", tmp_path / "absent")
    out = tmp_path / "repro"
    argv = ["reproduce", "--out", str(out), "--quiet", "--real-sensors", "240x180"]
    one_line_exit_2(capsys, argv, "--real-sensors sets the sizes of the real-footage experiment")
    assert not no_build and not out.exists()
    # Without it the run starts (and says there is no real footage).
    with pytest.raises(Reached):
        main(argv[:-2])
    assert "no real footage" in capsys.readouterr().err


# ------------------------------------------------------------------ 2. evaluate --track-score


def test_track_score_needs_a_model_with_identification(
    dataset: Path, models: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["evaluate", str(models["plain"]), str(dataset), "--tracks", "--track-score", "max"]
    one_line_exit_2(capsys, argv, "--track-score max sets how the identified track rule alarms")
    one_line_exit_2(capsys, [*argv[:-1], "mean"], "needs a model with identification")


def test_an_ablation_tuned_on_the_evaluated_recordings_is_refused(
    models: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # `evaluate --ablation DIR` tuned each refit on DIR whatever it held: the dataset itself or
    # a copy of it gave figures tuned on the recordings they score.
    import shutil

    data = build(
        tmp_path / "set",
        "dvs",
        n_test=4,
        n_train=4,
        seed=5,
        dvs=SceneSource("dvs", SENSOR, 200.0, 0.3),
    ).root
    copy = tmp_path / "copy"
    shutil.copytree(data, copy)
    argv = ["evaluate", str(models["ident"]), str(data), "--ablation"]
    one_line_exit_2(capsys, [*argv, str(data)], "--ablation")
    line = one_line_exit_2(capsys, [*argv, str(copy)], "holds recordings of")
    assert line.startswith("uavsnn evaluate: error: --ablation ")


def test_track_score_reaches_the_track_figures_and_is_recorded(
    dataset: Path,
    models: dict[str, Path],
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    base = ["evaluate", str(models["ident"]), str(dataset), "--tracks"]
    for extra, score in (([], "mean"), (["--track-score", "max"], "max")):
        assert main([*base, *extra, "--json"]) == 0
        figures = json.loads(capsys.readouterr().out)
        assert figures["tracks"]["confirm"] == "3/5"
        assert figures["tracks"]["track_score"] == score
        assert main([*base, *extra]) == 0
        assert f"identified on the running {score} UAV score" in capsys.readouterr().out
    # Without identification the any-spike rule alone is scored: no running score.
    assert main(["evaluate", str(models["plain"]), str(dataset), "--tracks", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["tracks"]["track_score"] is None
    # It is the option, not a default, that the track figures are computed with.
    calls = _stop_at(monkeypatch, uavsnn.track_eval, "evaluate_tracks")
    with pytest.raises(Reached):
        main([*base, "--track-score", "max"])
    assert calls[0]["track_score"] == "max"


# ------------------------------------------------------------------ 3. bench --windows --events


def test_bench_refuses_windows_beside_events(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    calls = _stop_at(monkeypatch, uavsnn.cli.bench, "bench_density")
    argv = ["bench", "--windows", "3", "--events", "5000", "--quiet"]
    one_line_exit_2(capsys, argv, "--windows and --events both set how many windows")
    assert not calls
    # Either alone is taken; neither: the default count of events.
    for extra, windows, events in (
        (["--windows", "3"], 3, 300_000),
        (["--events", "5000"], None, 5000),
        ([], None, 300_000),
    ):
        with pytest.raises(Reached):
            main(["bench", "--quiet", *extra])
        assert (calls[-1]["windows"], calls[-1]["events"]) == (windows, events)


# ------------------------------------------------------------------ 4. real footage


def test_a_video_that_is_a_link_to_nothing_is_a_dataset_error(
    tmp_path: Path, clips: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (clips / "V_DRONE_009.csv").write_text((clips / "V_DRONE_001.csv").read_text())
    symlink(clips / "V_DRONE_009.mp4", tmp_path / "gone.mp4")
    out = tmp_path / "ds"
    argv = ["dataset", "build", str(out), "--domain", "real", "--videos", str(clips)]
    line = one_line_exit_2(capsys, [*argv, "--n-test", "4", "--quiet"], "V_DRONE_009.mp4")
    assert "DatasetError" in line or "link to nothing" in line
    assert not (out / "manifest.json").exists()
    # Its box file a link to nothing: named as such, not as missing.
    (clips / "V_DRONE_009.mp4").unlink()
    (clips / "V_DRONE_009.csv").unlink()
    (clips / "V_DRONE_009.mp4").write_bytes((clips / "V_DRONE_001.avi").read_bytes())
    symlink(clips / "V_DRONE_009.csv", tmp_path / "gone.csv")
    one_line_exit_2(capsys, [*argv, "--n-test", "4", "--quiet"], "V_DRONE_009.csv is a link to")


def test_an_empty_video_is_one_line_and_nothing_from_ffmpeg(
    tmp_path: Path, clips: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    (clips / "V_DRONE_009.mp4").write_bytes(b"")
    (clips / "V_DRONE_009.csv").write_text((clips / "V_DRONE_001.csv").read_text())
    argv = ["dataset", "build", str(tmp_path / "ds"), "--domain", "real", "--videos", str(clips)]
    assert main([*argv, "--n-test", "4", "--quiet"]) == 2
    err = capfd.readouterr().err  # FFmpeg writes to the descriptor itself
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "error:" in lines[0] and "V_DRONE_009.mp4" in lines[0] and "empty" in lines[0]


# ------------------------------------------------------------------ 5. conv1's caption


def test_a_trained_conv1_is_not_captioned_as_fixed_gabor_kernels(
    tmp_path: Path, dataset: Path, models: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    md = {}
    for name in ("plain", "conv1"):
        folder = tmp_path / name
        assert main(["evaluate", str(models[name]), str(dataset), "--report", str(folder)]) == 0
        capsys.readouterr()
        md[name] = (folder / "report.md").read_text(encoding="utf-8")
    gabor = report.CAPTIONS["features-conv1"]
    assert "fixed, not learned" in gabor and f"*features-conv1: {gabor}*" in md["plain"]
    assert "fixed, not learned" not in md["conv1"]
    assert f"*features-conv1: {report.TRAINED_CONV1_CAPTION}*" in md["conv1"]
    assert not report.conv1_trained(Network.load(models["plain"]))
    assert report.conv1_trained(Network.load(models["conv1"]))
    assert report.caption("features-conv1") == gabor  # the network not given: as before


# ------------------------------------------------------------------ 6. --roc inside --report


def test_roc_inside_the_report_folder_is_written_there(
    tmp_path: Path, dataset: Path, models: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    report = tmp_path / "rep1"
    argv = ["evaluate", str(models["ident"]), str(dataset), "--report", str(report)]
    assert main([*argv, "--roc", str(report / "roc.png"), "--json"]) == 0
    figures = json.loads(capsys.readouterr().out)
    assert (report / "roc.png").is_file() and (report / "report.md").is_file()
    assert figures["roc_png"] == str(report / "roc.png")
    # A name the report writes itself would be overwritten: refused before anything is made.
    other = tmp_path / "rep2"
    argv[-1] = str(other)
    one_line_exit_2(capsys, [*argv, "--roc", str(other / "confusion.png")], "confusion.png")
    # A folder below the report's is still one that does not exist.
    one_line_exit_2(capsys, [*argv, "--roc", str(other / "sub" / "roc.png")], "does not exist")
    assert not other.exists()


# ------------------------------------------------------------------ 7. texts


def test_one_recording_is_singular(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    tracks: dict[str, Any] = {
        "confirm": "3/5", "recordings": 1, "uav_recordings": 1, "windows": 1,
        "window_coverage": 1.0, "uav_free_minutes": 0.0, "alarm_clock": "recording",
        "rules": {"any_spike": {
            "time_to_alarm_ms": {"median": None}, "false_tracks_per_minute": None, "found": 0,
            "false_tracks": 0, "stray_tracks": 0, "decided": {"right": 0}, "missed": [],
        }},
        "per_recording": [],
    }  # fmt: skip
    _print_tracks(tracks)
    out = capsys.readouterr().out
    assert "1 recording (1 with a UAV), 1 window (" in out and "recordings (" not in out
    monkeypatch.setattr(_results_text, "track_table", lambda _figures: "")
    assert _results_text.tracks_text(tracks).startswith("1 test recording (1 with a UAV)")


def test_dataset_info_says_one_recording_and_no_scenes_for_real_footage(
    tmp_path: Path, clips: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "real"
    argv = ["dataset", "build", str(out), "--domain", "real", "--videos", str(clips)]
    assert main([*argv, "--n-test", "4", "--quiet"]) == 0
    capsys.readouterr()
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["parameters"]["object_scenes"] is None  # real footage draws no scenes
    assert main(["dataset", "info", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["parameters"]["object_scenes"] is None
    # A manifest written before ("drawn") reads the same; a split of one recording says so.
    manifest["parameters"]["object_scenes"] = "drawn"
    manifest["splits"]["train"]["recordings"] = manifest["splits"]["train"]["recordings"][:1]
    (out / "manifest.json").write_text(json.dumps(manifest))
    assert main(["dataset", "info", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["parameters"]["object_scenes"] is None
    assert main(["dataset", "info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "from 1 recording —" in text and "from 1 recordings" not in text


def test_drawn_size_bounds_are_written_alike(capsys: pytest.CaptureFixture[str]) -> None:
    rule = {"confusion": [[1, 0], [0, 1]], "accuracy": 1.0, "accuracy_interval": [0.5, 1.0]}
    ident = {
        "any_spike": rule, "identified": rule, "roc": None, "rotor_coverage": [],
        "at_false_alarm": [{
            "false_alarm_target": 0.01, "detection_rate": 0.5, "detection_interval": [0.1, 0.9],
            "by_size_px": [
                {"low": 0.0, "high": 6.0, "rate": 0.03},
                {"low": 6.0, "high": 12.0, "rate": 0.5},
                {"low": 12.0, "high": None, "rate": 1.0},
            ],
        }],
    }  # fmt: skip
    _print_identification(ident)
    out = capsys.readouterr().out
    assert "by drawn size: 0–6 px 3.0 %, 6–12 px 50.0 %, ≥ 12 px 100.0 %)" in out
