"""Behaviour of the scene renderer: labels match what is drawn, paths, sizes, light, seeds."""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from uavsnn import ParameterError, SimulationError
from uavsnn.scenes import (
    LABEL_DTYPE,
    OBJECT_KINDS,
    Background,
    Lighting,
    ObjectSpec,
    PathSpec,
    SceneSpec,
    contact_sheet,
    object_shares,
    render,
    sample_spec,
    scene_labels,
)

FOCAL = 220.0


def _scene(
    *objects: ObjectSpec,
    output: str | None = None,
    level: float = 1.0,
    background: Background | None = None,
    duration: float = 0.04,
    fps: float = 500.0,
    noise: float = 0.0,
) -> SceneSpec:
    return SceneSpec(
        domain="dvs",
        width=240,
        height=180,
        fps=fps,
        duration_s=duration,
        focal_px=FOCAL,
        background=background or Background("sky", cloud_cover=0.5, cloud_speed_deg_s=2.0),
        lighting=Lighting(level=level, noise=noise),
        objects=objects,
        tilt_deg=30.0,
        output=output,
    )


def _uav(
    kind: str = "phantom",
    z: float = 6.0,
    velocity: tuple[float, float, float] = (0, 0, 0),
    x: float = 0.0,
) -> ObjectSpec:
    size = 0.29 if kind == "phantom" else 0.098
    return ObjectSpec(
        kind, size, PathSpec("linear", (x, 0.0, z), velocity), rate_hz=120.0, heading_deg=30.0
    )


def _centres(labels: np.ndarray) -> np.ndarray:
    return np.stack([(labels["x0"] + labels["x1"]) / 2, (labels["y0"] + labels["y1"]) / 2], 1)


# -- labels against pixels --------------------------------------------------------------------


@pytest.mark.parametrize("output", ["gray32f", "bgr8"])
@pytest.mark.parametrize("kind", OBJECT_KINDS)
def test_changed_pixels_lie_inside_the_labelled_box(kind: str, output: str) -> None:
    rng = np.random.default_rng(7)
    spec = sample_spec("dvs", kind, rng, duration_s=0.03)
    spec = replace(spec, output=output, lighting=replace(spec.lighting, level=1.0, flicker=0.0))
    frames, _, labels = render(spec, seed=3)
    empty, _, _ = render(replace(spec, objects=()), seed=3)
    diff = np.abs(frames.astype(np.float32) - empty.astype(np.float32))
    if diff.ndim == 4:
        diff = diff.max(axis=3)
    changed = diff > (1.0 if output == "bgr8" else 1e-3)
    assert changed.any(), f"the {kind} drew nothing"
    seen = 0
    for k, lab in enumerate(labels):
        ys, xs = np.nonzero(changed[k])
        if lab["cls"] == "none":
            assert len(xs) == 0, f"frame {k}: pixels changed but no object is labelled"
            continue
        seen += 1
        # Pixel (x, y) covers [x, x+1) × [y, y+1): every changed one must overlap the box
        # (up to the 1/64-pixel grid the vertices are drawn on).
        tol = 0.05
        assert xs.min() + 1 >= lab["x0"] - tol and xs.max() <= lab["x1"] + tol, (k, lab)
        assert ys.min() + 1 >= lab["y0"] - tol and ys.max() <= lab["y1"] + tol, (k, lab)
        assert lab["uav"] == (kind in ("phantom", "tello"))
    assert seen > 0


def test_labels_follow_the_first_visible_uav_then_other_objects() -> None:
    bird = ObjectSpec("bird", 0.6, PathSpec("linear", (-1.0, 0.0, 8.0)), rate_hz=5.0)
    # The drone starts out of view to the right and flies in.
    drone = _uav(z=6.0, x=4.0, velocity=(-40.0, 0.0, 0.0))
    _, _, labels = render(_scene(bird, drone, duration=0.1), seed=0)
    assert labels.dtype == LABEL_DTYPE
    assert labels["cls"][0] == "bird" and not labels["uav"][0]
    assert labels["cls"][-1] == "drone" and labels["uav"][-1]
    switch = int(np.argmax(labels["uav"]))
    assert np.all(labels["uav"][switch:])


# -- paths --------------------------------------------------------------------------------------


def test_a_hovering_uav_keeps_its_box() -> None:
    _, _, labels = render(_scene(_uav(z=5.0)), seed=1)
    c = _centres(labels)
    assert np.all(labels["uav"])
    assert np.ptp(c[:, 0]) < 0.5 and np.ptp(c[:, 1]) < 0.5


def test_a_moving_uavs_box_moves_as_the_path_says() -> None:
    z, v = 6.0, 3.0
    spec = _scene(_uav(z=z, x=-0.8, velocity=(v, 0.0, 0.0)), duration=0.1)
    _, ts, labels = render(spec, seed=1)
    t = ts.astype(np.float64) / 1e6
    c = _centres(labels)
    expected = FOCAL * v * (t - t[0]) / z
    assert np.max(np.abs((c[:, 0] - c[0, 0]) - expected)) < 0.5
    assert np.ptp(c[:, 1]) < 0.5


def test_a_hovering_path_with_jitter_stays_near_its_point() -> None:
    amp = 0.05
    path = PathSpec(
        "hover", (0.0, 0.0, 5.0), amplitudes=((amp, amp, 0.0),), freqs=(3.0,), phases=(0.0,)
    )
    obj = ObjectSpec("tello", 0.098, path, rate_hz=200.0)
    _, ts, labels = render(_scene(obj, duration=0.4, fps=200.0), seed=2)
    c = _centres(labels)
    t = ts.astype(np.float64) / 1e6
    offset = FOCAL * amp * np.sin(2 * np.pi * 3.0 * t) / 5.0
    assert np.max(np.abs((c[:, 0] - c[0, 0]) - offset)) < 0.6
    assert np.ptp(c[:, 0]) > 2.0  # the jitter is visible


def test_path_velocity_is_the_derivative_of_position() -> None:
    path = PathSpec(
        "curved",
        (1.0, -2.0, 10.0),
        (2.0, 0.5, -1.0),
        (0.3, 0.0, 0.2),
        amplitudes=((0.4, 0.1, 0.0), (0.0, 0.2, 0.3)),
        freqs=(0.7, 2.0),
        phases=(0.1, 1.0),
    )
    t = np.linspace(0.0, 2.0, 41)
    h = 1e-6
    numeric = (path.position(t + h) - path.position(t - h)) / (2 * h)
    assert np.allclose(path.velocity_at(t), numeric, atol=1e-5)


# -- sizes and light -------------------------------------------------------------------------


def _width(kind: str, z: float) -> float:
    _, _, labels = render(_scene(_uav(kind, z=z), duration=0.01), seed=0)
    return float(labels["x1"][0] - labels["x0"][0])


def test_a_tello_is_smaller_than_a_phantom_at_the_same_range() -> None:
    for z in (3.0, 8.0):
        assert _width("tello", z) < 0.5 * _width("phantom", z)


@pytest.mark.parametrize("kind", ["phantom", "tello"])
def test_apparent_size_falls_with_range(kind: str) -> None:
    near, far = _width(kind, 3.0), _width(kind, 6.0)
    assert far == pytest.approx(near / 2, rel=0.05)


@pytest.mark.parametrize("output", ["gray32f", "bgr8"])
@pytest.mark.parametrize("background", ["sky", "ground", "hall"])
def test_darker_lighting_lowers_mean_intensity(background: str, output: str) -> None:
    means = []
    for level in (1.0, 0.3, 0.05, 0.01):
        spec = _scene(
            _uav(),
            output=output,
            level=level,
            background=Background(background),
            duration=0.01,
            noise=1.0,
        )
        frames, _, _ = render(spec, seed=4)
        means.append(float(frames.astype(np.float64).mean()))
    assert all(a > b for a, b in itertools.pairwise(means)), means


# -- determinism and formats -------------------------------------------------------------------


@pytest.mark.parametrize("domain", ["dvs", "sim"])
def test_same_seed_same_frames_other_seed_other_texture(domain: str) -> None:
    spec = sample_spec(
        domain,
        "uav",
        np.random.default_rng(5),
        size=(160, 90) if domain == "sim" else None,
        duration_s=0.05,
    )
    spec = replace(spec, background=replace(spec.background, kind="sky", cloud_cover=0.5))
    a = render(spec, seed=11)
    b = render(spec, seed=11)
    c = render(spec, seed=12)
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x, y)
    assert not np.array_equal(a[0], c[0])
    assert np.array_equal(a[2], c[2])  # labels come from the spec, not the seed


def test_frame_formats_and_timestamps() -> None:
    spec = sample_spec(
        "sim", "uav", np.random.default_rng(0), size=(160, 90), fps=30.0, duration_s=0.2
    )
    frames, ts, labels = render(spec, seed=0)
    assert frames.shape == (6, 90, 160, 3) and frames.dtype == np.uint8
    assert ts.dtype == np.uint64 and ts[0] == 0
    assert np.array_equal(ts, np.round(np.arange(6) * 1e6 / 30).astype(np.uint64))
    assert len(labels) == 6
    gray, _, _ = render(replace(spec, output="gray32f"), seed=0)
    assert gray.shape == (6, 90, 160) and gray.dtype == np.float32
    assert 0.0 <= gray.min() and gray.max() <= 255.0


def test_contact_sheet_draws_frames_and_boxes() -> None:
    frames, _, labels = render(_scene(_uav()), seed=0)
    sheet = contact_sheet(frames, labels, count=4, columns=2)
    assert sheet.dtype == np.uint8 and sheet.shape == (2 * 182, 2 * 242, 3)
    with pytest.raises(ParameterError):
        contact_sheet(frames, labels, count=0)


# -- the sampler -------------------------------------------------------------------------------


def _check_uav_shown_mid_clip(seed: int, domain: str) -> None:
    rng = np.random.default_rng(seed)
    # The sampled scene does not depend on fps; at 4 fps the clip's frames are t = 0 and 0.25 s.
    spec = sample_spec(
        domain,
        "uav",
        rng,
        size=(240, 180) if domain == "dvs" else (320, 180),
        fps=4.0,
        duration_s=0.5,
    )
    assert spec.objects[0].is_uav
    timestamps, labels = scene_labels(spec)
    lab = labels[int(np.flatnonzero(timestamps == 250_000)[0])]
    assert lab["uav"], (spec, lab)
    # At least min_object_px (3) sensor pixels: the 4:3 crop of the frame scaled to 240 wide.
    to_sensor = 240 / min(spec.width, spec.height * 4 / 3)
    extent = max(lab["x1"] - lab["x0"], lab["y1"] - lab["y0"]) * to_sensor
    assert extent >= 2.0


@settings(max_examples=25)
@given(seed=st.integers(0, 2**32 - 1), domain=st.sampled_from(["dvs", "sim"]))
# Scenes whose drone the path's wobble once carried out of the frame at mid-clip.
@example(seed=1196, domain="sim")
@example(seed=751, domain="sim")
@example(seed=408, domain="sim")
@example(seed=1613, domain="dvs")
@example(seed=2470, domain="dvs")
@example(seed=3034, domain="dvs")
def test_sampled_uav_scenes_show_the_uav_mid_clip(seed: int, domain: str) -> None:
    _check_uav_shown_mid_clip(seed, domain)


@pytest.mark.parametrize("domain", ["dvs", "sim"])
def test_every_sampled_uav_scene_shows_the_uav_mid_clip(domain: str) -> None:
    # Five of these 600 scenes lost their drone at mid-clip before the wobble was accounted for.
    for seed in range(1600, 1900):
        _check_uav_shown_mid_clip(seed, domain)


@pytest.mark.parametrize("kind", ["uav", "object", "empty", *OBJECT_KINDS])
def test_sampler_kinds(kind: str) -> None:
    specs = [sample_spec("dvs", kind, np.random.default_rng(s)) for s in range(12)]
    for spec in specs:
        if kind == "empty":
            assert spec.objects == ()
        elif kind == "uav":
            assert spec.objects[0].kind in ("phantom", "tello")
        elif kind == "object":
            assert not spec.objects[0].is_uav and all(not o.is_uav for o in spec.objects)
        else:
            assert spec.objects[0].kind == kind
    if kind != "empty":
        ranges = {round(s.objects[0].path.start[2], 3) for s in specs}
        assert len(ranges) > 6  # varied ranges
    assert len({s.background.kind for s in specs} | {round(s.lighting.level, 3) for s in specs}) > 3


def test_sampler_varies_paths_backgrounds_and_light() -> None:
    specs = [sample_spec("sim", "uav", np.random.default_rng(s)) for s in range(40)]
    assert {s.objects[0].path.kind for s in specs} == {"linear", "curved", "hover"}
    assert {s.background.kind for s in specs} == {"sky", "ground", "hall"}
    levels = np.array([s.lighting.level for s in specs])
    assert levels.max() > 0.5 and levels.min() < 0.1
    dark = [sample_spec("dvs", "uav", np.random.default_rng(s)).lighting.level for s in range(40)]
    assert min(dark) < 0.03  # the event camera also sees very dark scenes
    assert {s.fps for s in specs} == {30.0, 60.0}
    assert {s.objects[0].kind for s in specs} == {"phantom", "tello"}


def test_sampler_is_deterministic() -> None:
    a = sample_spec("dvs", "object", np.random.default_rng(3))
    b = sample_spec("dvs", "object", np.random.default_rng(3))
    assert a == b


@pytest.mark.parametrize("domain", ["dvs", "sim"])
def test_object_shares_are_what_object_scenes_draw(domain: str) -> None:
    shares = object_shares(domain)
    assert set(shares) == {"bird", "aircraft", "helicopter", "ball", "insect", "leaf"}
    assert sum(shares.values()) == pytest.approx(1.0)
    n = 3000
    first = [sample_spec(domain, "object", np.random.default_rng(s)).objects[0].kind
             for s in range(n)]  # fmt: skip
    for kind, share in shares.items():
        # Binomial: 4 standard deviations.
        assert abs(first.count(kind) / n - share) < 4 * np.sqrt(share * (1 - share) / n), kind


def test_an_object_kind_draws_its_background_as_object_scenes_do() -> None:
    n = 1500
    drawn = [sample_spec("dvs", "object", np.random.default_rng(s)) for s in range(6000)]
    balls = [s for s in drawn if s.objects[0].kind == "ball"]
    indoor_drawn = np.mean([s.background.kind == "hall" for s in balls])
    given = [
        sample_spec("dvs", "object", np.random.default_rng(s), object_kind="ball") for s in range(n)
    ]
    assert all(s.objects[0].kind == "ball" for s in given)
    indoor_given = np.mean([s.background.kind == "hall" for s in given])
    assert indoor_drawn > 0.6  # mostly indoors, against the 45 % of all dvs scenes
    assert abs(indoor_given - indoor_drawn) < 0.06
    helicopters = [
        sample_spec("dvs", "object", np.random.default_rng(s), object_kind="helicopter")
        for s in range(200)
    ]
    assert all(s.objects[0].kind == "helicopter" for s in helicopters)
    assert all(s.background.kind != "hall" for s in helicopters)
    # A second object now and then, as in any object scene, never a UAV.
    assert 0 < sum(len(s.objects) > 1 for s in given) < n / 4
    assert not any(o.is_uav for s in given for o in s.objects)


def test_bad_object_kinds() -> None:
    rng = np.random.default_rng(0)
    for kind, obj in (("uav", "ball"), ("object", "tello"), ("object", "kite"), ("ball", "ball")):
        with pytest.raises(ParameterError, match="object_kind"):
            sample_spec("dvs", kind, rng, object_kind=obj)
    with pytest.raises(ParameterError, match="domain"):
        object_shares("film")


# -- bad input --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "change",
    [
        {"width": 0},
        {"height": 5000},
        {"fps": math.nan},
        {"fps": 0.0},
        {"duration_s": -1.0},
        {"duration_s": 0.001},  # fewer than two frames
        {"focal_px": 0.0},
        {"domain": "film"},
        {"output": "rgb16"},
        {"tilt_deg": 95.0},
        {"pan_deg_s": (float("inf"), 0.0)},
        {"objects": ("a drone",)},
    ],
)
def test_bad_scene_specs_raise_simulation_errors(change: dict) -> None:
    base = _scene()
    fields = {f: getattr(base, f) for f in base.__dataclass_fields__}
    fields.update(change)
    with pytest.raises(SimulationError):
        SceneSpec(**fields)


def test_bad_parts_raise_simulation_errors() -> None:
    path = PathSpec("linear", (0.0, 0.0, 5.0))
    with pytest.raises(SimulationError):
        ObjectSpec("zeppelin", 1.0, path)
    with pytest.raises(SimulationError):
        ObjectSpec("bird", -1.0, path)
    with pytest.raises(SimulationError):
        ObjectSpec("bird", 1.0, path, color=(2.0, 0.0, 0.0))
    with pytest.raises(SimulationError):
        PathSpec("hover", (0.0, 0.0, math.nan))
    with pytest.raises(SimulationError):
        PathSpec("hover", (0.0, 0.0, 5.0), amplitudes=((0.1, 0.1, 0.1),), freqs=(), phases=())
    with pytest.raises(SimulationError):
        Lighting(level=0.0)
    with pytest.raises(SimulationError):
        Background("desert")
    with pytest.raises(SimulationError):
        Background("hall", camera_height_m=9.0, room_m=(20.0, 10.0, 8.0))


def test_bad_render_and_sampler_arguments() -> None:
    with pytest.raises(SimulationError):
        render("a scene", seed=0)  # type: ignore[arg-type]
    with pytest.raises(SimulationError):
        render(_scene(), seed=-1)
    rng = np.random.default_rng(0)
    with pytest.raises(ParameterError):
        sample_spec("film", "uav", rng)
    with pytest.raises(ParameterError):
        sample_spec("dvs", "zeppelin", rng)
    with pytest.raises(ParameterError):
        sample_spec("dvs", "uav", 42)  # type: ignore[arg-type]
    with pytest.raises(ParameterError):
        sample_spec("dvs", "uav", rng, min_object_px=0.0)


def test_record_gives_events_and_labels_with_sub_frame_patches() -> None:
    """record(): a hovering Tello's rotors are sampled between frames (patches around it),
    the events are a Recording on the sensor, the labels those of render(), the same seed the
    same events; a sensor that is not the scene's size is refused."""
    from uavsnn.events import Recording
    from uavsnn.scenes import record
    from uavsnn.scenes.renderer import frames

    spec = sample_spec("dvs", "uav", np.random.default_rng(3), duration_s=0.04)
    assert any(o.rate_hz > 100 for o in spec.objects)
    got = list(frames(spec, seed=1))
    assert not got[0].patches
    assert any(f.patches for f in got[1:])
    for f in got[1:]:
        for x0, y0, times, values in f.patches:
            assert values.shape[0] == len(times) and values.dtype == np.float32
            assert 0 <= x0 and x0 + values.shape[2] <= spec.width
            assert 0 <= y0 and y0 + values.shape[1] <= spec.height
            assert np.all(np.diff(times.astype(np.int64)) > 0)
    whole, ts, labels = render(spec, seed=1)
    assert np.array_equal(np.stack([f.image for f in got]), whole)
    a = record(spec, sensor=(spec.width, spec.height), seed=5)
    b = record(spec, sensor=(spec.width, spec.height), seed=5)
    assert isinstance(a.recording, Recording) and len(a.recording.events) > 0
    assert np.array_equal(a.recording.events, b.recording.events)
    assert np.array_equal(a.timestamps_us, ts)
    assert np.array_equal(a.labels, labels)
    with pytest.raises(ParameterError, match="sensor"):
        record(spec, sensor=(spec.width + 2, spec.height), seed=5)


def test_a_scene_round_trips_through_json_and_the_cli_records_it(tmp_path: Path) -> None:
    """spec_to_dict / spec_from_dict round-trip a sampled scene through JSON; `uavsnn simulate
    --scene FILE.json` records it (events and the labels beside them), and a bad field is one
    line and exit code 2."""
    import json

    from uavsnn.cli import main
    from uavsnn.scenes import spec_from_dict, spec_to_dict

    spec = sample_spec("dvs", "uav", np.random.default_rng(5), duration_s=0.02)
    text = json.dumps(spec_to_dict(spec))
    assert spec_from_dict(json.loads(text)) == spec
    path = tmp_path / "scene.json"
    path.write_text(text)
    out = tmp_path / "scene.npz"
    assert main(["simulate", "--scene", str(path), "-o", str(out), "--json"]) == 0
    labels = np.load(tmp_path / "scene.labels.npz")
    assert len(labels["labels"]) == spec.n_frames
    assert np.load(out)["events"].shape[0] > 0
    bad = json.loads(text)
    bad["objects"][0]["wings"] = 3
    with pytest.raises(SimulationError, match="wings"):
        spec_from_dict(bad)
    path.write_text(json.dumps(bad))
    assert main(["simulate", "--scene", str(path), "-o", str(out)]) == 2


# -- the field of view ------------------------------------------------------------------------


@pytest.mark.parametrize(("domain", "default"), [("dvs", (45, 70)), ("sim", (35, 70))])
def test_the_field_of_view_is_drawn_from_the_range_given(domain: str, default: tuple) -> None:
    """The default range is the domain's (the same scene as without the argument); a range of
    one value gives that view, and the rest of the scene is drawn from the same numbers."""
    for seed in range(5):
        plain = sample_spec(domain, "uav", np.random.default_rng(seed))
        assert sample_spec(domain, "uav", np.random.default_rng(seed), fov_deg=default) == plain
        assert default[0] <= plain.horizontal_fov_deg <= default[1]
        narrow = sample_spec(domain, "uav", np.random.default_rng(seed), fov_deg=(20, 20))
        assert narrow.horizontal_fov_deg == pytest.approx(20.0)
        assert narrow.lighting == plain.lighting and narrow.background == plain.background
        assert [o.kind for o in narrow.objects] == [o.kind for o in plain.objects]


@pytest.mark.parametrize("fov", [(0.0, 10.0), (30.0, 20.0), (10.0, 200.0), (math.nan, 20.0), "x"])
def test_bad_fields_of_view_raise_parameter_errors(fov: object) -> None:
    with pytest.raises(ParameterError, match="fov_deg"):
        sample_spec("dvs", "uav", np.random.default_rng(0), fov_deg=fov)  # type: ignore[arg-type]
