"""Bad scenes (a JSON file, a spec built in Python, an option) end in a typed error that names
the field, before any work: quoted numbers, bad variants, huge values, fast rotors, deep
nesting, long scenes, huge textures and lens blurs too wide. What the project draws is not
touched."""

from __future__ import annotations

import copy
import json
import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import one_line_exit_2 as _one_line_exit_2

from uavsnn import SimulationError
from uavsnn.scenes import (
    ObjectSpec,
    PathSpec,
    SceneSpec,
    render,
    sample_spec,
    spec_from_dict,
    spec_to_dict,
)
from uavsnn.scenes import renderer as scene_renderer
from uavsnn.scenes.renderer import _patches, frames, sub_frame_times

Edit = Callable[[dict[str, Any]], None]


@pytest.fixture(scope="module")
def base() -> dict[str, Any]:
    """A valid 64x48 "dvs" scene of 10 frames with a Tello, as JSON data."""
    spec = sample_spec("dvs", "uav", np.random.default_rng(3), duration_s=0.02, size=(64, 48))
    return spec_to_dict(spec)


def _edited(base: dict[str, Any], edit: Edit) -> dict[str, Any]:
    d = copy.deepcopy(base)
    edit(d)
    return d


def _path(d: dict[str, Any]) -> dict[str, Any]:
    path: dict[str, Any] = d["objects"][0]["path"]
    return path


def _object_field(name: str, value: object) -> Edit:
    def edit(d: dict[str, Any]) -> None:
        d["objects"][0][name] = value

    return edit


def _helicopter(variant: object) -> Edit:
    def edit(d: dict[str, Any]) -> None:
        d["objects"][0].update(kind="helicopter", size_m=12.0, rate_hz=5.0, variant=variant)

    return edit


# -- 1. quoted numbers and bad variants -------------------------------------------------------

BAD_FIELDS: list[tuple[str, Edit, str]] = [
    ("start quoted", lambda d: _path(d).update(start=["0", "0", "5"]), "path.start"),
    ("start bool", lambda d: _path(d).update(start=[True, 0, 5]), "path.start"),
    ("velocity quoted", lambda d: _path(d).update(velocity=["1", "0", "0"]), "path.velocity"),
    ("freqs quoted", lambda d: _path(d).update(freqs=["1.5"]), "path.freqs"),
    (
        "amplitudes quoted",
        lambda d: _path(d).update(amplitudes=[["0.1", "0", "0"]]),
        "path.amplitudes",
    ),
    ("room quoted", lambda d: d["background"].update(room_m=["25", "15", "8"]), "room_m"),
    ("pan quoted", lambda d: d.update(pan_deg_s=["0", "0"]), "pan_deg_s"),
    ("color quoted", lambda d: d["objects"][0].update(color=["0.5", 0.5, 0.5]), "color"),
    ("background variant", lambda d: d["background"].update(variant="x"), "background.variant"),
    ("helicopter variant str", _helicopter("x"), "object.variant"),
    ("helicopter variant float", _helicopter(1.5), "object.variant"),
    ("helicopter variant bool", _helicopter(True), "object.variant"),
    ("fps quoted", lambda d: d.update(fps="500"), "fps"),
    ("focus quoted", lambda d: d.update(focus_m="far"), "focus_m"),
    ("size quoted", lambda d: d["objects"][0].update(size_m="0.1"), "size_m"),
    ("level quoted", lambda d: d["lighting"].update(level="1"), "lighting.level"),
    ("freqs not a list", lambda d: _path(d).update(freqs=5), "freqs"),
]


@pytest.mark.parametrize(
    ("edit", "match"), [c[1:] for c in BAD_FIELDS], ids=[c[0] for c in BAD_FIELDS]
)
def test_quoted_numbers_and_bad_variants_are_refused_naming_the_field(
    base: dict[str, Any], edit: Edit, match: str
) -> None:
    # They passed the checks (NumPy reads "5" as 5.0) and crashed while rendering, or were
    # refused as "scene: must be real number, not str".
    with pytest.raises(SimulationError, match=match.replace(".", r"\.")):
        spec_from_dict(_edited(base, edit))


def test_a_bad_json_field_is_one_line_and_writes_nothing(
    base: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene, out = tmp_path / "scene.json", tmp_path / "s.npz"
    for edit, match in ((BAD_FIELDS[0][1], "path.start"), (_helicopter("x"), "variant")):
        scene.write_text(json.dumps(_edited(base, edit)))
        _one_line_exit_2(
            capsys, ["simulate", "--scene", str(scene), "-o", str(out), "--size", "64x48"], match
        )
        assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.json"]


def test_a_json_scenes_size_is_its_own_or_sizes_where_it_gives_none(
    base: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The docs said width and height default to --size: left out, they were refused
    (missing fields); given with another --size, the refusal named a Python call."""
    from uavsnn.cli import main
    from uavsnn.io import read

    scene, out = tmp_path / "scene.json", tmp_path / "s.npz"
    cases = [  # (edit, --size, the sensor recorded)
        (lambda d: [d.pop("width"), d.pop("height")], [], (240, 180)),
        (lambda d: [d.pop("width"), d.pop("height")], ["--size", "64x48"], (64, 48)),
        (lambda d: None, [], (64, 48)),
        (lambda d: None, ["--size", "64x48"], (64, 48)),
    ]
    for edit, size, sensor in cases:
        scene.write_text(json.dumps(_edited(base, edit)))
        assert main(["simulate", "--scene", str(scene), "-o", str(out), *size]) == 0
        capsys.readouterr()
        assert read(out).sensor_size == sensor
    scene.write_text(json.dumps(base))
    line = _one_line_exit_2(
        capsys, ["simulate", "--scene", str(scene), "-o", str(out), "--size", "80x60"], "--size"
    )
    assert line.endswith("the scene's width and height are 64x48, --size 80x60: leave --size "
                         "out to record at the scene's size, or edit the scene's")  # fmt: skip
    scene.write_text(json.dumps(_edited(base, lambda d: d.pop("height"))))
    _one_line_exit_2(capsys, ["simulate", "--scene", str(scene), "-o", str(out)], "and not height")


def test_what_is_checked_is_what_is_drawn(base: dict[str, Any]) -> None:
    """Integers and NumPy arrays are kept as tuples of floats; a sampled scene is unchanged."""
    spec = spec_from_dict(base)
    assert spec_from_dict(json.loads(json.dumps(spec_to_dict(spec)))) == spec
    path = PathSpec("linear", np.array([0, 1, 5]), velocity=[1, 0, 0])  # type: ignore[arg-type]
    assert path.start == (0.0, 1.0, 5.0) and path.velocity == (1.0, 0.0, 0.0)
    assert all(type(v) is float for v in (*path.start, *path.velocity))
    obj = ObjectSpec("bird", 1.0, path, color=np.array([0.5, 0.5, 0.5]))  # type: ignore[arg-type]
    assert obj.color == (0.5, 0.5, 0.5)
    lists: Any = {"amplitudes": [[1, 2, 3]], "freqs": [1], "phases": [0]}
    wobble = PathSpec("hover", (0, 0, 5), **lists)
    assert wobble.amplitudes == ((1.0, 2.0, 3.0),) and wobble.freqs == (1.0,)


# -- 2. huge values ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda d: _path(d).update(start=[1e308, 0, 5]), "path.start"),
        (lambda d: _path(d).update(velocity=[0, -1e12, 0]), "path.velocity"),
        (lambda d: _path(d).update(acceleration=[0, 0, 1e300]), "path.acceleration"),
        (lambda d: d["objects"][0].update(size_m=1e300), "size_m"),
    ],
)
def test_huge_path_and_size_values_are_refused(
    base: dict[str, Any], edit: Edit, match: str
) -> None:
    # A start of 1e308 raised OverflowError while rendering; a size of 1e300 drew nothing and
    # labelled the object as covering the frame.
    with pytest.raises(SimulationError, match=match):
        spec_from_dict(_edited(base, edit))


def test_patches_skip_boxes_that_are_not_finite() -> None:
    inf = math.inf
    assert _patches([0], [(-inf, 0.0, inf, 4.0)], [(1.0, 1.0, 3.0, 3.0)], 8, 8) == []
    assert _patches([0], [(1.0, 1.0, 3.0, 3.0)], [(1.0, 1.0, 3.0, 3.0)], 8, 8) == [
        ((0, 0, 4, 4), [0])
    ]


def test_sampled_scenes_lie_far_within_the_bounds() -> None:
    """The longest sampled scenes (600 s, a ball thrown: it starts 441 km below its midpoint)
    are accepted."""
    for seed in range(4):
        spec = sample_spec("dvs", "ball", np.random.default_rng(seed), duration_s=600, fps=1.0)
        assert spec.n_frames == 600 and max(abs(v) for v in spec.objects[0].path.start) < 1e6


# -- 3. fast rotors ---------------------------------------------------------------------------


def test_a_rotor_rate_beyond_the_bound_is_refused(base: dict[str, Any]) -> None:
    # 3e9 Hz took 30 s for 10 frames of 64x48; 1e15 ran out of memory.
    for rate in (3e9, 1e15):
        with pytest.raises(SimulationError, match="rate_hz"):
            spec_from_dict(_edited(base, _object_field("rate_hz", rate)))


def test_sub_frame_times_take_at_most_one_a_microsecond() -> None:
    sub = sub_frame_times(0, 2000, 10**12, np.random.default_rng(0))
    assert 0 < len(sub) <= 1999 and sub.min() > 0 and sub.max() < 2000
    assert len(sub_frame_times(0, 1, 10**12, np.random.default_rng(0))) == 0
    # Below the bound, the times are the jittered strata they always were.
    for m in (2, 7, 2000):
        rng = np.random.default_rng(m)
        j = np.arange(1, m) + rng.random(m - 1) - 0.5
        want = np.unique(np.round(2000 * j / m).astype(np.int64))
        want = want[(want > 0) & (want < 2000)].astype(np.uint64)
        assert np.array_equal(sub_frame_times(0, 2000, m, np.random.default_rng(m)), want)


def test_sub_frame_samples_of_a_patch_are_bounded_in_bytes(
    base: dict[str, Any], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A rotor at the highest rate takes 240 samples a frame at 500 fps; a patch whose samples
    would exceed MAX_PATCH_BYTES gets fewer."""
    spec = spec_from_dict(_edited(base, lambda d: d["objects"][0].update(rate_hz=1e4)))
    limit = 4_000
    monkeypatch.setattr(scene_renderer, "MAX_PATCH_BYTES", limit, raising=False)
    patches = [p for f in frames(spec, seed=1) for p in f.patches]
    assert patches
    for _, _, times, values in patches:
        assert 0 < len(times) and values.nbytes <= limit


# -- 4. deep nesting --------------------------------------------------------------------------


def test_deeply_nested_json_is_one_line(
    base: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene, out = tmp_path / "deep.json", tmp_path / "s.npz"
    scene.write_text("[" * 100_000 + "]" * 100_000)
    _one_line_exit_2(
        capsys, ["simulate", "--scene", str(scene), "-o", str(out), "--size", "64x48"], "nested"
    )
    deep: Any = [0.0, 0.0]
    for _ in range(900):
        deep = [deep]
    scene.write_text(json.dumps(_edited(base, lambda d: d.update(pan_deg_s=deep))))
    _one_line_exit_2(
        capsys, ["simulate", "--scene", str(scene), "-o", str(out), "--size", "64x48"], "pan_deg_s"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["deep.json"]
    with pytest.raises(SimulationError, match=r"objects\[0\]\.path\.amplitudes"):
        spec_from_dict(_edited(base, lambda d: _path(d).update(amplitudes=[[[0.1, 0.1, 0.1]]])))


# -- 5. long scenes ---------------------------------------------------------------------------


def test_a_scene_of_too_many_frames_is_refused() -> None:
    # 30 million frames of 8x8 passed (their pixels were few): about 50 min and 14 GB.
    with pytest.raises(SimulationError, match="frames"):
        SceneSpec("dvs", 8, 8, fps=100_000.0, duration_s=300.0, focal_px=8.0)
    assert SceneSpec("dvs", 8, 8, fps=1_000.0, duration_s=600.0, focal_px=8.0).n_frames == 600_000
    with pytest.raises(SimulationError, match="memory"):
        SceneSpec("dvs", 1280, 720, 500.0, 5.0, 1000.0)


def test_render_refuses_more_frames_than_it_can_hold() -> None:
    # 90 s at 500 fps on 240x180: render() wanted 7.8 GB of frames.
    spec = sample_spec("dvs", "uav", np.random.default_rng(0), duration_s=90.0)
    with pytest.raises(SimulationError, match="render holds every frame"):
        render(spec, seed=0)


def test_the_preview_draws_its_frames_one_at_a_time(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """It called render() for an 8-frame sheet, which held every frame (a 90 s preview
    needed 7.8 GB); the sheet is the same as render's frames give."""
    import cv2

    from uavsnn.cli import main
    from uavsnn.cli._camera import lens_option, through_lens
    from uavsnn.scenes import contact_sheet

    spec = sample_spec("dvs", "uav", np.random.default_rng(2), duration_s=0.1)
    spec = through_lens(spec, lens_option(None, None), (spec.width, spec.height))
    images, _, labels = render(spec, seed=2)
    expected = contact_sheet(images, labels, count=6, columns=4, scale=2.0)
    # render() now refuses any scene: the preview must not need it.
    monkeypatch.setattr(scene_renderer, "MAX_RENDER_BYTES", 1)
    out = tmp_path / "p.png"
    argv = ["dataset", "preview", str(out), "--duration", "0.1", "--seed", "2", "--frames", "6"]
    assert main(argv) == 0
    np.testing.assert_array_equal(cv2.imread(str(out), cv2.IMREAD_UNCHANGED), expected)


# -- 6. huge textures -------------------------------------------------------------------------


def test_a_narrow_view_on_a_large_sensor_is_refused_up_front(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # cv2.error: Failed to allocate 7744704016 bytes (a 1° view on 640x480: clouds 11,000 px
    # across).
    out = tmp_path / "f.png"
    argv = ["dataset", "preview", str(out), "--fov", "1", "--sensor", "640x480"]
    argv += ["--kind", "aircraft", "--duration", "0.004", "--seed", "0"]
    _one_line_exit_2(capsys, argv, "focal_px")
    assert not out.exists()


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"focal_px": 1e6}, "focal_px"),
        ({"pan_deg_s": (90.0, 90.0), "fps": 1.0, "duration_s": 600.0}, "pan_deg_s"),
        ({"fps": 1.0, "duration_s": 600.0, "focal_px": 1e4, "cloud_speed": 30.0}, "cloud_speed"),
    ],
)
def test_huge_textures_are_refused_naming_the_fields(change: dict[str, Any], match: str) -> None:
    spec = sample_spec("dvs", "empty", np.random.default_rng(1), size=(64, 48), duration_s=0.02)
    background = replace(spec.background, kind="sky", cloud_cover=0.5)
    if "cloud_speed" in change:
        background = replace(background, cloud_speed_deg_s=change.pop("cloud_speed"))
    spec = replace(spec, background=background, **change)
    with pytest.raises(SimulationError, match=match):
        render(spec, seed=0)


# -- 7. lens blur -----------------------------------------------------------------------------


def _one_grid_disk(key: int) -> np.ndarray:
    """The blur disk as the renderer first built it: every sample of its (16·n)² grid at once."""
    radius = key / 16 / 2
    reach = max(math.ceil(radius - 0.5), 0)
    n, sub = 2 * reach + 1, 16
    c = (np.arange(n * sub) + 0.5) / sub - (reach + 0.5)
    inside = (c[:, None] ** 2 + c[None, :] ** 2) <= radius * radius
    cover = inside.reshape(n, sub, n, sub).sum(axis=(1, 3)).astype(np.float64)
    if cover.sum() == 0:
        return np.ones((1, 1), dtype=np.float32)
    return (cover / cover.sum()).astype(np.float32)


def test_the_blur_disk_is_the_same_and_built_in_little_memory() -> None:
    """A blur of hundreds of pixels built a (16·blur)² grid of float64 (740 MB for 600 px);
    the disk is built a row of pixels at a time now, and is the same to the bit."""
    import tracemalloc

    disk = scene_renderer._make_disk
    for key in [*range(0, 16 * 12), 16 * 37 + 5, 16 * 100 + 9, 16 * 150]:
        np.testing.assert_array_equal(disk(key), _one_grid_disk(key), err_msg=f"key {key}")
    tracemalloc.start()
    try:
        kernel = disk(16 * 600)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert kernel.shape == (601, 601) and kernel.sum() == pytest.approx(1.0, abs=1e-4)
    assert peak < 32_000_000, f"{peak / 1e6:.0f} MB"


def _through_lens(base: dict[str, Any], aperture_mm: float, focus_m: float | None) -> SceneSpec:
    return spec_from_dict(
        _edited(base, lambda d: d.update(aperture_mm=aperture_mm, focus_m=focus_m))
    )


def _largest_blur(spec: SceneSpec) -> float:
    """The largest blur (px) of any object at any frame, as the renderer draws it."""
    from uavsnn.scenes.camera import Camera

    times = np.arange(spec.n_frames) / spec.fps
    cam = Camera(spec)
    return max(
        float(spec.blur_px(cam.project(o.path.position(times), times)[1]).max())
        for o in spec.objects
    )


def test_a_lens_blur_beyond_the_bound_is_refused_before_drawing(
    base: dict[str, Any], monkeypatch: pytest.MonkeyPatch
) -> None:
    # An aperture of 500 mm focused at 5 cm blurs the Tello over about 10·focal_px pixels; at
    # focal_px 2000, 20,000 px: _disk asked for a (320,000)² grid (800 GB).
    spec = replace(_through_lens(base, 500.0, 0.05), focal_px=2000.0)
    assert _largest_blur(spec) > 5 * scene_renderer.MAX_BLUR_PX

    def must_not_run(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("drawing began before the refusal")

    monkeypatch.setattr(scene_renderer, "Backdrop", must_not_run)
    monkeypatch.setattr(scene_renderer, "_disk", must_not_run)
    for draw in (
        lambda: next(frames(spec, seed=0)),
        lambda: render(spec, seed=0),
        lambda: scene_renderer.scene_labels(spec),
    ):
        with pytest.raises(SimulationError, match=r"aperture_mm.*MAX_BLUR_PX \(2,048 px\)"):
            draw()


def test_a_blur_below_the_bound_draws_as_before(
    base: dict[str, Any], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The bound refuses a blur above it and changes nothing below it."""
    spec = _through_lens(base, 400.0, None)
    blur = _largest_blur(spec)
    assert 2 < blur < 20
    images, _, labels = render(spec, seed=4)
    monkeypatch.setattr(scene_renderer, "MAX_BLUR_PX", blur * 1.01)
    again, _, labels_again = render(spec, seed=4)
    np.testing.assert_array_equal(again, images)
    np.testing.assert_array_equal(labels_again, labels)
    monkeypatch.setattr(scene_renderer, "MAX_BLUR_PX", blur * 0.99)
    with pytest.raises(SimulationError, match="aperture_mm"):
        render(spec, seed=4)


def test_sampled_scenes_through_a_lens_blur_far_within_the_bound() -> None:
    """No point nearer than NEAR_M (5 cm) is drawn and no lens focuses nearer than 5 cm, so a
    lens blurs by less than focal_px · aperture / 5 cm. At the default views (45-70°) the widest
    lens the command line takes (f/0.5) on each known sensor blurs by 464 px at most (the Gen4's
    1280x720 at 45°); the narrow view of docs/identification.md (18-22° at f/1.4 on 1280x720,
    an insect at 5 cm) by 1,134."""
    from uavsnn.scenes import Lens
    from uavsnn.scenes.camera import NEAR_M, PIXEL_PITCH_UM
    from uavsnn.scenes.spec import NEAR_FOCUS_M

    def most(sensor: tuple[int, int], fov: float, lens: Lens) -> float:
        rng = np.random.default_rng(0)
        spec = sample_spec("dvs", "insect", rng, size=sensor, duration_s=0.004, fov_deg=(fov, fov))
        spec = lens.on(spec, sensor)
        near = spec.focal_px / min(NEAR_M, NEAR_FOCUS_M)
        return float(spec.blur_px(np.array([near, 1e-9])).max())  # the nearest, the farthest

    wide = max(most(sensor, 45.0, Lens(0.5, f)) for sensor in PIXEL_PITCH_UM for f in (None, 0.05))
    assert 460 < wide < scene_renderer.MAX_BLUR_PX / 4
    narrow = most((1280, 720), 18.0, Lens(1.4))
    assert 1_100 < narrow < scene_renderer.MAX_BLUR_PX


def test_a_lens_blur_beyond_the_bound_is_one_line(
    base: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene, out = tmp_path / "lens.json", tmp_path / "s.npz"
    blurred = _edited(base, lambda d: d.update(aperture_mm=500.0, focus_m=0.05, focal_px=2000.0))
    scene.write_text(json.dumps(blurred))
    argv = ["simulate", "--scene", str(scene), "-o", str(out), "--size", "64x48"]
    line = _one_line_exit_2(capsys, argv, "aperture_mm")
    assert "MAX_BLUR_PX (2,048 px)" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lens.json"]
