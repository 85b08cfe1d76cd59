"""Range and size in the labels: per frame (renderer, real footage), per window, on disk."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from uavsnn import DatasetError
from uavsnn.dataset import boxes_to_sensor, clip_labels, find_clips, label_windows, load
from uavsnn.dataset.format import save_split, write_manifest
from uavsnn.scenes import (
    LABEL_DTYPE,
    Background,
    Lighting,
    ObjectSpec,
    PathSpec,
    SceneSpec,
    render,
    scene_labels,
)

FOCAL = 220.0


def _spec(*objects: ObjectSpec, duration: float = 0.05) -> SceneSpec:
    return SceneSpec(
        domain="dvs",
        width=240,
        height=180,
        fps=200.0,
        duration_s=duration,
        focal_px=FOCAL,
        background=Background("sky", cloud_cover=0.0),
        lighting=Lighting(level=1.0, noise=0.0),
        objects=objects,
        tilt_deg=30.0,
    )


def _drone(start: tuple[float, float, float], velocity=(0.0, 0.0, 0.0)) -> ObjectSpec:
    return ObjectSpec(
        "phantom", 0.29, PathSpec("linear", start, velocity), rate_hz=120.0, heading_deg=30.0
    )


def test_a_rendered_label_carries_the_range_and_the_unclipped_size() -> None:
    # A Phantom receding along a line of sight that is not the optical axis.
    start, v = (0.6, -0.3, 5.0), (0.0, 0.0, 20.0)
    ts, labels = scene_labels(_spec(_drone(start, v)))
    assert labels.dtype == LABEL_DTYPE and np.all(labels["uav"])
    t = ts.astype(np.float64) / 1e6
    expected = np.sqrt(start[0] ** 2 + start[1] ** 2 + (start[2] + v[2] * t) ** 2)
    assert np.allclose(labels["range_m"], expected, rtol=1e-5)
    # Weak perspective: the size in pixels falls as 1/Z, so size·Z is constant.
    z = start[2] + v[2] * t
    product = labels["size_px"] * z
    assert np.ptp(product) < 0.02 * product.mean()
    # The box is within the frame here, so its longer side is the size.
    side = np.maximum(labels["x1"] - labels["x0"], labels["y1"] - labels["y0"])
    assert np.allclose(side, labels["size_px"], rtol=1e-5)
    # The renderer's labels are those scene_labels gives.
    _, _, drawn = render(_spec(_drone(start, v)), seed=0)
    for k in ("range_m", "size_px"):
        assert np.array_equal(drawn[k], labels[k])


def test_a_clipped_object_keeps_its_whole_size_and_empty_frames_have_none() -> None:
    # Centre on the left edge of the frame (u = 0): half of it is outside.
    z = 4.0
    x = -120.0 * z / FOCAL
    _, labels = scene_labels(_spec(_drone((x, 0.0, z))))
    side = np.maximum(labels["x1"] - labels["x0"], labels["y1"] - labels["y0"])
    assert np.all(labels["x0"] == 0.0)
    assert np.all(labels["size_px"] > side + 1.0)
    _, empty = scene_labels(_spec())
    assert np.all(empty["cls"] == "none")
    assert np.all(np.isnan(empty["range_m"])) and np.all(np.isnan(empty["size_px"]))


def test_the_labelled_object_gives_the_range_a_uav_before_other_objects() -> None:
    bird = ObjectSpec("bird", 0.6, PathSpec("linear", (0.5, 0.0, 9.0)), rate_hz=5.0)
    _, labels = scene_labels(_spec(bird, _drone((-0.5, 0.0, 4.0))))
    assert np.all(labels["cls"] == "drone")
    assert np.allclose(labels["range_m"], np.hypot(0.5, 4.0), rtol=1e-5)


def _frames(n: int) -> tuple[np.ndarray, np.ndarray]:
    ts = (np.arange(n) * 10_000).astype(np.uint64)  # 100 fps, frame k stands for ±5 ms
    lab = np.zeros(n, dtype=LABEL_DTYPE)
    lab["cls"], lab["uav"] = "drone", True
    for k, v in zip(("x0", "y0", "x1", "y1"), (10.0, 20.0, 30.0, 40.0), strict=True):
        lab[k] = v
    lab["range_m"] = 10.0 + np.arange(n)
    lab["size_px"] = 100.0 / lab["range_m"]
    return ts, lab


def test_window_range_and_size_are_means_over_the_frames_of_its_box() -> None:
    ts, lab = _frames(50)
    lab["cls"][30:], lab["uav"][30:] = "none", False
    for k in ("x0", "y0", "x1", "y1", "range_m", "size_px"):
        lab[k][30:] = np.nan
    # [95, 135) ms overlaps frames 10..13; [400, 440) ms has no object.
    wl = label_windows(np.array([95_000, 400_000], dtype=np.uint64), 40_000, ts, lab)
    assert wl.cls.tolist() == ["drone", "none"]
    assert wl.range_m[0] == pytest.approx(np.mean([20.0, 21.0, 22.0, 23.0]))
    assert wl.size_px[0] == pytest.approx(np.mean(100.0 / np.array([20.0, 21.0, 22.0, 23.0])))
    assert np.isnan(wl.range_m[1]) and np.isnan(wl.size_px[1])
    assert wl.range_m.dtype == np.float32 and wl.size_px.dtype == np.float32


def test_an_unknown_range_stays_unknown_in_the_window() -> None:
    ts, lab = _frames(20)
    lab["range_m"], lab["size_px"] = np.nan, 7.0
    wl = label_windows(np.array([50_000], dtype=np.uint64), 40_000, ts, lab)
    assert np.isnan(wl.range_m[0]) and wl.size_px[0] == pytest.approx(7.0)


def test_size_follows_the_crop_and_scale_and_range_is_kept() -> None:
    lab = np.zeros(2, dtype=LABEL_DTYPE)
    lab["uav"], lab["cls"] = True, "drone"
    lab["x0"], lab["x1"], lab["y0"], lab["y1"] = [100.0, 0.0], [140.0, 10.0], 100.0, 120.0
    lab["range_m"], lab["size_px"] = 30.0, 40.0
    # 640×480 → 240×180: already 4:3, so only the scale of 3/8 applies.
    out = boxes_to_sensor(lab, (640, 480), (240, 180))
    assert out["size_px"][0] == pytest.approx(15.0)
    assert out["range_m"][0] == pytest.approx(30.0)
    # A box that leaves the frame's crop (800×480 crops 80 px off each side) has no size.
    out = boxes_to_sensor(lab, (800, 480), (240, 180))
    assert out["cls"][1] == "none" and np.isnan(out["size_px"][1]) and np.isnan(out["range_m"][1])


def test_real_footage_has_sizes_from_its_boxes_and_no_range(shared_data: Path) -> None:
    clip = next(c for c in find_clips(shared_data / "svanstrom-dev") if c.uav)
    rows = np.genfromtxt(clip.boxes, delimiter=",", skip_header=1, max_rows=12)
    # The Svanström videos are 640×512: crop to 640×480, then scale by 3/8.
    labels, labelled = clip_labels(clip, 12, (640, 512), (240, 180))
    has = labelled & (labels["cls"] != "none")
    assert has.any()
    assert np.all(np.isnan(labels["range_m"]))
    longer = np.maximum(rows[:, 3], rows[:, 4])[has]
    assert np.allclose(labels["size_px"][has], longer * 240 / 640, rtol=1e-4)


def test_range_and_size_go_through_a_dataset_file(tmp_path: Path) -> None:
    from uavsnn.dataset import SceneSource, build

    root = build(
        tmp_path / "set",
        "dvs",
        n_test=10,
        n_train=0,
        seed=5,
        dvs=SceneSource("dvs", (240, 180), 200.0, 0.3),
    ).root
    data = load(root, "test")
    boxed = data.cls != "none"
    assert np.all(np.isnan(data.size_px[~boxed])) and np.all(np.isnan(data.range_m[~boxed]))
    assert np.all(data.size_px[boxed] > 0) and np.all(data.range_m[boxed] > 0)
    by_id = {r["id"]: r for r in data.manifest["recordings"]}
    for i in np.flatnonzero(data.label):
        ranges = [o["range_m"] for o in by_id[int(data.recording[i])]["objects"]]
        # The manifest gives where each object's path starts; a clip lasts 0.3 s.
        assert min(abs(data.range_m[i] - r) for r in ranges) < 0.3 * 15 + 1
    part = data.select([0, 1])
    assert np.array_equal(part.range_m, data.range_m[:2], equal_nan=True)
    # An old dataset (format 1, without range and size) is refused, with how to rebuild it.
    m = json.loads((root / "manifest.json").read_text())
    m["format_version"] = 1
    (root / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(DatasetError, match=r"format version 1.*rebuild"):
        load(root, "test")
    m["format_version"] = 2
    (root / "manifest.json").write_text(json.dumps(m))
    with np.load(root / "test.npz") as z:
        arrays = {k: z[k] for k in z.files}
    arrays["format_version"] = np.asarray(1)
    np.savez(root / "test.npz", **arrays)
    with pytest.raises(DatasetError, match=r"split file .* format version 1.*rebuild"):
        load(root, "test")
    save_split(root / "test.npz", data)
    assert np.array_equal(load(root, "test").size_px, data.size_px, equal_nan=True)


def test_raw_events_are_what_the_stream_saw_before_and_in_each_window(tmp_path: Path) -> None:
    from uavsnn.dataset import SceneSource, build
    from uavsnn.events import Recording
    from uavsnn.windows import make_windows

    root = build(
        tmp_path / "set",
        "dvs",
        n_test=10,
        n_train=6,
        seed=8,
        dvs=SceneSource("dvs", (240, 180), 200.0, 0.3),
    ).root
    for split in ("test", "train"):
        data = load(root, split)
        raw, w = data.raw, data.windows
        assert raw is not None and raw.before_us == w.length_us == 50_000
        for i in range(len(data)):
            t0 = int(w.t0[i])
            ev = raw.window(i)
            assert len(ev) > 0 and np.all(np.diff(ev["t"].astype(np.int64)) >= 0)
            assert ev["t"].min() >= max(t0 - 50_000, 0) and ev["t"].max() < t0 + 50_000
            # Cutting the raw events again gives the stored window: spikes and PENT's count.
            again = make_windows(
                Recording(ev, (240, 180)), 50_000, 0.0, start_us=t0, end_us=t0 + 50_000
            )
            t, x, y = w.spikes(i)
            t2, x2, y2 = again.spikes(0)
            assert np.array_equal(t, t2) and np.array_equal(x, x2) and np.array_equal(y, y2)
            assert again.n_preceding[0] == w.n_preceding[i]
        # Each event is stored once: the kept events are exactly those some window uses.
        covered = np.zeros(len(raw.events), dtype=bool)
        for a, b in zip(raw.start, raw.stop, strict=True):
            covered[a:b] = True
        assert covered.all()
    # A selection saved and read back keeps every window's raw events, and no others.
    data = load(root, "test")
    part = data.select([1, 7, 3])
    save_split(root / "test.npz", part)
    m = json.loads((root / "manifest.json").read_text())
    m["splits"]["test"]["windows"] = 3
    write_manifest(root, m)  # the split file's hash changes with it
    back = load(root, "test")
    for j in range(3):
        assert np.array_equal(back.raw.window(j), part.raw.window(j))
    assert len(back.raw.events) <= len(data.raw.events)
    with np.load(root / "test.npz") as z:
        arrays = {k: z[k] for k in z.files if k != "raw_stop"}
    np.savez(root / "test.npz", **arrays)
    with pytest.raises(DatasetError, match="raw events but lacks arrays: raw_stop"):
        load(root, "test")
