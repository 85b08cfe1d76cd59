"""Datasets: window labels, splits by recording, balance, manifest, files, real footage."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import symlink
from hypothesis import given
from hypothesis import strategies as st

from uavsnn import DatasetError, ParameterError
from uavsnn.cli import main
from uavsnn.dataset import (
    FORMAT_VERSION,
    SceneSource,
    boxes_to_sensor,
    build,
    clip_labels,
    find_clips,
    label_windows,
    load,
    read_boxes,
    save_split,
)
from uavsnn.dataset.build import check_footage
from uavsnn.dataset.format import write_manifest
from uavsnn.dataset.labels import AMBIGUOUS, OK, UNSCORED
from uavsnn.dataset.real import crop_box
from uavsnn.dataset.synthetic import stratified_object
from uavsnn.distributed import SerialRunner
from uavsnn.scenes import LABEL_DTYPE, object_shares
from uavsnn.sim import crop_to_aspect, probe_video

# Small recordings so that a build takes seconds: 0.3 s at 200 fps for dvs, 1 s at 30 fps for
# sim; windows of 50 ms with 50 % overlap.
DVS = SceneSource("dvs", (240, 180), 200.0, 0.3)
SIM = SceneSource("sim", (320, 240), 30.0, 1.0)


def _small(tmp_path: Path, name: str, domain: str = "dvs", **kw: object) -> Path:
    args: dict = {"n_test": 20, "n_train": 16, "seed": 3, "dvs": DVS, "sim": SIM} | kw
    return build(tmp_path / name, domain, **args).root


@pytest.fixture(scope="module")
def dvs_set(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _small(tmp_path_factory.mktemp("dvs"), "set")


# -- window labels ----------------------------------------------------------------------------


def _frames(n: int, uav: np.ndarray, cls: str = "drone") -> tuple[np.ndarray, np.ndarray]:
    ts = (np.arange(n) * 10_000).astype(np.uint64)  # 100 fps
    lab = np.zeros(n, dtype=LABEL_DTYPE)
    lab["cls"] = np.where(uav, cls, "none")
    lab["uav"] = uav & (cls == "drone")
    for k, v in zip(("x0", "y0", "x1", "y1"), (10.0, 20.0, 30.0, 40.0), strict=True):
        lab[k] = np.where(uav, v + np.arange(n), np.nan)
    return ts, lab


def test_window_is_uav_when_visible_at_least_the_given_fraction() -> None:
    # Frames every 10 ms; each stands for ±5 ms. The UAV is visible in frames 10..29.
    uav = np.zeros(50, dtype=bool)
    uav[10:30] = True
    ts, lab = _frames(50, uav)
    # The UAV is seen from 95 ms to 295 ms. Windows of 40 ms: [100, 140) all of it; [270, 310)
    # 25 ms; [275, 315) 20 ms, exactly half; [280, 320) 15 ms; [60, 100) 5 ms; [300, 340) none.
    t0 = np.array([100, 270, 275, 280, 60, 300], dtype=np.uint64) * 1000
    wl = label_windows(t0, 40_000, ts, lab)
    assert wl.status.tolist() == [OK, OK, OK, AMBIGUOUS, AMBIGUOUS, OK]
    assert wl.label.tolist() == [True, True, True, False, False, False]
    assert wl.cls.tolist() == ["drone", "drone", "drone", "none", "none", "none"]
    assert np.allclose(wl.uav_fraction, [1.0, 25 / 40, 0.5, 15 / 40, 5 / 40, 0.0])
    # The box is the union over the frames that overlap the window: frames 10..14 for the first.
    assert wl.box[0].tolist() == [20.0, 30.0, 44.0, 54.0]
    assert np.all(np.isnan(wl.box[5]))


def test_stricter_fraction_makes_more_windows_ambiguous() -> None:
    uav = np.zeros(50, dtype=bool)
    uav[10:30] = True
    ts, lab = _frames(50, uav)
    t0 = np.arange(0, 450_000, 10_000, dtype=np.uint64)
    loose = label_windows(t0, 40_000, ts, lab, min_fraction=0.25)
    strict = label_windows(t0, 40_000, ts, lab, min_fraction=0.9)
    assert strict.label.sum() < loose.label.sum()
    assert (strict.status == AMBIGUOUS).sum() > (loose.status == AMBIGUOUS).sum()
    assert np.all(strict.label <= loose.label)


def test_windows_with_unlabelled_time_are_unscored() -> None:
    uav = np.ones(50, dtype=bool)
    ts, lab = _frames(50, uav)
    labelled = np.ones(50, dtype=bool)
    labelled[40:] = False  # past the last label row
    t0 = np.array([0, 350_000, 360_000, 480_000], dtype=np.uint64)
    wl = label_windows(t0, 40_000, ts, lab, labelled)
    # [350, 390) ends before frame 40's span starts at 395 ms; [360, 400) does not.
    assert wl.status.tolist() == [OK, OK, UNSCORED, UNSCORED]


def test_other_objects_name_the_negative_windows() -> None:
    bird = np.zeros(50, dtype=bool)
    bird[5:45] = True
    ts, lab = _frames(50, bird, cls="bird")
    wl = label_windows(np.array([100_000, 440_000], dtype=np.uint64), 40_000, ts, lab)
    assert wl.label.tolist() == [False, False]
    assert wl.cls.tolist() == ["bird", "none"]  # the bird leaves: visible 5 of 40 ms


def test_a_box_is_the_union_over_the_frames_that_overlap_the_window() -> None:
    # Frame k stands for [10k - 5, 10k + 5) ms. [95, 135) ms overlaps frames 10..13 only:
    # frame 9's span ends where the window starts and frame 14's starts where it ends.
    ts, lab = _frames(50, np.ones(50, dtype=bool))
    wl = label_windows(np.array([95_000], dtype=np.uint64), 40_000, ts, lab)
    assert wl.label.tolist() == [True]
    assert wl.box[0].tolist() == [20.0, 30.0, 43.0, 53.0]


def test_a_tie_between_other_objects_goes_to_the_first_class_by_name() -> None:
    # In [95, 135) ms a bird and an airplane are each visible 20 ms, half the window.
    ts, lab = _frames(50, np.zeros(50, dtype=bool))
    for frames, name in ((slice(10, 12), "airplane"), (slice(12, 14), "bird")):
        lab["cls"][frames] = name
        for k, v in zip(("x0", "y0", "x1", "y1"), (1.0, 2.0, 3.0, 4.0), strict=True):
            lab[k][frames] = v + (name == "bird")
    wl = label_windows(np.array([95_000], dtype=np.uint64), 40_000, ts, lab)
    assert wl.cls.tolist() == ["airplane"] and wl.label.tolist() == [False]
    assert wl.box[0].tolist() == [1.0, 2.0, 3.0, 4.0]


def test_bad_label_arguments() -> None:
    ts, lab = _frames(10, np.ones(10, dtype=bool))
    with pytest.raises(ParameterError):
        label_windows(ts[:1], 1000, ts, lab, min_fraction=0.0)
    with pytest.raises(ParameterError):
        label_windows(ts[:1], 0, ts, lab)
    with pytest.raises(Exception, match="frame"):
        label_windows(ts[:1], 1000, ts[:5], lab)


# -- synthetic builds -------------------------------------------------------------------------


def test_dvs_build_splits_by_recording_and_balances_the_test_set(dvs_set: Path) -> None:
    test, train = load(dvs_set, "test"), load(dvs_set, "train")
    assert len(test) == 20 and int(test.label.sum()) == 10
    assert len(train) == 16 and int(train.label.sum()) == 8
    assert not set(test.recording.tolist()) & set(train.recording.tolist())
    manifest = test.manifest
    by_id = {r["id"]: r for r in manifest["recordings"]}
    for data, split in ((test, "test"), (train, "train")):
        assert {by_id[int(r)]["split"] for r in data.recording} == {split}
        assert set(data.recording_domains().tolist()) == {"dvs"}
        # Positive windows come from UAV scenes and carry a box on the sensor.
        pos = data.label
        assert {by_id[int(r)]["kind"] for r in data.recording[pos]} == {"uav"}
        assert np.all(data.cls[pos] == "drone")
        box = data.box[pos]
        assert np.all((box[:, 0] >= 0) & (box[:, 2] <= 240) & (box[:, 0] < box[:, 2]))
        assert np.all((box[:, 1] >= 0) & (box[:, 3] <= 180) & (box[:, 1] < box[:, 3]))
        assert np.all(np.isnan(data.box[data.cls == "none"]))
        # Windows of 50 ms start every 25 ms from 0 and end within the recording.
        assert data.windows.length_us == 50_000
        assert np.all(data.windows.t0 % 25_000 == 0)
        assert np.all(data.windows.t0 + 50_000 <= 300_000)


def test_manifest_fields(dvs_set: Path) -> None:
    m = json.loads((dvs_set / "manifest.json").read_text())
    assert m["format"] == "uavsnn-dataset" and m["format_version"] == FORMAT_VERSION
    assert m["domain"] == "dvs" and m["seed"] == 3 and isinstance(m["source"], str)
    p = m["parameters"]
    assert p["window_ms"] == 50.0 and p["overlap"] == 0.5 and p["sensor_size"] == [240, 180]
    assert p["n_test"] == 20 and p["n_train"] == 16 and p["min_visible_fraction"] == 0.5
    assert p["object_scenes"] == "drawn"
    assert p["sources"][0]["simulator_params"]["threshold_on"] > 0
    kept_first: dict[int, int] = {}  # each recording's first UAV window the splits kept
    for name in ("test", "train"):
        s = m["splits"][name]
        data = load(dvs_set, name)
        assert s["file"] == f"{name}.npz" and s["windows"] == len(data)
        assert s["uav"] == int(data.label.sum()) and s["non_uav"] == len(data) - s["uav"]
        assert s["classes"] == data.class_counts()
        assert s["recordings"] == sorted(set(data.recording.tolist()))
        for t0, rec in zip(data.windows.t0[data.label], data.recording[data.label], strict=True):
            kept_first[int(rec)] = min(kept_first.get(int(rec), int(t0)), int(t0))
    used = {r["id"]: r["windows_used"] for r in m["recordings"]}
    total = sum(m["splits"][n]["windows"] for n in ("test", "train"))
    assert sum(used.values()) == total
    for r in m["recordings"]:
        assert r["usable"] <= r["windows"] and r["windows_used"] <= r["usable"]
        assert r["domain"] == "dvs" and r["kind"] in ("uav", "object", "empty")
        # The first UAV window of all the build cut: on the grid, none without a UAV window.
        assert (r["first_uav_us"] is None) == (r["usable_uav"] == 0)
        if r["first_uav_us"] is not None:
            assert r["first_uav_us"] % p["step_us"] == 0
    # No UAV window a split kept starts before it; some split left out its recording's first.
    first = {r["id"]: r["first_uav_us"] for r in m["recordings"]}
    assert kept_first and all(first[r] <= t for r, t in kept_first.items())
    assert any(first[r] < t for r, t in kept_first.items())


def test_same_seed_same_dataset_other_seed_other(dvs_set: Path, tmp_path: Path) -> None:
    again = _small(tmp_path, "again")
    other = _small(tmp_path, "other", seed=4)
    for split in ("test", "train"):
        a, b = np.load(dvs_set / f"{split}.npz"), np.load(again / f"{split}.npz")
        assert set(a.files) == set(b.files)
        for k in a.files:
            assert np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind == "f"), k
    assert not np.array_equal(np.load(dvs_set / "test.npz")["t"], np.load(other / "test.npz")["t"])


@given(
    st.lists(st.floats(0.01, 1.0), min_size=1, max_size=8),
    st.integers(0, 300),
)
def test_stratified_objects_keep_every_kind_within_one_of_its_share(
    weights: list[float], n: int
) -> None:
    shares = {f"k{i}": w for i, w in enumerate(weights)}
    p = np.array(weights) / sum(weights)
    kinds = [stratified_object(shares, j) for j in range(n + 1)]
    for m in range(1, n + 2):
        count = np.array([kinds[:m].count(k) for k in shares])
        assert np.abs(count - m * p).max() < 1.0


def test_stratified_object_rejects_bad_shares() -> None:
    for shares, j in (({}, 0), ({"a": -1.0}, 0), ({"a": 0.0}, 0), ({"a": float("nan")}, 0),
                      ({"a": 1.0}, -1)):  # fmt: skip
        with pytest.raises(ParameterError):
            stratified_object(shares, j)


class _Guessing(SerialRunner):
    """Starts recordings ahead as a cluster does (deferred: a wrong guess costs nothing)."""

    ahead = 4

    def __init__(self) -> None:
        self.submitted: list[tuple] = []

    def submit(self, fn, *args):  # type: ignore[no-untyped-def]
        self.submitted.append(args[2:])
        return super().submit(fn, *args)


def test_a_stratified_split_holds_every_object_kind_in_its_share(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    guessing = _Guessing()
    small = SceneSource("dvs", (96, 72), 200.0, 0.3, sensor=(96, 72))
    args = {"n_test": 2, "n_train": 300, "seed": 5, "dvs": small, "sensor": (96, 72)}
    root = build(tmp_path / "strat", "dvs", runner=guessing, stratify=True, **args).root
    m = json.loads((root / "manifest.json").read_text())
    assert m["parameters"]["object_scenes"] == "stratified"
    train = set(m["splits"]["train"]["recordings"])
    first = [r["objects"][0]["kind"] for r in m["recordings"]
             if r["kind"] == "object" and r["id"] in train]  # fmt: skip
    shares = object_shares("dvs")
    assert len(first) >= 13 and set(first) == set(shares)  # a helicopter every 13 scenes
    for kind, share in shares.items():
        assert abs(first.count(kind) - share * len(first)) < 1.0, kind
    # The guesses started ahead do not change the dataset: the serial build's.
    serial = build(tmp_path / "serial", "dvs", stratify=True, **args).root
    for split in ("test", "train"):
        a, b = np.load(root / f"{split}.npz"), np.load(serial / f"{split}.npz")
        for k in a.files:
            assert np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind == "f"), k
    # ... and were mostly right, object kinds included.
    assert len(guessing.submitted) < 1.3 * len(m["recordings"])
    assert main(["dataset", "info", str(root)]) == 0
    assert "object scenes stratified" in capsys.readouterr().out


def test_round_trip_through_the_file(dvs_set: Path, tmp_path: Path) -> None:
    data = load(dvs_set, "test")
    part = data.select(np.arange(0, len(data), 3))
    (tmp_path / "copy").mkdir()
    (tmp_path / "copy" / "manifest.json").write_text((dvs_set / "manifest.json").read_text())
    save_split(tmp_path / "copy" / "test.npz", part)
    manifest = json.loads((tmp_path / "copy" / "manifest.json").read_text())
    manifest["splits"]["test"]["windows"] = len(part)
    # write_manifest records the new file's hash (a hand-copied manifest would not match it).
    write_manifest(tmp_path / "copy", manifest)
    back = load(tmp_path / "copy", "test")
    for name in ("t0", "offsets", "t", "x", "y", "n_preceding"):
        assert np.array_equal(getattr(back.windows, name), getattr(part.windows, name))
    assert np.array_equal(back.label, part.label) and np.array_equal(back.cls, part.cls)
    assert np.array_equal(back.recording, part.recording)
    assert np.array_equal(back.box, part.box, equal_nan=True)
    assert back.windows.sensor_size == (240, 180) and back.windows.length_us == 50_000
    # Plain arrays: NumPy reads the file without pickle, strings are fixed-width unicode.
    with np.load(tmp_path / "copy" / "test.npz", allow_pickle=False) as z:
        assert z["cls"].dtype.kind == "U" and z["box"].shape == (len(part), 4)


def test_sim_and_combined_builds(tmp_path: Path) -> None:
    sim = _small(tmp_path, "sim", "sim", n_test=10, n_train=10)
    data = load(sim, "test")
    assert len(data) == 10 and int(data.label.sum()) == 5
    assert set(data.recording_domains().tolist()) == {"sim"}
    combined = _small(tmp_path, "combined", "combined", n_test=10, n_train=20)
    test, train = load(combined, "test"), load(combined, "train")
    assert set(test.recording_domains().tolist()) == {"dvs"}
    domains = train.recording_domains()
    assert set(domains.tolist()) == {"dvs", "sim"}
    assert (domains == "dvs").sum() == (domains == "sim").sum() == 10
    assert not set(test.recording.tolist()) & set(train.recording.tolist())
    # The combined test set is the dvs domain's test set for the same seed.
    alone = _small(tmp_path, "dvs-alone", "dvs", n_test=10, n_train=0)
    assert np.array_equal(np.load(combined / "test.npz")["t"], np.load(alone / "test.npz")["t"])
    with pytest.raises(DatasetError, match="no split 'train'"):
        load(alone, "train")


# -- real footage (svanström layout) ---------------------------------------------------------


@pytest.fixture(scope="module")
def videos(tmp_path_factory: pytest.TempPathFactory, write_clip: Callable[..., None]) -> Path:
    folder = tmp_path_factory.mktemp("videos")
    n = 45
    for i, cls in enumerate(("DRONE", "DRONE", "BIRD", "BIRD", "AIRPLANE")):
        path = [(40 + 5 * k + 7 * i, 60 + 2 * k) for k in range(n)]
        boxes: list[tuple[int, int] | None] = list(path)
        if i == 0:
            boxes[20:25] = [None] * 5  # the target is lost for a moment
        write_clip(folder, f"V_{cls}_{i + 1:03d}", boxes, rows=n - 6 if i == 0 else n)
    (folder / "notes.txt").write_text("not a clip")
    return folder


def test_find_clips_reads_the_class_from_the_name(videos: Path) -> None:
    clips = find_clips(videos)
    assert [c.name for c in clips] == [
        "V_AIRPLANE_005",
        "V_BIRD_003",
        "V_BIRD_004",
        "V_DRONE_001",
        "V_DRONE_002",
    ]
    assert [c.uav for c in clips] == [False, False, False, True, True]
    assert [c.cls for c in clips] == ["airplane", "bird", "bird", "drone", "drone"]


def test_real_build_labels_scores_and_splits(videos: Path, tmp_path: Path) -> None:
    root = build(tmp_path / "real", "real", videos=videos, n_test=10, n_train=None, seed=1).root
    test, train = load(root, "test"), load(root, "train")
    assert len(test) == 10 and int(test.label.sum()) == 5
    assert not set(test.recording.tolist()) & set(train.recording.tolist())
    by_id = {r["id"]: r for r in test.manifest["recordings"]}
    names = {by_id[int(r)]["name"] for r in np.concatenate([test.recording, train.recording])}
    assert names <= {c.name for c in find_clips(videos)}
    # Each class keeps at least one clip for testing.
    test_names = {r["name"] for r in by_id.values() if r["split"] == "test"}
    assert {n.split("_")[1] for n in test_names} == {"DRONE", "BIRD", "AIRPLANE"}
    # Without n_train every usable window of the train clips is kept, labelled by its clip.
    for data in (test, train):
        kinds = np.array([by_id[int(r)]["kind"] for r in data.recording])
        assert np.all(data.label <= (kinds == "drone"))
        assert np.all(data.cls[~data.label] != "drone")
    train_ids = {int(r) for r in train.recording}
    assert len(train) == sum(by_id[i]["usable"] for i in train_ids)
    # V_DRONE_001 has rows for frames 1..39 only: no window reaches past frame 39's span.
    first = next(i for i, r in by_id.items() if r["name"] == "V_DRONE_001")
    seen = 0
    for data in (test, train):
        t0 = data.windows.t0[data.recording == first]
        seen += len(t0)
        assert np.all(t0 + 50_000 <= 38 * 1e6 / 30 + 1e6 / 60)
    assert seen > 0
    # The events of UAV windows lie around the labelled box (grown by the square's motion in
    # one frame, 3.75 sensor pixels): the clip is a dark square moving over a plain sky.
    shares = []
    for data in (test, train):
        for i in np.flatnonzero(data.label):
            _, x, y = data.windows.spikes(int(i))
            x0, y0, x1, y1 = data.box[i] + np.array([-4, -4, 4, 4])
            assert len(x) > 0
            shares.append(np.mean((x + 1 >= x0) & (x <= x1) & (y + 1 >= y0) & (y <= y1)))
    assert min(shares) > 0.7 and np.mean(shares) > 0.9, shares


def test_real_boxes_follow_the_crop_and_scale(videos: Path) -> None:
    clip = next(c for c in find_clips(videos) if c.name == "V_DRONE_002")
    labels, labelled = clip_labels(clip, 45, (320, 256), (240, 180))
    assert labelled.all() and labels["uav"].all()
    # 320×256 crops to the centred 320×240 (8 rows off the top), then scales by 3/4.
    x, y = 40 + 7, 60
    assert labels[0]["x0"] == pytest.approx(x * 0.75)
    assert labels[0]["y0"] == pytest.approx((y - 8) * 0.75)
    assert labels[0]["x1"] - labels[0]["x0"] == pytest.approx(9.0)


@given(
    w=st.integers(16, 4000), h=st.integers(16, 4000), sw=st.integers(8, 640), sh=st.integers(8, 640)
)
def test_crop_box_is_the_crop_the_simulator_takes(w: int, h: int, sw: int, sh: int) -> None:
    xs = np.broadcast_to(np.arange(w)[None, :], (h, w))
    ys = np.broadcast_to(np.arange(h)[:, None], (h, w))
    cx = crop_to_aspect(xs, sw / sh)
    cy = crop_to_aspect(ys, sw / sh)
    assert crop_box((w, h), (sw, sh)) == (int(cx[0, 0]), int(cy[0, 0]), cx.shape[1], cy.shape[0])


def test_boxes_leaving_the_crop_are_not_visible() -> None:
    lab = np.zeros(3, dtype=LABEL_DTYPE)
    lab["uav"], lab["cls"] = True, "drone"
    # In the cropped-off left strip of a 400×180 frame, straddling its edge, inside.
    lab["x0"], lab["x1"] = [10.0, 75.0, 150.0], [20.0, 90.0, 160.0]
    lab["y0"], lab["y1"] = 50.0, 60.0
    out = boxes_to_sensor(lab, (400, 180), (240, 180))
    assert out["uav"].tolist() == [False, True, True]
    assert out["cls"].tolist() == ["none", "drone", "drone"]
    assert out["x0"][1] == 0.0 and out["x1"][1] == pytest.approx(10.0)


def test_svanstrom_clip_labels_match_its_csv(shared_data: Path) -> None:
    folder = shared_data / "svanstrom-dev"
    clip = next(c for c in find_clips(folder) if c.uav)
    info = probe_video(clip.video)
    n = 12
    labels, labelled = clip_labels(clip, n, (info.width, info.height), (240, 180))
    rows = np.genfromtxt(clip.boxes, delimiter=",", skip_header=1, max_rows=n)
    # The crop and scale, found independently: crop an image of its own coordinates.
    aspect = 240 / 180
    xs = crop_to_aspect(
        np.broadcast_to(np.arange(info.width)[None, :], (info.height, info.width)), aspect
    )
    ys = crop_to_aspect(
        np.broadcast_to(np.arange(info.height)[:, None], (info.height, info.width)), aspect
    )
    ox, oy = xs[0, 0], ys[0, 0]
    sx, sy = 240 / xs.shape[1], 180 / ys.shape[0]
    assert labelled.all()
    for k in range(n):
        frame, x, y, w, h = rows[k]
        assert frame == k + 1
        if np.isnan(x):
            assert labels[k]["cls"] == "none" and not labels[k]["uav"]
            continue
        assert labels[k]["uav"] and labels[k]["cls"] == "drone"
        expected = [(x - ox) * sx, (y - oy) * sy, (x + w - ox) * sx, (y + h - oy) * sy]
        expected = np.clip(expected, 0, [240, 180, 240, 180])
        got = [labels[k][f] for f in ("x0", "y0", "x1", "y1")]
        assert np.allclose(got, expected, atol=1e-3)
    # Frames past the last row are unlabelled.
    n_rows = len(np.genfromtxt(clip.boxes, delimiter=",", skip_header=1))
    _, tail = clip_labels(clip, n_rows + 3, (info.width, info.height), (240, 180))
    assert tail[:n_rows].all() and not tail[n_rows:].any()


# -- bad input --------------------------------------------------------------------------------


def test_bad_build_arguments_raise_parameter_errors(tmp_path: Path) -> None:
    cases = [
        {"domain": "film"},
        {"domain": "real"},  # no videos
        {"n_test": 7},
        {"n_test": 0},
        {"n_train": -1},
        {"window_ms": 0.0},
        {"window_ms": float("nan")},
        {"overlap": 1.0},
        {"seed": -1},
        {"min_fraction": 0.0},
        {"window_ms": 500.0},  # longer than the 0.3 s recordings
        {"n_train": None},  # "all windows" is only for real footage
        {"domain": "real", "videos": tmp_path, "stratify": True},  # no rendered scenes
    ]
    for i, case in enumerate(cases):
        args = {"domain": "dvs", "dvs": DVS, "n_test": 4, "n_train": 0} | case
        with pytest.raises(ParameterError):
            build(tmp_path / f"bad{i}", **args)


def test_a_refused_build_leaves_no_folder_nor_the_folders_above_it(
    tmp_path: Path, videos: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Refused arguments: checked before any folder is made.
    argv = ["dataset", "build", str(tmp_path / "a" / "b" / "set"), "--domain", "dvs"]
    assert main([*argv, "--n-test", "-1"]) == 2
    assert "n_test must be an even integer >= 2, got -1" in capsys.readouterr().err
    assert not (tmp_path / "a").exists()
    for bad in ({"n_test": -1}, {"window_ms": 0.0}, {"sensor": "big"}, {"n_train": None}):
        args = {"dvs": DVS, "n_test": 4, "n_train": 0} | bad
        with pytest.raises(ParameterError):
            build(tmp_path / "c" / "d" / "set", "dvs", **args)
        assert not (tmp_path / "c").exists()
    # A build that fails once writing: the folders it made go, a folder that was there stays.
    (tmp_path / "keep").mkdir()
    with pytest.raises(DatasetError, match="cannot balance"):
        build(tmp_path / "keep" / "e" / "set", "real", videos=videos, n_test=2000, n_train=0)
    assert [p.name for p in tmp_path.iterdir()] == ["keep"]
    assert not any((tmp_path / "keep").iterdir())


def test_build_refuses_a_non_empty_folder(dvs_set: Path, tmp_path: Path) -> None:
    (tmp_path / "keep.txt").write_text("mine")
    with pytest.raises(DatasetError, match="not empty"):
        build(tmp_path, "dvs", dvs=DVS, n_test=4, n_train=0)
    with pytest.raises(DatasetError, match="not a dataset"):
        build(tmp_path, "dvs", dvs=DVS, n_test=4, n_train=0, overwrite=True)
    assert (tmp_path / "keep.txt").read_text() == "mine"


def drones_only(tmp_path: Path, videos: Path) -> Path:
    """A folder of the UAV clips of ``videos`` alone (links to them)."""
    drones = tmp_path / "drones"
    drones.mkdir()
    for c in find_clips(videos):
        if c.uav:
            symlink(drones / c.video.name, c.video)
            symlink(drones / c.boxes.name, c.boxes)
    return drones


def test_bad_footage_raises_dataset_errors(tmp_path: Path, videos: Path) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(DatasetError, match="no labelled videos"):
        find_clips(empty)
    with pytest.raises(DatasetError, match="does not exist"):
        find_clips(tmp_path / "nowhere")
    lonely = tmp_path / "lonely"
    lonely.mkdir()
    (lonely / "V_DRONE_001.mp4").write_bytes((videos / "V_DRONE_001.avi").read_bytes())
    with pytest.raises(DatasetError, match="no box file"):
        find_clips(lonely)
    # Only drones (a few windows where the target is lost are all the non-UAV windows there
    # are): the test set cannot be balanced.
    drones = drones_only(tmp_path, videos)
    with pytest.raises(DatasetError, match="cannot balance"):
        build(tmp_path / "out", "real", videos=drones, n_test=40, n_train=0)
    with pytest.raises(DatasetError, match="does not exist"):
        build(tmp_path / "out2", "real", videos=tmp_path / "nowhere", n_test=10)


def test_check_footage_plans_as_a_real_build_without_decoding(tmp_path: Path, videos: Path) -> None:
    assert check_footage(videos, n_test=10, n_train=None, seed=3) == 5
    drones = drones_only(tmp_path, videos)
    # What build refuses of this footage (test_bad_footage_raises_dataset_errors), refused here.
    with pytest.raises(DatasetError, match="cannot balance the real test pool"):
        check_footage(drones, n_test=40)
    with pytest.raises(DatasetError, match="cannot balance the real test pool"):
        check_footage(videos, n_test=2000)
    with pytest.raises(DatasetError, match="smaller than the 640x480 sensor"):
        check_footage(videos, (640, 480), n_test=10)
    with pytest.raises(DatasetError, match="does not exist"):
        check_footage(tmp_path / "nowhere", n_test=10)
    with pytest.raises(ParameterError, match="n_test"):
        check_footage(videos, n_test=7)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "empty"),
        ("frame,x,y\n1,2,3\n", "header"),
        ("frame,x,y,w,h\n1,2,3,4\n", "5 fields"),
        ("frame,x,y,w,h\none,2,3,4,5\n", "not an integer"),
        ("frame,x,y,w,h\n2,1,1,1,1\n1,1,1,1,1\n", "increase"),
        ("frame,x,y,w,h\n0,1,1,1,1\n", "start at 1"),
        ("frame,x,y,w,h\n1,a,1,1,1\n", "four numbers"),
        ("frame,x,y,w,h\n1,1,1,0,1\n", "w, h > 0"),
        ("frame,x,y,w,h\n1,1,,1,1\n", "four numbers"),
    ],
)
def test_malformed_box_files(tmp_path: Path, text: str, match: str) -> None:
    path = tmp_path / "V_DRONE_001.csv"
    path.write_text(text)
    with pytest.raises(DatasetError, match=match):
        read_boxes(path)


def test_loading_bad_datasets_raises_dataset_errors(dvs_set: Path, tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="does not exist"):
        load(tmp_path / "nowhere", "test")
    with pytest.raises(DatasetError, match="no manifest"):
        load(tmp_path, "test")
    with pytest.raises(DatasetError, match="no split 'valid'"):
        load(dvs_set, "valid")

    def copy(name: str) -> Path:
        root = tmp_path / name
        root.mkdir()
        for f in dvs_set.iterdir():
            (root / f.name).write_bytes(f.read_bytes())
        return root

    root = copy("missing")
    (root / "test.npz").unlink()
    with pytest.raises(DatasetError, match="missing"):
        load(root, "test")
    root = copy("corrupt")
    (root / "test.npz").write_bytes(b"not a zip file")
    with pytest.raises(DatasetError, match="cannot read"):
        load(root, "test")
    root = copy("version")
    m = json.loads((root / "manifest.json").read_text())
    m["format_version"] = FORMAT_VERSION + 1
    (root / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(DatasetError, match="format version"):
        load(root, "test")
    root = copy("garbled")
    (root / "manifest.json").write_text("{not json")
    with pytest.raises(DatasetError, match="cannot read"):
        load(root, "test")
    root = copy("lacking")
    with np.load(root / "test.npz") as z:
        arrays = {k: z[k] for k in z.files if k != "label"}
    np.savez(root / "test.npz", **arrays)
    with pytest.raises(DatasetError, match="lacks arrays: label"):
        load(root, "test")
    root = copy("pickled")
    with np.load(root / "test.npz") as z:
        arrays = {k: z[k] for k in z.files}
    arrays["cls"] = arrays["cls"].astype(object)
    np.savez(root / "test.npz", **arrays)
    with pytest.raises(DatasetError, match="cannot read"):
        load(root, "test")
    root = copy("inconsistent")
    with np.load(root / "test.npz") as z:
        arrays = {k: z[k] for k in z.files}
    arrays["x"] = arrays["x"] + np.uint16(300)  # off the sensor
    np.savez(root / "test.npz", **arrays)
    with pytest.raises(DatasetError, match="inconsistent"):
        load(root, "test")
    root = copy("miscounted")
    m = json.loads((root / "manifest.json").read_text())
    m["splits"]["test"]["windows"] += 1
    (root / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(DatasetError, match="manifest says"):
        load(root, "test")


# -- the command line -------------------------------------------------------------------------


def test_cli_info_and_errors(dvs_set: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["dataset", "info", str(dvs_set), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["splits"]["test"]["windows"] == 20 and summary["domain"] == "dvs"
    assert main(["dataset", "info", str(dvs_set)]) == 0
    assert "test: 20 windows (10 UAV, 10 not)" in capsys.readouterr().out
    assert main(["dataset", "build", str(tmp_path / "x"), "--domain", "real"]) == 2
    assert "needs videos" in capsys.readouterr().err
    assert main(["dataset", "info", str(tmp_path)]) == 2


def test_cli_preview_writes_a_picture(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "scene.png"
    assert main(["dataset", "preview", str(out), "--kind", "bird", "--duration", "0.05"]) == 0
    image = cv2.imread(str(out))
    assert image is not None and image.shape[0] > 180 and image.shape[1] > 240
    assert "bird" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("frames", "fps"), [(4_000_000_000, 30.0), (100, 2_147_483_647.0), (1, 30.0), (100, 0.0)]
)
def test_a_clip_header_no_video_has_is_refused_naming_the_clip(
    videos: Path, monkeypatch: pytest.MonkeyPatch, frames: int, fps: float
) -> None:
    # 4·10^9 frames made the plan's times (32 GB); a rate above the simulator's 10^6 fps gave
    # "frame times must increase strictly", naming no clip.
    from uavsnn.dataset import footage
    from uavsnn.dataset.real import find_clips
    from uavsnn.dataset.splits import WindowCut
    from uavsnn.sim.video import VideoInfo

    clip = find_clips(videos)[0]
    monkeypatch.setattr(footage, "probe_video", lambda _: VideoInfo(320, 256, fps, frames))
    with pytest.raises(DatasetError, match=f"video {clip.video.name} reports"):
        footage.plan_clip(WindowCut(50_000, 0.5, 0.5), clip)
