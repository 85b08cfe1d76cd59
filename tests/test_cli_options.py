"""Options a new user gave that the command line read and then ignored, or answered with advice
it does not take: each is refused in one line (exit 2) saying what it applies to, and the
commands given without them work as before."""

from __future__ import annotations

import io
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import SMALL_SENSOR, random_events, small_config, symlink
from conftest import one_line_exit_2 as _one_line_exit_2

import uavsnn
import uavsnn.cli.dataset
import uavsnn.cli.train
import uavsnn.distributed
import uavsnn.identify
from uavsnn import ParameterError
from uavsnn import io as uio
from uavsnn.cli import main
from uavsnn.dataset import SceneSource, build, load
from uavsnn.dataset.build import _check_build_args
from uavsnn.detector import Detector
from uavsnn.network import Network


class _Reached(Exception):
    """Raised by a stand-in for the work a command does once its options are accepted."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("reached")
        self.kwargs = kwargs


def _stop_at(module: object, name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Make ``module.name`` raise :class:`_Reached` with the arguments it was called with."""

    def reached(*args: Any, **kwargs: Any) -> None:
        raise _Reached(args=args, **kwargs)

    monkeypatch.setattr(module, name, reached)


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("model") / "model.npz"
    Network(small_config(), seed=3).save(path)
    return path


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rec") / "A.npz"
    uio.write_npz(uavsnn.Recording(random_events(400, SMALL_SENSOR), SMALL_SENSOR), path)
    return path


# -- 1. dataset build: options its domain does not use --------------------------------------------


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        # The new user's command: --pix2nvs-compat, --videos and --test-fraction changed nothing.
        (["--domain", "dvs", "--pix2nvs-compat"], "--pix2nvs-compat sets PIX2NVS"),
        (["--domain", "dvs", "--videos", "v"], "--videos holds real clips"),
        (["--domain", "sim", "--videos", "v"], "not --domain sim"),
        (["--domain", "dvs", "--test-fraction", "0.9"], "--test-fraction splits the real clips"),
        (["--domain", "sim", "--test-fraction", "0.9"], "not --domain sim"),
        (["--domain", "combined", "--test-fraction", "0.9"], "combined without --videos"),
        # The reverse: the dvs camera's options with domains without dvs scenes (already refused).
        (["--domain", "sim", "--lens", "1.4"], "--lens is for rendered dvs scenes"),
        (["--domain", "real", "--videos", "v", "--fov", "20"], "--fov is for rendered dvs"),
        (["--domain", "sim", "--lens", "1.4", "--focus-m", "3"], "--lens"),
    ],
)
def test_dataset_build_refuses_options_its_domain_ignores(
    extra: list[str], match: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "d"
    argv = ["dataset", "build", str(out), "--n-train", "4", "--n-test", "4", *extra]
    _one_line_exit_2(capsys, argv, match)
    assert not out.exists()


@pytest.mark.parametrize(
    ("extra", "fraction"),
    [
        ([], None),
        (["--domain", "real", "--videos", "v"], None),
        (["--domain", "real", "--videos", "v", "--test-fraction", "0.5"], 0.5),
        (["--domain", "combined", "--videos", "v", "--test-fraction", "0.4"], 0.4),
        (["--domain", "sim", "--pix2nvs-compat"], None),
    ],
)
def test_dataset_build_takes_the_options_where_they_apply(
    extra: list[str], fraction: float | None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _stop_at(uavsnn.cli.dataset, "build", monkeypatch)
    argv = ["dataset", "build", str(tmp_path / "d"), *(extra or ["--domain", "dvs"])]
    with pytest.raises(_Reached) as got:
        main(argv)
    assert got.value.kwargs["test_fraction"] == fraction


# -- 1. train: options that apply to another one --------------------------------------------------


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        (["--track-seed", "5"], "--track-seed applies to --track-minutes"),
        (["--no-identify", "--identify-model", "trees"], "--identify-model"),
        (["--identify-only", "M", "--layers", "conv3"], "--layers does not apply"),
        (["--identify-only", "M", "--epochs", "7"], "--epochs does not apply"),
        (["--identify-only", "M", "--windows-per-layer", "9"], "--windows-per-layer does"),
        (["--identify-only", "M", "--seed", "2"], "--seed does not apply"),
        (["--identify-only", "M", "--layers", "conv3", "--epochs", "7"], "--layers, --epochs do"),
        (["--identify-only", "M", "--checkpoint-dir", "c"], "--checkpoint-dir"),
        (["--identify-only", "M", "--resume"], "--resume"),
        (["--identify-only", "M", "--config", "c.json"], "--config"),
        (["--identify-only", "M", "--set", "conv2.threshold=9"], "--set"),
    ],
)
def test_train_refuses_options_that_would_change_nothing(
    extra: list[str], match: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "m.npz"
    _one_line_exit_2(capsys, ["train", "D", "-o", str(out), *extra], match)
    assert not out.exists()


def test_train_without_those_options_keeps_its_defaults(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    class Data:
        windows = None

        def __len__(self) -> int:
            return 0

    monkeypatch.setattr(uavsnn.cli.train, "load", lambda *_args: Data())
    _stop_at(uavsnn.cli.train, "train", monkeypatch)
    with pytest.raises(_Reached) as got:
        main(["train", "D", "-o", str(tmp_path / "m.npz"), "--quiet"])
    kwargs = got.value.kwargs
    assert kwargs["layers"] == ["conv2", "conv3"]
    assert (kwargs["epochs"], kwargs["seed"], kwargs["windows_per_layer"]) == (1, 0, None)


def test_identify_only_without_identify_model_fits_auto(
    model: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(uavsnn.cli.train, "load", lambda *_args: object())
    _stop_at(uavsnn.identify, "fit_network", monkeypatch)
    argv = ["train", "D", "-o", str(tmp_path / "m.npz"), "--identify-only", str(model)]
    with pytest.raises(_Reached) as got:
        main(argv)
    assert got.value.kwargs["model"] == "auto"
    with pytest.raises(_Reached) as got:
        main([*argv, "--identify-model", "trees"])
    assert got.value.kwargs["model"] == "trees"


# -- 1. detect: a stream's format given for another source ----------------------------------------


@pytest.mark.parametrize(
    ("source", "extra", "match"),
    [
        ("FILE", ["--stdin-format", "csv"], "--stdin-format applies to standard input"),
        ("FILE", ["--udp-format", "spif"], "--udp-format applies to UDP sources"),
        ("-", ["--udp-format", "spif"], "--udp-format applies to UDP sources"),
        ("udp://127.0.0.1:0", ["--stdin-format", "csv"], "--stdin-format applies"),
    ],
)
def test_detect_refuses_a_format_for_another_source(
    source: str,
    extra: list[str],
    match: str,
    model: Path,
    recording: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    source = str(recording) if source == "FILE" else source
    _one_line_exit_2(capsys, ["detect", source, "-m", str(model), *extra], match)


def _no_ray(monkeypatch: pytest.MonkeyPatch) -> None:
    """A test that --ray refuses before connecting never starts a cluster, should it fail."""

    def no_cluster(*_args: object) -> None:
        raise AssertionError("connected to Ray before refusing")

    monkeypatch.setattr(uavsnn.distributed, "runner_for", no_cluster)


def _stdin(monkeypatch: pytest.MonkeyPatch, data: bytes) -> None:
    monkeypatch.setattr(sys, "stdin", io.TextIOWrapper(io.BytesIO(data)))


def test_detect_without_a_format_reads_as_before(
    model: Path,
    recording: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    base = ["-m", str(model), "--summary-every", "0"]
    assert main(["detect", str(recording), *base]) == 0
    assert "events=400" in capsys.readouterr().err
    events = random_events(300, SMALL_SENSOR, seed=1)
    _stdin(monkeypatch, events.tobytes())
    assert main(["detect", "-", *base]) == 0  # packed, the default
    assert "events=300" in capsys.readouterr().err
    text = "".join(f"{int(e['t'])},{int(e['x'])},{int(e['y'])},{int(e['p'])}\n" for e in events)
    _stdin(monkeypatch, text.encode())
    assert main(["detect", "-", *base, "--stdin-format", "csv"]) == 0
    assert "events=300" in capsys.readouterr().err


# -- 2. detect: a live stream of another size than the model's -----------------------------------


def test_detect_on_a_live_stream_of_another_size_gives_advice_it_takes(
    model: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["detect", "-", "-m", str(model), "--summary-every", "0"]
    _stdin(monkeypatch, b"")
    line = _one_line_exit_2(capsys, [*argv, "--sensor-size", "80x60"], "--sensor-size 40x30")
    assert "add --downsample to crop and scale its events to the model" in line
    # A smaller camera cannot be downsampled to the model: refused, saying why.
    line = _one_line_exit_2(
        capsys, [*argv, "--sensor-size", "20x15", "--downsample"], "downsampling only reduces"
    )
    assert "a 20x15 sensor cannot be downsampled to 40x30" in line
    # The advice is taken: events of the model's sensor, with its --sensor-size or none.
    for extra in (["--sensor-size", "40x30"], [], ["--downsample"]):
        _stdin(monkeypatch, random_events(200, SMALL_SENSOR).tobytes())
        assert main([*argv, *extra]) == 0
        assert "events=200" in capsys.readouterr().err


def test_detect_downsamples_a_live_stream_as_it_does_a_file(
    model: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A camera larger than the model on standard input was refused (--downsample fitted files
    only): it is cropped and scaled chunk by chunk, as the same events in a file are whole."""
    from uavsnn.events import Recording
    from uavsnn.io import write_npz

    camera = (100, 60)  # cropped to 80x60, then scaled by a half
    events = random_events(3000, camera, seed=4)
    write_npz(Recording(events, camera), tmp_path / "r.npz")
    argv = ["-m", str(model), "--summary-every", "0", "--json", "--downsample"]
    assert main(["detect", str(tmp_path / "r.npz"), *argv]) == 0
    whole, whole_err = capsys.readouterr()
    _stdin(monkeypatch, events.tobytes())
    assert main(["detect", "-", *argv, "--sensor-size", "100x60"]) == 0
    out, err = capsys.readouterr()
    assert out == whole and '"detected": true' in whole
    # The events the detector took: those inside the crop, as from the file.
    kept = re.search(r" events=(\d+) ", whole_err)
    assert kept and 0 < int(kept[1]) < 3000 and f" events={kept[1]} " in err
    assert "lie off" not in err


def test_detect_several_live_streams_of_another_size_are_refused_before_ray(
    model: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # Each actor failed on its own with a Python hint (uavsnn.filters.downsample).
    _no_ray(monkeypatch)
    argv = ["detect", "udp://127.0.0.1:0", "udp://127.0.0.1:1", "-m", str(model), "--ray"]
    _one_line_exit_2(capsys, [*argv, "--sensor-size", "80x60"], "--sensor-size 40x30")


# -- 3. n_train: balanced, as n_test ---------------------------------------------------------------


@pytest.mark.parametrize("n_train", ["1", "3", "7"])
def test_dataset_build_refuses_an_odd_n_train(
    n_train: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 1 gave 1 window and no UAV; 3 gave 1 UAV and 2 not.
    out = tmp_path / "d"
    argv = ["dataset", "build", str(out), "--domain", "dvs", "--n-test", "4", "--n-train", n_train]
    _one_line_exit_2(capsys, argv, "n_train must be an even integer >= 2")
    assert not out.exists()
    with pytest.raises(ParameterError, match="n_train must be an even integer >= 2"):
        build(out, "dvs", n_test=4, n_train=int(n_train))
    assert not out.exists()


def test_n_train_of_0_and_the_real_default_are_kept() -> None:
    args = (50.0, 0.5, 0, 0.5, None)
    _check_build_args("dvs", None, 4, 0, *args)  # no train split
    _check_build_args("dvs", None, 4, 2, *args)
    _check_build_args("real", "videos", 4, None, *args)  # every usable window


def test_a_combined_train_set_is_half_uav(tmp_path: Path) -> None:
    # 6 windows were shared 3 and 3, each 1 UAV and 2 not: 2 UAV of 6.
    dvs = SceneSource("dvs", (64, 48), 200.0, 0.3, sensor=(64, 48))
    sim = SceneSource("sim", (96, 72), 30.0, 1.0, sensor=(64, 48))
    root = build(
        tmp_path / "c", "combined", n_test=2, n_train=6, seed=1, dvs=dvs, sim=sim, sensor=(64, 48)
    ).root
    train = load(root, "train")
    assert len(train) == 6 and int(np.sum(train.label)) == 3


# -- 4. simulate: neither a video nor --scene -----------------------------------------------------


def test_simulate_says_what_is_missing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = str(tmp_path / "x.npz")
    line = _one_line_exit_2(capsys, ["simulate", "-o", out], "give a video to simulate")
    assert "not both" not in line
    _one_line_exit_2(capsys, ["simulate", "v.mp4", "--scene", "uav", "-o", out], "not both")


# -- 5. detect: a window too long to measure its objects ------------------------------------------


def test_detect_refuses_a_window_too_long_with_advice_for_the_command_line(
    model: Path, recording: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["detect", str(recording), "-m", str(model), "--downsample", "--window-ms", "1e9"]
    line = _one_line_exit_2(capsys, argv, "give a shorter --window-ms")
    assert "rotor=False" not in line and "20480 ms" in line
    # The longest window measured is still taken.
    assert main(["detect", str(recording), "-m", str(model), "--window-ms", "20480"]) == 0
    capsys.readouterr()
    # The Python API keeps its Python advice.
    with pytest.raises(ParameterError, match="rotor=False"):
        Detector(Network(small_config()), window_us=10**12)
    # A window of 0 ms is told the range the command takes (it named 4.61e+15 ms).
    argv = ["detect", str(recording), "-m", str(model), "--window-ms", "0"]
    line = _one_line_exit_2(capsys, argv, "--window-ms must be a number of ms from 0.001")
    assert "to 20480, got 0" in line


@pytest.mark.parametrize("size", ["0x0", "40x0"])
def test_detect_refuses_a_sensor_of_no_pixels(
    size: str, model: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # It advised training a model of that size.
    argv = ["detect", "-", "-m", str(model), "--sensor-size", size]
    line = _one_line_exit_2(capsys, argv, "--sensor-size must be at least 1x1 pixels")
    assert "uavsnn train" not in line


@pytest.mark.parametrize("point", [["--false-alarm", "0.01"], ["--false-tracks", "1"]])
def test_detect_refuses_an_operating_point_with_per_spike(
    point: list[str], model: Path, recording: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Spike lines carry no UAV score: the point was accepted and ignored.
    argv = ["detect", str(recording), "-m", str(model), "--per-spike", *point]
    _one_line_exit_2(capsys, argv, f"{point[0]} sets identification's threshold")


# -- 6. detect: a source named twice, however spelled; what --ray prints --------------------------


def test_detect_finds_a_source_named_twice_however_spelled(
    model: Path,
    recording: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    _no_ray(monkeypatch)
    monkeypatch.chdir(recording.parent)
    link = tmp_path / "link.npz"
    symlink(link, recording)
    for again in ("A.npz", "./A.npz", str(recording), str(link)):
        for ray in ([], ["--ray"]):
            argv = ["detect", "A.npz", again, "-m", str(model), *ray]
            _one_line_exit_2(capsys, argv, "a source is named twice")


def test_detect_help_says_that_ray_prints_the_window_lines(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # Several sources and --ray print one stream's lines (tests/test_ray.py checks them).
    with pytest.raises(SystemExit):
        main(["detect", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "print the same lines led by the stream's name" in text
    assert "one line per spike" not in text


@pytest.mark.parametrize("domain", ["dvs", "sim", "combined"])
def test_build_refuses_a_test_fraction_its_domain_ignores(domain: str, tmp_path: Path) -> None:
    # It built the set and left test_fraction unused, where the CLI refuses --test-fraction.
    out = tmp_path / "d"
    with pytest.raises(ParameterError, match=f"test_fraction splits the real clips: .*{domain}"):
        build(out, domain, test_fraction=0.5, n_test=4, n_train=2)
    with pytest.raises(ParameterError, match="test_fraction splits the real clips"):
        build(out, domain, test_fraction=0.3, n_test=4, n_train=2)  # the default too, when given
    assert not out.exists()
    with pytest.raises(ParameterError, match="test_fraction must be in"):
        build(out, "real", videos=tmp_path, test_fraction=1.5, n_test=4, n_train=2)
    assert not out.exists()


@pytest.mark.parametrize("domain", ["dvs", "sim"])
def test_build_refuses_videos_for_a_domain_that_reads_none(domain: str, tmp_path: Path) -> None:
    # build(..., "dvs", videos=...) built a dvs set and left the videos unread, as the CLI did.
    out = tmp_path / "d"
    with pytest.raises(ParameterError, match=f"videos are real clips: .* not {domain}"):
        build(out, domain, videos=tmp_path, n_test=4, n_train=2)
    assert not out.exists()


# -- detect --start-us: the windows of uavsnn evaluate's streams ---------------------------------


def test_detect_start_us_windows_a_recording_as_the_evaluation_streams_do(
    tmp_path: Path, model: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # detect started its windows at the first event, evaluate's streams (stream_reports) at 0,
    # and detect could not be told otherwise: a clip's windows could not be reproduced.
    import json

    from uavsnn.false_alarms import stream_reports

    events = random_events(400, SMALL_SENSOR)
    events["t"] += np.uint64(14_969) - events["t"][0]  # a clip's first event, not at 0
    path = tmp_path / "clip.npz"
    uio.write_npz(uavsnn.Recording(events, SMALL_SENSOR), path)
    net = Network.load(model)
    wanted = [(r.window, r.t0, r.detected) for r in stream_reports(net, events, SMALL_SENSOR)]

    def detect(*extra: str) -> list[tuple[int, int, bool]]:
        code = main(["detect", str(path), "-m", str(model), "--json", *extra])
        lines = capsys.readouterr().out.splitlines()
        assert code == 0
        return [(d["window"], d["t0"], d["detected"]) for d in map(json.loads, lines)]

    assert detect("--start-us", "0") == wanted
    assert detect()[0][1] == int(events["t"][0]) != wanted[0][1]
    _one_line_exit_2(
        capsys, ["detect", str(path), "-m", str(model), "--start-us", "-5"], "--start-us must be"
    )
