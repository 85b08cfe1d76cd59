"""Sensor sizes: the same scenes in angles on every sensor, datasets at 640×480 and 1280×720,
and sizes that are refused before anything is written."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from uavsnn import DatasetError, ParameterError
from uavsnn.cli import main
from uavsnn.dataset import SENSOR_SIZES, SceneSource, build, load, parse_sensor
from uavsnn.dataset.synthetic import default_source, sim_render_size
from uavsnn.scenes import sample_spec, scene_labels


@pytest.mark.parametrize("seed", [0, 4, 11])
def test_a_scene_is_the_same_in_angles_on_every_sensor(seed: int) -> None:
    base = sample_spec("dvs", "uav", np.random.default_rng(seed))
    _, base_labels = scene_labels(base)
    for w, h in SENSOR_SIZES[1:]:
        spec = sample_spec("dvs", "uav", np.random.default_rng(seed), size=(w, h))
        assert (spec.width, spec.height) == (w, h)
        # The same horizontal field of view: the focal length grows with the width.
        assert spec.focal_px == pytest.approx(base.focal_px * w / 240, rel=1e-9)
        assert spec.tilt_deg == pytest.approx(base.tilt_deg, abs=0.1)
        assert [o.kind for o in spec.objects] == [o.kind for o in base.objects]
        for a, b in zip(spec.objects, base.objects, strict=True):
            assert a.size_m == b.size_m and a.rate_hz == b.rate_hz
            assert np.allclose(a.path.start, b.path.start, rtol=2e-3, atol=2e-3)
            assert np.allclose(a.path.velocity, b.path.velocity, rtol=1e-9)
        # So an object in view on both covers w/240 times the pixels, at the same range.
        _, labels = scene_labels(spec)
        both = (labels["cls"] != "none") & (base_labels["cls"] != "none")
        assert np.allclose(labels["range_m"][both], base_labels["range_m"][both], rtol=1e-3)
        ratio = labels["size_px"][both] / base_labels["size_px"][both]
        assert np.allclose(ratio, w / 240, rtol=5e-3)


def test_default_sources_render_only_what_the_sensor_needs() -> None:
    assert sim_render_size((240, 180)) == (480, 360)
    assert sim_render_size((346, 260)) == (480, 361)
    assert sim_render_size((640, 480)) == (640, 480)
    assert sim_render_size((1280, 720)) == (1280, 720)
    for sensor in SENSOR_SIZES:
        dvs = default_source("dvs", sensor)
        assert dvs.size == sensor and dvs.sensor == sensor and dvs.fps == 500.0
        sim = default_source("sim", sensor)
        assert sim.sensor == sensor and sim.size == sim_render_size(sensor)
    # sim frames are held in memory at once; dvs frames stream through record().
    with pytest.raises(ParameterError, match="GB in memory"):
        SceneSource("sim", (2000, 2000), 60.0, 10.0, sensor=(240, 180))
    SceneSource("dvs", (2000, 2000), 500.0, 1.0, sensor=(2000, 2000))


@pytest.mark.parametrize(
    "text", ["0x180", "240x0", "-1x5", "240", "240x180x3", "64.5x48", "abc", "4097x300", "7x7", ""]
)
def test_bad_sensor_sizes_are_refused(text: str) -> None:
    with pytest.raises(ParameterError, match="sensor"):
        parse_sensor(text)


def test_sensor_sizes_are_parsed() -> None:
    assert parse_sensor("640x480") == (640, 480)
    assert parse_sensor(" 1280X720 ") == (1280, 720)
    assert parse_sensor((346, 260)) == (346, 260)
    with pytest.raises(ParameterError, match="integers"):
        parse_sensor((640.0, 480))
    with pytest.raises(ParameterError, match="integers"):
        parse_sensor((True, 480))


@pytest.mark.parametrize("text", ["0x180", "5000x4000", "big"])
def test_the_cli_refuses_a_bad_sensor_in_one_line_and_writes_nothing(
    text: str, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    out = tmp_path / "set"
    code = main(["dataset", "build", str(out), "--domain", "dvs", "--sensor", text, "--quiet"])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "sensor" in err[0]
    assert not out.exists()


@pytest.mark.parametrize("sensor", [(640, 480), (1280, 720)])
def test_dvs_builds_on_large_sensors(sensor: tuple[int, int], tmp_path: Path) -> None:
    w, h = sensor
    small = SceneSource("dvs", sensor, 100.0, 0.2, sensor=sensor)
    root = build(
        tmp_path / "set", "dvs", n_test=4, n_train=0, seed=2, dvs=small, sensor=f"{w}x{h}"
    ).root
    data = load(root, "test")
    assert data.windows.sensor_size == sensor and len(data) == 4
    assert data.manifest["parameters"]["sensor_size"] == [w, h]
    assert int(data.windows.x.max()) < w and int(data.windows.y.max()) < h
    box = data.box[data.label]
    assert np.all((box[:, 2] <= w) & (box[:, 3] <= h))
    assert np.all(data.size_px[data.label] > 0)
    # A source for another sensor is refused.
    with pytest.raises(ParameterError, match="sensor"):
        build(tmp_path / "other", "dvs", n_test=4, n_train=0, dvs=small)
    assert not (tmp_path / "other").exists()


#: The dark 30×20 square of the 640×512 clips crosses the frame in 12 frames.
PATH = [(100 + 12 * k, 200) for k in range(12)]


def test_real_footage_on_a_640x480_sensor_and_too_small_for_1280x720(
    tmp_path: Path, write_clip: Callable[..., None]
) -> None:
    videos = tmp_path / "videos"
    videos.mkdir()
    for i, cls in enumerate(("DRONE", "DRONE", "BIRD", "BIRD")):
        write_clip(videos, f"V_{cls}_{i + 1:03d}", PATH, size=(640, 512), square=(30, 20), dark=30)
    root = build(
        tmp_path / "real", "real", videos=videos, n_test=2, n_train=0, seed=0, sensor="640x480"
    ).root
    data = load(root, "test")
    assert data.windows.sensor_size == (640, 480)
    # 640×512 crops to its middle 640×480 rows: no scaling, so the box keeps its 30 px.
    assert np.allclose(data.size_px[data.cls != "none"], 30.0)
    assert np.all(np.isnan(data.range_m))
    with pytest.raises(DatasetError, match="smaller than the 1280x720 sensor"):
        build(tmp_path / "big", "real", videos=videos, n_test=2, n_train=0, sensor="1280x720")
    assert not (tmp_path / "big").exists() or not any((tmp_path / "big").iterdir())


def test_the_sensor_benchmark_and_the_raw_cost_script_run(
    capsys: pytest.CaptureFixture, bench_script
) -> None:
    import json

    bench = bench_script("bench_sensor")
    argv = ["--scenes", "1", "--seconds", "0.02", "--sensor", "64x48", "--json"]
    assert bench.main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["64x48"]["frames"] == 10 and out["64x48"]["realtime_factor"] > 0
    assert len(out["machine_before"]["load_average"]) == 3
    raw = bench_script("raw_cost").cost((64, 48), 4, 0.3, 0)
    assert raw["raw_MB_per_1000_windows"] > 0 and raw["raw_events_per_window"] > 0


def test_a_real_dataset_made_as_the_original_pix2nvs_makes_events(
    tmp_path: Path, write_clip: Callable[..., None]
) -> None:
    import json

    videos = tmp_path / "videos"
    videos.mkdir()
    for i, cls in enumerate(("DRONE", "DRONE", "BIRD", "BIRD")):
        write_clip(videos, f"V_{cls}_{i + 1:03d}", PATH, size=(640, 512), square=(30, 20), dark=30)
    out = tmp_path / "real"
    argv = ["dataset", "build", str(out), "--domain", "real", "--videos", str(videos)]
    argv += ["--n-test", "2", "--n-train", "0", "--quiet", "--pix2nvs-compat"]
    assert main(argv) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    params = manifest["parameters"]["sources"][0]["simulator_params"]
    assert params["compat"] is True and params["adaptive"] == 0.05
