"""The streaming API refuses what it cannot use, with a uavsnn error naming what was expected:
options for another kind of source, an idle flush of a file, the wrong objects handed to the
driver or the window grouper, a text stream as standard input, a downsampling target larger
than the recording; and ``uavsnn info`` recognises a model file."""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import SMALL_SENSOR, blob_events, small_config

from uavsnn import EVENT_DTYPE, ParameterError, ShapeError, UavsnnError
from uavsnn.cli import main
from uavsnn.detector import Detector
from uavsnn.driver import StreamDriver
from uavsnn.grouping import WindowGrouper
from uavsnn.network import WINDOW_DETECTION_DTYPE, Network
from uavsnn.sources import FileSource, StdinSource, UdpSource, open_source


@pytest.fixture(scope="module")
def net() -> Network:
    return Network(small_config())


def _recording(folder: Path, size: tuple[int, int], n: int = 2000) -> Path:
    """An ``.npz`` recording of ``n`` events on a ``size`` sensor."""
    rng = np.random.default_rng(1)
    ev = np.zeros(n, dtype=EVENT_DTYPE)
    ev["t"] = 1_000 + np.cumsum(rng.integers(0, 30, n))
    ev["x"] = rng.integers(0, size[0], n)
    ev["y"] = rng.integers(0, size[1], n)
    path = folder / f"rec{size[0]}x{size[1]}.npz"
    np.savez(path, events=ev, sensor_size=np.array(size))
    return path


# -- 1. options for another kind of source ---------------------------------------------------------


@pytest.mark.parametrize(
    ("option", "applies"),
    [
        ({"udp_format": "bogus"}, "UDP"),
        ({"udp_format": "spif"}, "UDP"),
        ({"max_packets": 1}, "UDP"),
        ({"idle_timeout": 1}, "UDP"),
        ({"stdin_format": "csv"}, "standard input"),
        ({"heartbeat_s": 0.5}, "'-' and UDP"),
    ],
)
def test_open_source_refuses_options_that_do_not_apply_to_a_file(
    tmp_path: Path, option: dict[str, Any], applies: str
) -> None:
    path = _recording(tmp_path, SMALL_SENSOR)
    with pytest.raises(ParameterError, match=f"{next(iter(option))} applies to {applies}"):
        open_source(str(path), **option)


@pytest.mark.parametrize(
    ("option", "applies"),
    [
        ({"realtime": True}, "files"),
        ({"stdin_format": "csv"}, "standard input"),
    ],
)
def test_open_source_refuses_options_that_do_not_apply_to_udp(
    option: dict[str, Any], applies: str
) -> None:
    with pytest.raises(ParameterError, match=f"{next(iter(option))} applies to {applies}"):
        open_source("udp://127.0.0.1:0", sensor_size=SMALL_SENSOR, **option)


@pytest.mark.parametrize(
    "option",
    [{"realtime": True}, {"udp_format": "spif"}, {"max_packets": 3}],
)
def test_open_source_refuses_options_that_do_not_apply_to_standard_input(
    option: dict[str, Any],
) -> None:
    with pytest.raises(ParameterError, match=f"{next(iter(option))} applies to"):
        open_source("-", sensor_size=SMALL_SENSOR, **option)


def test_open_source_takes_every_option_at_its_default_whatever_the_source(
    tmp_path: Path,
) -> None:
    """A caller that spells every option (``uavsnn detect`` does) passes the defaults of the
    options that do not apply: they change nothing, and are taken."""
    defaults: dict[str, Any] = {
        "realtime": False,
        "stdin_format": "packed",
        "udp_format": "t64_x16_y16_on8",
        "max_packets": None,
        "idle_timeout": None,
        "downsample_to": None,
        "heartbeat_s": None,
    }
    path = _recording(tmp_path, SMALL_SENSOR)
    with open_source(str(path), **defaults) as source:
        assert isinstance(source, FileSource) and source.sensor_size == SMALL_SENSOR
    with open_source("udp://127.0.0.1:0", sensor_size=SMALL_SENSOR, **defaults) as source:
        assert isinstance(source, UdpSource)
    assert isinstance(open_source("-", sensor_size=SMALL_SENSOR, **defaults), StdinSource)


def test_the_options_that_apply_are_still_taken(tmp_path: Path) -> None:
    path = _recording(tmp_path, (80, 60))
    with open_source(str(path), realtime=True, downsample_to=SMALL_SENSOR) as source:
        assert isinstance(source, FileSource)
        assert source.realtime and source.sensor_size == SMALL_SENSOR
    with open_source(
        "udp://127.0.0.1:0",
        sensor_size=SMALL_SENSOR,
        udp_format="spif",
        max_packets=2,
        idle_timeout=0.5,
        heartbeat_s=0.1,
    ) as source:
        assert isinstance(source, UdpSource) and source.max_packets == 2
    src = open_source("-", sensor_size=SMALL_SENSOR, stdin_format="csv")
    assert isinstance(src, StdinSource) and src.fmt == "csv"
    # Live sources downsample too, chunk by chunk, from the sensor_size the events come in.
    with open_source("udp://127.0.0.1:0", sensor_size=(80, 60), downsample_to=(40, 30)) as udp:
        assert (udp.sensor_size, udp.camera_size) == ((40, 30), (80, 60))
    src = open_source("-", sensor_size=(80, 60), downsample_to=(40, 30))
    assert (src.sensor_size, src.camera_size) == ((40, 30), (80, 60))
    src = open_source("-", sensor_size=(40, 30), downsample_to=(40, 30))
    assert (src.sensor_size, src.camera_size) == ((40, 30), None)  # nothing to do
    for spec in ("-", "udp://127.0.0.1:0"):
        with pytest.raises(ParameterError, match="downsampling only reduces"):
            open_source(spec, sensor_size=(40, 30), downsample_to=(80, 60))


def test_source_options_keeps_what_applies_to_each_kind() -> None:
    """What a caller opening several kinds of source with one set of options (the Ray
    workers) passes to each."""
    from uavsnn.sources import source_options

    given = {
        "sensor_size": (40, 30),
        "realtime": True,
        "udp_format": "spif",
        "max_packets": 3,
        "idle_timeout": 2.0,
        "downsample_to": (20, 15),
        "heartbeat_s": 0.1,
    }
    assert source_options("a.aedat4", given) == {
        "sensor_size": (40, 30),
        "realtime": True,
        "downsample_to": (20, 15),
    }
    assert source_options("udp://h:1", given) == {
        "sensor_size": (40, 30),
        "udp_format": "spif",
        "max_packets": 3,
        "idle_timeout": 2.0,
        "downsample_to": (20, 15),
        "heartbeat_s": 0.1,
    }
    assert source_options("-", given) == {
        "sensor_size": (40, 30),
        "downsample_to": (20, 15),
        "heartbeat_s": 0.1,
    }
    with pytest.raises(ParameterError, match="no option of open_source: 'fps'"):
        source_options("-", {"fps": 3})


def test_the_stream_driver_refuses_an_idle_flush_for_a_file(tmp_path: Path, net: Network) -> None:
    source = FileSource(_recording(tmp_path, SMALL_SENSOR))
    with pytest.raises(ParameterError, match="idle_flush_s applies to live sources"):
        StreamDriver(source, Detector(net), idle_flush_s=0.5)
    # Without it a file drives as before.
    steps = list(StreamDriver(source, Detector(net)))
    assert steps and all(s.kind == "found" for s in steps)
    # A bad one is named as given (it was named lag_s, the IdleClock's).
    live = StdinSource(io.BytesIO(b""), sensor_size=SMALL_SENSOR, heartbeat_s=0.1)
    with pytest.raises(ParameterError, match="idle_flush_s must be > 0"):
        StreamDriver(live, Detector(net), idle_flush_s=-1)


# -- 2. the wrong objects --------------------------------------------------------------------------


def test_the_window_grouper_refuses_detections_that_are_not_a_detectors(net: Network) -> None:
    det = Detector(net)
    ev = blob_events(0, 100)
    grouper = WindowGrouper.of(det)
    with pytest.raises(ParameterError, match="detections must be"):
        grouper.add(ev[:10], np.zeros(3))
    with pytest.raises(ParameterError, match="detections must be"):
        grouper.advance(10_000, [])  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="detections must be"):
        grouper.finish(None)  # type: ignore[arg-type]
    with pytest.raises(ShapeError, match="1-D"):
        grouper.add(ev[:10], np.zeros((2, 2), WINDOW_DETECTION_DTYPE))
    with pytest.raises(ParameterError, match="events must be"):
        grouper.add(np.zeros(3), det.push(ev[:10]))  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match=r"a uavsnn\.detector\.Detector"):
        WindowGrouper.of(net)  # type: ignore[arg-type]
    # What the detector returns is taken.
    det = Detector(net, window_us=3_000)
    good = WindowGrouper.of(det)
    assert good.add(ev, det.push(ev)) == []
    reports = good.finish(det.flush())
    assert reports and reports[0].detected


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"window_us": 3.5, "step_us": 1}, "window_us must be an integer"),
        ({"window_us": 3, "step_us": "1"}, "step_us must be an integer"),
        ({"window_us": 3, "step_us": 1, "min_detections": None}, "min_detections must be"),
        ({"window_us": 3, "step_us": 1, "start_us": -1}, "start_us must be an integer >= 0"),
        ({"window_us": 0, "step_us": 1}, "window_us must be an integer >= 1"),
    ],
)
def test_the_window_grouper_refuses_arguments_that_are_no_whole_numbers(
    kwargs: dict[str, object], match: str
) -> None:
    # A float or a string was a TypeError or a ValueError, or taken rounded down.
    with pytest.raises(ParameterError, match=match):
        WindowGrouper(**kwargs)  # type: ignore[arg-type]


def test_the_window_grouper_refuses_an_advance_to_no_time(net: Network) -> None:
    det = Detector(net, window_us=3_000)
    grouper = WindowGrouper.of(det)
    ev = blob_events(0, 100)
    grouper.add(ev, det.push(ev))
    for bad in (1.5, "9", -1, 1 << 63):
        with pytest.raises(ParameterError, match="t_us must be"):
            grouper.advance(bad, det.advance(int(ev["t"][-1])))  # type: ignore[arg-type]
        det.reset()
        grouper = WindowGrouper.of(det)
        grouper.add(ev, det.push(ev))


def test_standard_input_refuses_a_text_stream() -> None:
    with pytest.raises(ParameterError, match="binary stream"):
        StdinSource(io.StringIO("1,2,3,1\n"), fmt="csv", sensor_size=SMALL_SENSOR)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="binary stream"):
        StdinSource(b"1,2,3,1\n", fmt="csv", sensor_size=SMALL_SENSOR)  # type: ignore[arg-type]


def test_standard_input_refuses_a_stream_that_reads_text() -> None:
    """A stream that is no ``io.TextIOBase`` but hands out text is refused at its first read."""

    class Texts:
        def read1(self, size: int) -> str:
            return "1,2,3,1\n"

    source = StdinSource(Texts(), fmt="csv", sensor_size=SMALL_SENSOR)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="binary stream"):
        list(source)


def test_the_stream_driver_refuses_what_is_not_a_source_or_a_detector(net: Network) -> None:
    ev = blob_events(0, 100)
    with pytest.raises(ParameterError, match=r"source must be a uavsnn\.sources\.EventSource"):
        StreamDriver([ev], Detector(net))  # type: ignore[arg-type]
    source = StdinSource(io.BytesIO(ev.tobytes()), sensor_size=SMALL_SENSOR)
    with pytest.raises(ParameterError, match=r"detector must be a uavsnn\.detector\.Detector"):
        StreamDriver(source, None)  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match=r"detector must be a uavsnn\.detector\.Detector"):
        StreamDriver(source, net)  # type: ignore[arg-type]


# -- 3. a file's sensor size -----------------------------------------------------------------------


def test_open_source_says_a_sensor_size_must_agree_with_the_files(tmp_path: Path) -> None:
    path = _recording(tmp_path, SMALL_SENSOR)
    with pytest.raises(UavsnnError, match="contradicts"):
        open_source(str(path), sensor_size=(80, 60))
    doc = " ".join((open_source.__doc__ or "").split())
    assert "overrides" not in doc
    assert "must agree with a file's own" in doc


# -- 4. downsampling only reduces ------------------------------------------------------------------


@pytest.mark.parametrize("target", [(80, 60), (40, 31), (41, 30)])
def test_downsampling_to_a_larger_sensor_is_refused(
    tmp_path: Path, target: tuple[int, int]
) -> None:
    path = _recording(tmp_path, SMALL_SENSOR)
    w, h = target
    match = f"40x30.*to {w}x{h}.*only reduces"
    with pytest.raises(ParameterError, match=match):
        open_source(str(path), downsample_to=target)
    with pytest.raises(ParameterError, match=match):
        FileSource(path, downsample_to=target)


def test_the_detect_command_refuses_to_upscale_a_recording(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    Network({**small_config(), "width": 80, "height": 60}).save(tmp_path / "m.npz")
    path = _recording(tmp_path, SMALL_SENSOR)
    argv = ["detect", str(path), "-m", str(tmp_path / "m.npz"), "--downsample"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "only reduces" in err[0] and "80x60" in err[0], err


def test_downsampling_to_the_same_or_a_smaller_sensor_runs(tmp_path: Path) -> None:
    path = _recording(tmp_path, (80, 60))
    assert FileSource(path, downsample_to=(80, 60)).sensor_size == (80, 60)
    assert FileSource(path, downsample_to=(40, 40)).sensor_size == (40, 40)


# -- 5. uavsnn info on a model file ----------------------------------------------------------------


def test_info_summarises_a_model_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "m.npz"
    Network(small_config()).save(path)
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "model" in out and "40x30" in out and "uavsnn train" in out
    assert "conv1" in out and "conv3" in out and "identification" in out
    assert main(["info", str(path), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["format"] == "model" and info["input_size"] == [40, 30]
    assert info["identification"] is None and "no identification" in info["load_note"]
    assert [layer["name"] for layer in info["layers"]] == ["conv1", "conv2", "conv3"]


def test_info_refuses_a_sensor_size_for_a_model(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "m.npz"
    Network(small_config()).save(path)
    assert main(["info", str(path), "--sensor-size", "40x30"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--sensor-size" in err[0] and "model" in err[0], err


def test_info_on_a_recording_is_unchanged(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _recording(tmp_path, SMALL_SENSOR)
    assert main(["info", str(path), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["sensor_size"] == [40, 30] and info["events"] == 2000
