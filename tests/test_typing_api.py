"""The typed API as a user's checker and program meet it: what the annotations promise
(tonic's 3-tuple sensor sizes, model paths, array-likes, precise results) type-checks under
``mypy --strict``, the names docs/api.md promises are exported, a source's path is read as
``open_source`` reads it, and ``sim.event_frame`` refuses what it cannot draw."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from uavsnn import identify, linear, sim
from uavsnn.errors import EventError, ParameterError
from uavsnn.events import EVENT_DTYPE
from uavsnn.sources import is_live, source_options

# One program using the annotations a typed-API walk found too narrow (a 3-tuple sensor size,
# a model path, a mapping of metadata, a subprocess's stdout, array-likes, None defaults) or
# too loose (Any where the type is known). Never run: only checked.
USER_PROGRAM = """
import subprocess
from pathlib import Path
from types import MappingProxyType
from typing import assert_type

import numpy as np

from uavsnn import identify, linear, trees
from uavsnn.dataset import LabelledWindows
from uavsnn.detector import Detector
from uavsnn.distributed import SERIAL, StreamResult, detect_streams
from uavsnn.driver import StreamDriver, StreamStep
from uavsnn.events import Recording, SensorSizeLike, convert
from uavsnn.false_alarms import AlarmCounts, count_alarms, stream_reports
from uavsnn.grouping import WindowReport
from uavsnn.io import read
from uavsnn.network import Network
from uavsnn.signature import RotorSignature
from uavsnn.sim import event_frame
from uavsnn.sources import FileSource, StdinSource, UdpSource, open_source
from uavsnn.windows import Windows, noise_per_window

TONIC = (240, 180, 2)


def sizes(ev: np.ndarray, net: Network) -> None:
    size: SensorSizeLike = TONIC
    rec = Recording(ev, TONIC, MappingProxyType({"camera": "davis"}))
    w, h = rec.sensor_size
    noise_per_window(0.1, (w, h))
    read("r.csv", sensor_size=TONIC)
    convert(ev, sensor_size=TONIC)
    Detector(net, sensor_size=TONIC)
    FileSource("r.csv", sensor_size=TONIC)
    UdpSource("localhost", 1, sensor_size=TONIC)
    open_source("-", sensor_size=size)
    noise_per_window(0.1, TONIC)
    RotorSignature.for_sensor(TONIC)
    stream_reports(net, ev, TONIC)
    event_frame(ev, TONIC)


def model_paths() -> dict[str, StreamResult]:
    detect_streams(SERIAL, ["a.npz"], Path("model.npz"))
    return detect_streams(SERIAL, ["a.npz"], "model.npz")


def stdin(proc: subprocess.Popen[bytes]) -> StdinSource:
    assert proc.stdout is not None
    return StdinSource(proc.stdout, sensor_size=TONIC)


def labelled(w: Windows, a: np.ndarray) -> LabelledWindows:
    return LabelledWindows(w, a, a, a, a, {}, range_m=None, size_px=None)


def array_likes() -> float:
    identify.threshold_accuracies([0.2, 0.7], [False, True])
    identify.alarm_threshold([0.2, 0.7], [False, True], 0.01)
    linear.fit_logistic([[0.0], [1.0]], [False, True])
    linear.predict_logistic([1.0, 0.0], [[0.5]])
    linear.fit_softmax([[0.0], [1.0]], [0, 1], 2, weights=[1.0, 1.0])
    linear.predict_softmax([[1.0, 0.0], [0.0, 0.0]], [[0.5]])
    trees.fit_trees([[0.0], [1.0]], [False, True], x_tune=[[0.5]], y_tune=[True])
    return identify.best_threshold([0.2, 0.7], [False, True])


def results(step: StreamStep, driver: StreamDriver, result: StreamResult) -> None:
    assert_type(step.found, np.ndarray | list[WindowReport] | None)
    assert_type(driver.flush(), np.ndarray | list[WindowReport])
    assert_type(result.reports, list[WindowReport])
    assert_type(count_alarms([], {}), AlarmCounts)
    assert_type(count_alarms([], {})["track_peaks"], list[float])
"""


def test_the_typed_api_takes_what_the_runtime_takes_and_gives_precise_types(
    tmp_path: Path,
) -> None:
    pytest.importorskip("mypy", reason="mypy (the test extra) checks what a user's checker sees")
    script = tmp_path / "user.py"
    script.write_text(textwrap.dedent(USER_PROGRAM))
    run = subprocess.run(
        [
            sys.executable,
            "-m",
            "mypy",
            "--strict",
            "--no-error-summary",
            f"--cache-dir={tmp_path / 'cache'}",
            str(script),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    errors = [line for line in run.stdout.splitlines() if "user.py" in line]
    assert errors == [], "\n".join(errors)
    assert run.returncode == 0, run.stdout + run.stderr


def test_every_name_of_linear_is_importable_from_identify() -> None:
    # docs/api.md: the linear names are "also importable from uavsnn.identify", and identify
    # re-exports every name of uavsnn.features (MAX_MEASURED_WINDOW_US among them).
    from uavsnn import features
    from uavsnn.identify import labelled, sigmoid

    assert sigmoid is linear.sigmoid and labelled is linear.labelled
    for module in (linear, features):
        for name in module.__all__:
            assert name in identify.__all__
            assert getattr(identify, name) is getattr(module, name)
    assert "MAX_MEASURED_WINDOW_US" in features.__all__
    assert features.MAX_MEASURED_WINDOW_US == features.MAX_RATE_BINS * features.RATE_BIN_US


def test_a_source_given_as_a_path_is_read_as_open_source_reads_it() -> None:
    assert is_live(Path("-"))
    assert not is_live(Path("recording.npz"))
    assert is_live("udp://localhost:3333")
    options = {"sensor_size": (4, 4), "stdin_format": "csv", "realtime": True}
    assert source_options(Path("-"), options) == {"sensor_size": (4, 4), "stdin_format": "csv"}
    assert source_options(Path("r.npz"), options) == {"sensor_size": (4, 4), "realtime": True}
    for bad in (b"-", 3):
        with pytest.raises(ParameterError, match="a source is a path"):
            is_live(bad)  # type: ignore[arg-type]
        with pytest.raises(ParameterError, match="a source is a path"):
            source_options(bad, {})  # type: ignore[arg-type]


def _events(*xy: tuple[int, int]) -> np.ndarray:
    ev = np.zeros(len(xy), dtype=EVENT_DTYPE)
    for i, (x, y) in enumerate(xy):
        ev[i] = (i, x, y, i % 2 == 0)
    return ev


def test_event_frame_takes_tonics_sensor_size() -> None:
    ev = _events((0, 0), (3, 1))
    img = sim.event_frame(ev, (4, 2, 2))
    assert img.shape == (2, 4, 3)
    assert np.array_equal(img, sim.event_frame(ev, (4, 2)))
    assert tuple(img[0, 0]) == (40, 40, 255)  # ON, red
    assert tuple(img[1, 3]) == (255, 150, 40)  # OFF, blue


@pytest.mark.parametrize("size", [(4, 2, 3), (4,), (0, 2), "4x2", (4.5, 2)])
def test_event_frame_refuses_a_bad_sensor_size(size: object) -> None:
    with pytest.raises(ParameterError, match="sensor_size"):
        sim.event_frame(_events((0, 0)), size)  # type: ignore[arg-type]


@pytest.mark.parametrize("xy", [(4, 0), (0, 2)])
def test_event_frame_refuses_an_event_off_the_sensor(xy: tuple[int, int]) -> None:
    with pytest.raises(EventError, match=r"event 1: \(x=\d+, y=\d+\) is outside the 4x2 sensor"):
        sim.event_frame(_events((0, 0), xy), (4, 2))


def test_event_frame_refuses_events_of_another_dtype() -> None:
    with pytest.raises(EventError, match="dtype"):
        sim.event_frame(np.zeros(3), (4, 2))
