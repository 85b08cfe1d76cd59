"""``WindowReport.to_dict`` and ``WindowObject.to_dict``: the dict is the JSON line ``uavsnn
detect --json`` prints for the window (same keys, order and values, byte for byte once written),
holds plain Python values only (no NumPy scalar, no NaN) so that ``json.dumps`` takes it, and
refuses class names that are not names."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import SMALL_SENSOR, blob_events, small_config

from uavsnn import Recording
from uavsnn._jsonout import dumps
from uavsnn.cli import main
from uavsnn.detector import Detector
from uavsnn.errors import ParameterError
from uavsnn.grouping import WindowObject, WindowReport
from uavsnn.identify import Identifier
from uavsnn.io import write_npz
from uavsnn.network import Network
from uavsnn.signature import RotorEstimate

CLASSES = ("uav", "bird", "plane")


def _identifier() -> Identifier:
    """An identification model with a class part (three classes)."""
    names = ("log_width", "log_height")
    return Identifier(
        names, np.array([0.5, -0.25, 0.1]), np.zeros(2), np.ones(2), 0.4, 1.0, classes=CLASSES,
        class_coef=np.array([[0.1, 0.2, 0.3], [0.0, -0.1, 0.2], [0.3, 0.1, -0.2]]),
    )  # fmt: skip


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, np.ndarray]:
    path = tmp_path_factory.mktemp("report_dict") / "blob.npz"
    events = blob_events(11, 900)
    write_npz(Recording(events, SMALL_SENSOR), path)
    return path, events


def _model(tmp_path: Path, identified: bool) -> Path:
    net = Network(small_config(), seed=3)
    if identified:
        net.identification = _identifier()
    path = tmp_path / ("ident.npz" if identified else "bare.npz")
    net.save(path)
    return path


def _reports(model: Path, events: np.ndarray) -> tuple[list[WindowReport], tuple[str, ...]]:
    """The windows of ``events`` as detect's detector reports them, and the model's classes."""
    net = Network.load(model)
    det = Detector(net, window_us=3_000, overlap=0.5)
    reports = det.push_windows(events) + det.flush_windows()
    ident = net.identification
    return reports, tuple(ident.classes) if ident is not None else ()


def _plain(value: Any, where: str = "") -> None:
    """Fail unless ``value`` is made of plain Python values (exact types, finite floats)."""
    if isinstance(value, dict):
        assert type(value) is dict, where
        for key, item in value.items():
            assert type(key) is str, f"{where}: key {key!r}"
            _plain(item, f"{where}.{key}")
    elif isinstance(value, list):
        assert type(value) is list, where
        for i, item in enumerate(value):
            _plain(item, f"{where}[{i}]")
    else:
        assert type(value) in (int, float, bool, str, type(None)), f"{where}: {type(value)}"
        if type(value) is float:
            assert np.isfinite(value), where


@pytest.mark.parametrize("identified", [True, False])
def test_to_dict_is_the_line_detect_prints(
    recording, tmp_path: Path, capsys: pytest.CaptureFixture[str], identified: bool
) -> None:
    path, events = recording
    model = _model(tmp_path, identified)
    argv = ["detect", str(path), "--model", str(model), "--window-ms", "3", "--json"]
    assert main([*argv, "--summary-every", "0"]) == 0
    lines = capsys.readouterr().out.splitlines()
    reports, classes = _reports(model, events)
    assert classes == (CLASSES if identified else ())
    assert len(lines) == len(reports) > 0
    for line, report in zip(lines, reports, strict=True):
        d = report.to_dict(classes)
        assert d == json.loads(line)
        assert dumps(d) == line  # the same keys in the same order: byte for byte
        assert json.dumps(d, allow_nan=False) == line
        _plain(d)
    objects = [o for r in reports for o in r.to_dict(classes)["objects"]]
    assert any(o["track_stats"] is not None for o in objects), "the test needs tracks"
    if identified:  # not vacuous: scored objects, with their probabilities by class
        scored = [o for o in objects if o["uav_score"] is not None]
        assert scored and all(list(o["class_probabilities"]) == list(CLASSES) for o in scored)
    else:
        assert all(o["uav_score"] is None and o["class"] is None for o in objects)


def test_to_dict_by_hand_with_a_rotor_and_a_track(recording, tmp_path: Path) -> None:
    """Every field as detect names it, in its order: the rotor rounded as printed, a figure
    that is not finite as null, and probabilities only when the classes name each of them."""
    _, events = recording
    reports, _ = _reports(_model(tmp_path, True), events)
    track = next(o.track for r in reports for o in r.objects if o.track is not None)
    track = replace(track, first_alarm_us=None, turn_rate=float("nan"), speed=2.5)
    o = WindowObject(
        box=(2, 3, 7, 8), spikes=4, uav_score=0.75, class_guess="uav", track_id=9,
        track_confirmed=True, rotor=RotorEstimate(123.456789, 0.123456789, 12, 3, 4, 5, True),
        track=track, track_score=0.625, class_probabilities=(0.5, 0.25, 0.25), track_class="bird",
    )  # fmt: skip
    d = WindowReport(4, 100, 3100, True, reports[0].detections[:0], (o,)).to_dict(CLASSES)
    assert list(d) == ["window", "run", "t0", "t1", "detected", "spikes", "objects"]
    assert (d["window"], d["t0"], d["t1"], d["detected"], d["spikes"]) == (4, 100, 3100, True, 0)
    (got,) = d["objects"]
    assert list(got) == [
        "box", "centre", "spikes", "uav_score", "class", "class_probabilities", "track",
        "track_confirmed", "track_score", "track_class", "track_stats", "rotor",
    ]  # fmt: skip
    assert got == o.to_dict(CLASSES)
    assert got["box"] == [2, 3, 7, 8] and got["centre"] == [4.5, 5.5] and got["spikes"] == 4
    assert got["class_probabilities"] == {"uav": 0.5, "bird": 0.25, "plane": 0.25}
    assert (got["uav_score"], got["class"], got["track"], got["track_confirmed"]) == (
        0.75, "uav", 9, True,
    )  # fmt: skip
    assert (got["track_score"], got["track_class"]) == (0.625, "bird")
    assert got["rotor"] == {"frequency_hz": 123.46, "strength": 0.1235, "pixels": 12}
    stats = got["track_stats"]
    assert list(stats) == [
        "age_us", "hits", "speed_px_s", "velocity_px_s", "straightness", "turn_rate_rad_s",
        "first_alarm_us", "rotor_strength_mean", "activity_measured", "events_per_px_mean",
        "events_per_px_std", "on_balance_mean", "rate_swing_mean",
    ]  # fmt: skip
    assert stats["speed_px_s"] == 2.5 and stats["turn_rate_rad_s"] is None
    assert stats["first_alarm_us"] is None and stats["age_us"] == track.age_us
    json.dumps(d, allow_nan=False)
    # Classes that do not name each probability (a model without a class part): none.
    assert o.to_dict(CLASSES[:2])["class_probabilities"] is None
    assert o.to_dict()["class_probabilities"] is None
    # A rotor not detected, and no rotor, are null; so is everything of a bare object.
    undetected = RotorEstimate(50.0, 0.1, 0, 0, 0, 0, False)
    assert replace(o, rotor=undetected).to_dict()["rotor"] is None
    # detect's text line shows the JSON line's rotor to fewer places.
    from uavsnn.cli._detect_lines import rotor_text

    assert rotor_text(o) == "123.5Hz/0.123/12px"
    assert rotor_text(replace(o, rotor=undetected)) == rotor_text(replace(o, rotor=None)) == "-"
    bare = WindowObject(box=(0, 0, 1, 1), spikes=1).to_dict()
    assert bare["centre"] == [0.5, 0.5]
    assert all(bare[k] is None for k in bare if k not in ("box", "centre", "spikes"))


def test_to_dict_of_numpy_values_is_plain(recording, tmp_path: Path) -> None:
    """NumPy scalars in an object built by hand come out as plain ints, floats, bools and str,
    and NaN as None: json.dumps takes the dict without a default."""
    _, events = recording
    reports, _ = _reports(_model(tmp_path, True), events)
    track = next(o.track for r in reports for o in r.objects if o.track is not None)
    track = replace(
        track, age_us=np.int64(6000), hits=np.uint16(2), speed=np.float32(1.5),
        velocity=(np.float64(1.0), np.float32(-0.5)), first_alarm_us=np.uint64(7),
        events_per_px_mean=np.float64("nan"), activity_measured=np.int32(2),
    )  # fmt: skip
    o = WindowObject(
        box=tuple(np.array([1, 2, 5, 6], dtype=np.uint16)), spikes=np.int64(3),
        uav_score=np.float32(0.5), class_guess=np.str_("uav"), track_id=np.int64(4),
        track_confirmed=np.bool_(False), track=track, track_score=np.float64(0.25),
        class_probabilities=tuple(np.array([0.5, 0.25, 0.25])), track_class=np.str_("bird"),
        rotor=RotorEstimate(
            np.float32(80.0), np.float64(0.5), np.int64(9), 1, 2, 3, np.bool_(True)
        ),
    )  # fmt: skip
    report = WindowReport(
        np.int64(2), np.uint64(10), np.uint64(20), np.bool_(True), reports[0].detections[:0], (o,)
    )
    d = report.to_dict(tuple(np.array(CLASSES)))
    _plain(d)
    assert d["objects"][0]["track_stats"]["events_per_px_mean"] is None
    assert d["objects"][0]["track_stats"]["first_alarm_us"] == 7
    assert d["objects"][0]["rotor"] == {"frequency_hz": 80.0, "strength": 0.5, "pixels": 9}
    assert json.loads(json.dumps(d, allow_nan=False)) == d
    for r in reports:  # and what the detector fills in
        _plain(r.to_dict(CLASSES))


@pytest.mark.parametrize("classes", ["uav", b"uav", 3, [1, 2, 3], ("uav", None)])
def test_to_dict_refuses_classes_that_are_not_names(classes: Any) -> None:
    o = WindowObject(box=(0, 0, 2, 2), spikes=1, class_probabilities=(0.5, 0.25, 0.25))
    report = WindowReport(0, 0, 10, True, np.empty(0), (o,))
    for to_dict in (report.to_dict, o.to_dict):
        with pytest.raises(ParameterError, match=r"classes must be an iterable of class names"):
            to_dict(classes)
    assert o.to_dict(["uav", "bird", "plane"]) == o.to_dict(iter(CLASSES))
