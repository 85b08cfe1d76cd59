"""The lens: near objects blur by the thin lens's disk, far ones stay as a pinhole draws them,
and the scenes, labels and datasets carry it."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from uavsnn import ParameterError, SimulationError
from uavsnn.scenes import (
    PIXEL_PITCH_UM,
    Background,
    Lens,
    Lighting,
    ObjectSpec,
    PathSpec,
    SceneSpec,
    render,
    sample_spec,
    scene_labels,
    spec_from_dict,
    spec_to_dict,
)
from uavsnn.scenes.renderer import _disk

FOCAL = 220.0


def _ball(z: float, x: float = 0.0, size: float | None = None) -> ObjectSpec:
    # A ball whose apparent size is about 30 px whatever its range.
    return ObjectSpec(
        "ball", size or 30.0 * z / FOCAL, PathSpec("linear", (x, 0.0, z)), color=(0.1, 0.1, 0.1)
    )


def _scene(*objects: ObjectSpec, aperture_mm: float = 0.0, focus_m: float | None = None):
    return SceneSpec(
        domain="dvs",
        width=240,
        height=180,
        fps=500.0,
        duration_s=0.004,
        focal_px=FOCAL,
        background=Background("sky", cloud_cover=0.0),
        lighting=Lighting(level=1.0, noise=0.0),
        objects=objects,
        tilt_deg=30.0,
        aperture_mm=aperture_mm,
        focus_m=focus_m,
    )


def _ink(spec: SceneSpec) -> np.ndarray:
    """How much the objects darken each pixel of the first frame (the sky behind, without
    them, minus the frame)."""
    frames, _, _ = render(spec, seed=1)
    empty, _, _ = render(replace(spec, objects=()), seed=1)
    return (empty[0] - frames[0]).astype(np.float64)


def _extent(ink: np.ndarray) -> int:
    """The width in pixels of the columns the objects darken by more than 0.01 levels."""
    cols = np.nonzero((ink > 0.01).any(axis=0))[0]
    return int(cols.max() - cols.min() + 1)


# -- the thin lens ----------------------------------------------------------------------------


def test_blur_is_the_thin_lens_disk() -> None:
    spec = _scene(aperture_mm=4.0)
    z = np.array([0.25, 1.0, 10.0])
    # Focused at infinity: aperture · focal_px / Z.
    np.testing.assert_allclose(spec.blur_px(FOCAL / z), 4e-3 * FOCAL / z)
    # Focused at 1 m: nothing blurs there, and both sides of it blur.
    near = replace(spec, focus_m=1.0).blur_px(FOCAL / z)
    np.testing.assert_allclose(near, 4e-3 * FOCAL * np.abs(1 / z - 1.0), atol=1e-12)
    assert near[1] == 0 and near[0] > 0 and near[2] > 0
    assert np.all(_scene().blur_px(FOCAL / z) == 0), "a pinhole blurs nothing"
    assert spec.blur_px(np.array([0.0]))[0] == 0, "an object not drawn has no blur"


def test_a_lens_takes_its_aperture_from_the_f_number_and_the_sensors_pitch() -> None:
    spec = _scene()
    on = Lens(2.0).on(spec, (240, 180))
    assert on.aperture_mm == pytest.approx(FOCAL * 18.5e-3 / 2.0)
    assert on.focus_m is None
    assert replace(on, aperture_mm=0.0) == spec, "nothing else changes"
    assert Lens(2.0, 5.0, pixel_um=3.0).on(spec, (999, 9)).aperture_mm == pytest.approx(
        FOCAL * 3e-3 / 2.0
    )
    assert set(PIXEL_PITCH_UM) >= {(240, 180), (346, 260), (640, 480), (1280, 720)}
    with pytest.raises(SimulationError, match="pixel pitch"):
        Lens(2.0).on(spec, (300, 200))


@pytest.mark.parametrize(
    "args",
    [
        {"f_number": 0.0},
        {"f_number": math.nan},
        {"f_number": 100.0},
        {"f_number": 2.0, "focus_m": 0.0},
        {"f_number": 2.0, "focus_m": math.inf},
        {"f_number": 2.0, "pixel_um": -1.0},
    ],
)
def test_bad_lenses_raise_simulation_errors(args: dict) -> None:
    with pytest.raises(SimulationError):
        Lens(**args)


@pytest.mark.parametrize(
    "change", [{"aperture_mm": -1.0}, {"aperture_mm": math.nan}, {"focus_m": 0.0}]
)
def test_bad_apertures_and_focus_raise_simulation_errors(change: dict) -> None:
    with pytest.raises(SimulationError):
        replace(_scene(), **change)


@pytest.mark.parametrize("diameter", [0.0, 0.5, 1.0, 1.5, 3.0, 7.3, 20.0])
def test_the_blur_disk_sums_to_one_and_spans_its_diameter(diameter: float) -> None:
    k = _disk(round(diameter * 16))
    assert k.dtype == np.float32
    assert k.sum() == pytest.approx(1.0, abs=1e-5)
    np.testing.assert_allclose(k, k.T)
    np.testing.assert_allclose(k, k[::-1, ::-1])
    if diameter <= 1.0:
        assert k.shape == (1, 1), "a disk inside one pixel spreads nothing"
    else:
        # It reaches the pixels its radius touches, and no further.
        assert k.shape[0] == 2 * math.ceil(diameter / 2 - 0.5) + 1
        assert k[k.shape[0] // 2, 0] > 0


# -- what is drawn ----------------------------------------------------------------------------


def test_a_near_object_blurs_by_the_disk_of_its_range() -> None:
    """A ball 0.3 m away through a 4 mm aperture blurs into a disk 2.9 px across: its ink
    spreads over that many more pixels and keeps its total; the ink of a sharp one does not."""
    ball = _ball(0.3)
    sharp, blurred = _ink(_scene(ball)), _ink(_scene(ball, aperture_mm=4.0))
    blur = float(_scene(aperture_mm=4.0).blur_px(np.array([FOCAL / 0.3]))[0])
    assert blur == pytest.approx(2.93, abs=0.01)
    assert blurred.sum() == pytest.approx(sharp.sum(), rel=1e-3), "blur moves ink, keeps it"
    grown = _extent(blurred) - _extent(sharp)
    assert 2 <= grown <= math.ceil(blur) + 1
    assert blurred.max() < sharp.max(), "the edge softens"
    # Ten times the aperture: a 29 px disk.
    wide = _ink(_scene(ball, aperture_mm=40.0))
    assert _extent(wide) - _extent(sharp) >= 26
    assert wide.sum() == pytest.approx(sharp.sum(), rel=1e-3)


def test_a_far_object_is_drawn_as_a_pinhole_draws_it() -> None:
    """At 50 m the same aperture blurs less than a pixel: frame for frame the pinhole's."""
    scene = _scene(_ball(50.0))
    lens = replace(scene, aperture_mm=4.0)
    assert lens.blur_px(np.array([FOCAL / 50.0]))[0] < 1
    a, _, la = render(scene, seed=2)
    b, _, lb = render(lens, seed=2)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(la, lb)


def test_in_focus_is_sharp_and_out_of_focus_on_both_sides_blurs() -> None:
    ball = _ball(2.0)
    sharp = _ink(_scene(ball))
    focused = _ink(_scene(ball, aperture_mm=40.0, focus_m=2.0))
    np.testing.assert_array_equal(focused, sharp)
    for focus in (0.5, 20.0):
        assert _extent(_ink(_scene(ball, aperture_mm=40.0, focus_m=focus))) > _extent(sharp) + 2


def test_the_label_box_holds_the_blur_and_labels_match_render() -> None:
    ball = _ball(0.3)
    spec = _scene(ball, aperture_mm=40.0)
    _, _, sharp = render(_scene(ball), seed=0)
    _, _, blurred = render(spec, seed=0)
    blur = float(spec.blur_px(np.array([FOCAL / 0.3]))[0])
    # The radius, or the kernel's reach in whole pixels where that is more (here 15 > 14.7).
    grow = max(blur / 2, math.ceil(blur / 2 - 0.5))
    assert grow == 15
    for side, sign in (("x0", -1), ("y0", -1), ("x1", 1), ("y1", 1)):
        assert blurred[side][0] - sharp[side][0] == pytest.approx(sign * grow, abs=1e-3)
    assert blurred["size_px"][0] == pytest.approx(sharp["size_px"][0] + 2 * grow, abs=1e-3)
    # Every darkened pixel lies in the box.
    ink = _ink(spec)
    ys, xs = np.nonzero(ink > 1e-3)
    lab = blurred[0]
    assert xs.min() + 1 >= lab["x0"] and xs.max() <= lab["x1"]
    assert ys.min() + 1 >= lab["y0"] and ys.max() <= lab["y1"]
    _, labels = scene_labels(spec)
    np.testing.assert_array_equal(labels, blurred)


def test_an_object_at_the_frame_edge_blurs_in_from_outside() -> None:
    """A ball whose centre is just off the left edge: the blur brings part of the ink that
    lies outside the frame into it, as a lens would."""
    x = -122.0 / FOCAL * 0.3  # centre 2 px left of the frame
    ball = _ball(0.3, x=x)
    sharp = _ink(_scene(ball))
    blurred = _ink(_scene(ball, aperture_mm=40.0))
    assert blurred.sum() > 0 and sharp.sum() > 0
    assert _extent(blurred) > _extent(sharp)


def test_a_lens_round_trips_through_json() -> None:
    spec = Lens(1.4, 30.0).on(sample_spec("dvs", "uav", np.random.default_rng(3)), (240, 180))
    assert spec_from_dict(spec_to_dict(spec)) == spec


# -- datasets ---------------------------------------------------------------------------------


def test_a_scene_source_with_a_lens_draws_the_same_scene_through_it() -> None:
    from uavsnn.clips import scene_source
    from uavsnn.dataset.synthetic import default_source, scene_spec

    source = default_source("dvs", (240, 180))
    lensed = replace(source, lens=Lens(1.4))
    a, b = scene_spec(source, "uav", 11), scene_spec(lensed, "uav", 11)
    assert b.aperture_mm == pytest.approx(a.focal_px * 18.5e-3 / 1.4)
    assert replace(b, aperture_mm=0.0) == a
    described = lensed.describe()
    assert described["lens"] == {"f_number": 1.4, "focus_m": None, "pixel_um": 18.5}
    assert "lens" not in source.describe()
    again = scene_source(described)
    assert again.lens == Lens(1.4, None, 18.5)
    assert scene_spec(again, "uav", 11) == b, "a manifest's source draws the same scene"
    with pytest.raises(ParameterError, match="dvs domain"):
        replace(default_source("sim", (240, 180)), lens=Lens(1.4))
    with pytest.raises(ParameterError, match="pixel pitch"):
        replace(default_source("dvs", (300, 200)), lens=Lens(1.4))
    with pytest.raises(ParameterError, match="Lens"):
        replace(source, lens=1.4)


def test_the_cli_refuses_a_lens_it_cannot_use(tmp_path) -> None:
    from uavsnn.cli import main

    out = str(tmp_path / "d")
    assert main(["dataset", "build", out, "--domain", "dvs", "--focus-m", "3"]) == 2
    assert main(["dataset", "build", out, "--domain", "sim", "--lens", "1.4"]) == 2
    assert main(["dataset", "build", out, "--domain", "dvs", "--lens", "0"]) == 2
    sensor = ["--sensor", "300x200"]
    assert main(["dataset", "build", out, "--domain", "dvs", "--lens", "1.4", *sensor]) == 2
    assert not (tmp_path / "d").exists()


def test_a_dataset_built_through_a_lens_records_it(tmp_path, capsys) -> None:
    """The manifest's dvs source holds the lens, `dataset info` says so, and the set's
    recordings are the same scenes as without it: the same recordings, objects and light."""
    import json

    from uavsnn.cli import main
    from uavsnn.dataset import SceneSource, build, read_manifest

    source = SceneSource("dvs", (240, 180), 200.0, 0.3)
    args = {"n_test": 8, "n_train": 0, "seed": 3}
    plain = build(tmp_path / "plain", "dvs", dvs=source, **args).root
    lensed = build(tmp_path / "lens", "dvs", dvs=replace(source, lens=Lens(2.0, 40.0)), **args)
    manifest = read_manifest(lensed.root)
    assert manifest["parameters"]["sources"][0]["lens"] == {
        "f_number": 2.0,
        "focus_m": 40.0,
        "pixel_um": 18.5,
    }
    strip = ("events", "windows_used", "usable", "usable_uav", "windows")
    assert [{k: v for k, v in r.items() if k not in strip} for r in manifest["recordings"]] == [
        {k: v for k, v in r.items() if k not in strip} for r in read_manifest(plain)["recordings"]
    ]
    assert main(["dataset", "info", str(lensed.root)]) == 0
    assert "lens f/2 focused at 40 m" in capsys.readouterr().out
    assert main(["dataset", "info", str(lensed.root), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["lens"]["f_number"] == 2.0
    assert main(["dataset", "info", str(plain)]) == 0
    assert "lens" not in capsys.readouterr().out


def test_a_scene_source_draws_its_field_of_view_and_a_manifest_keeps_it() -> None:
    from uavsnn.clips import scene_source
    from uavsnn.dataset.synthetic import default_source, scene_spec

    source = replace(default_source("dvs", (1280, 720)), fov_deg=(18, 22), lens=Lens(1.4))
    spec = scene_spec(source, "object", 5, "insect")
    assert 18 <= spec.horizontal_fov_deg <= 22
    # A longer lens at the same f-number: a wider aperture (focal length / f-number).
    assert spec.aperture_mm == pytest.approx(spec.focal_px * 4.86e-3 / 1.4)
    assert spec.aperture_mm > 8
    described = source.describe()
    assert described["fov_deg"] == [18.0, 22.0]
    assert scene_spec(scene_source(described), "object", 5, "insect") == spec
    assert "fov_deg" not in default_source("dvs", (1280, 720)).describe()
    with pytest.raises(ParameterError, match="fov_deg"):
        replace(source, fov_deg=(50, 40))


def test_the_cli_refuses_a_field_of_view_it_cannot_use(tmp_path) -> None:
    from uavsnn.cli import main

    out = str(tmp_path / "d")
    for fov in ("x", "1,2,3", "0", "50,40"):
        assert main(["dataset", "build", out, "--domain", "dvs", "--fov", fov]) == 2
    assert main(["dataset", "build", out, "--domain", "sim", "--fov", "20"]) == 2
    assert not (tmp_path / "d").exists()


def test_simulate_records_a_scene_through_a_lens_and_a_field_of_view(tmp_path) -> None:
    """`uavsnn simulate --scene KIND --lens --fov`: the sampled scene through that lens (a lens
    focused at 5 cm blurs every object: other events than the pinhole's, the same scene), and
    the options it cannot use are refused with exit code 2."""
    import json

    from uavsnn.cli import main
    from uavsnn.scenes import spec_to_dict

    def simulate(name: str, *extra: str) -> int:
        args = ["simulate", "--scene", "ball", "--duration", "0.02", "--seed", "4"]
        return main([*args, "-o", str(tmp_path / f"{name}.npz"), *extra])

    def events(name: str) -> np.ndarray:
        return np.load(tmp_path / f"{name}.npz")["events"]

    assert simulate("pinhole") == 0
    assert simulate("lens", "--lens", "0.5", "--focus-m", "0.05") == 0
    assert simulate("narrow", "--fov", "20") == 0
    assert not np.array_equal(events("pinhole"), events("lens"))
    assert not np.array_equal(events("pinhole"), events("narrow"))
    assert simulate("bad", "--focus-m", "3") == 2
    assert simulate("bad", "--lens", "0") == 2
    assert simulate("bad", "--fov", "50,40") == 2
    assert simulate("bad", "--lens", "1.4", "--size", "300x200") == 2
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps(spec_to_dict(_scene(_ball(0.3)))))
    base = ["simulate", "--scene", str(scene), "-o", str(tmp_path / "json.npz")]
    assert main([*base, "--fov", "20"]) == 2
    assert main([*base, "--lens", "2"]) == 0
    assert main(["simulate", str(scene), "-o", str(tmp_path / "v.npz"), "--lens", "2"]) == 2
    assert not (tmp_path / "bad.npz").exists()


def test_preview_draws_a_scene_for_a_sensor_through_a_lens(tmp_path, capsys) -> None:
    """`uavsnn dataset preview --sensor --lens --fov`: the sampled scene drawn for that sensor
    (a sheet of its frames at their size), through that lens (each object's blur printed, the
    picture not the pinhole's), and the options it cannot use refused with exit code 2."""
    import cv2

    from uavsnn.cli import main

    def preview(name: str, *extra: str) -> int:
        args = ["dataset", "preview", str(tmp_path / f"{name}.png"), "--kind", "insect"]
        return main([*args, "--duration", "0.02", "--seed", "3", "--frames", "2", *extra])

    assert preview("pinhole", "--sensor", "346x260") == 0
    assert "blur" not in capsys.readouterr().out
    assert preview("lens", "--sensor", "346x260", "--lens", "0.5", "--focus-m", "0.05") == 0
    assert "px)" in capsys.readouterr().out
    pinhole, lensed = (cv2.imread(str(tmp_path / f"{n}.png")) for n in ("pinhole", "lens"))
    assert pinhole.shape == lensed.shape and pinhole.shape[1] >= 2 * 346
    assert not np.array_equal(pinhole, lensed)
    assert preview("narrow", "--fov", "20") == 0
    for bad in (
        ("--focus-m", "3"),
        ("--lens", "0"),
        ("--fov", "50,40"),
        ("--sensor", "300x200", "--lens", "1.4"),
        ("--sensor", "12"),
        ("--domain", "sim", "--lens", "1.4"),
    ):
        assert preview("bad", *bad) == 2, bad
    assert not (tmp_path / "bad.png").exists()
