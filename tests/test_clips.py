"""Whole clips of real footage, streamed (``uavsnn.clips``): the alarms of one stream on
handmade windows, the decision per clip, and a tiny real-footage dataset end to end."""

from __future__ import annotations

import copy
import json
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from uavsnn import EVENT_DTYPE, Network
from uavsnn.clips import box_events, clip_alarms, clip_set, clip_table, evaluate_clips
from uavsnn.errors import DatasetError, ParameterError, ShapeError
from uavsnn.grouping import _NO_DETECTIONS, WindowObject, WindowReport
from uavsnn.track_eval import Confirm, decision_figures

STEP, L = 25_000, 50_000
UAV_BOX = (100, 80, 110, 90)
OFF = (10, 10, 16, 16)


def _report(k: int, detected: bool, *objects: tuple) -> WindowReport:
    return WindowReport(
        k, k * STEP, k * STEP + L, detected, _NO_DETECTIONS,
        tuple(
            WindowObject(box, 1, uav_score=s, track_id=t, track_confirmed=c, track_score=s)
            for box, t, c, s in objects
        ),
    )  # fmt: skip


def test_the_alarms_of_one_stream_per_rule() -> None:
    """Windows 0-5, a UAV labelled from window 2 on. Track 1, off the UAV, confirmed in
    UAV-free window 1 at a score of 0.3; track 2 on the UAV, tentative at 0.9 in window 2,
    confirmed at 0.8 in window 3 and 0.6 in window 4; window 5 is not detected."""
    reports = [
        _report(0, True, (OFF, 1, False, 0.3)),
        _report(1, True, (OFF, 1, True, 0.3)),
        _report(2, True, (UAV_BOX, 2, False, 0.9)),
        _report(3, True, (UAV_BOX, 2, True, 0.8)),
        _report(4, True, (UAV_BOX, 2, True, 0.6)),
        _report(5, False, (UAV_BOX, 2, True, 0.99)),
    ]
    uav = np.arange(6) >= 2
    boxes = np.where(uav[:, None], np.array(UAV_BOX, dtype=float), np.nan)
    got = clip_alarms(reports, {"any_spike": None, "loose": 0.7, "strict": 0.85}, uav, boxes)
    # Track 1 alarms in window 1 (ends at 75 ms), a false track; track 2 in window 3 (125 ms).
    assert got["rules"]["any_spike"] == {
        "alarmed": True, "alarming_tracks": 2, "false_tracks": 1,
        "first_alarm_us": 75_000, "found_us": 125_000,
    }  # fmt: skip
    assert got["rules"]["loose"] == {
        "alarmed": True, "alarming_tracks": 1, "false_tracks": 0,
        "first_alarm_us": 125_000, "found_us": 125_000,
    }  # fmt: skip
    # 0.9 was tentative and window 5 is not detected: nothing reaches 0.85 while confirmed.
    assert got["rules"]["strict"] == {
        "alarmed": False, "alarming_tracks": 0, "false_tracks": 0,
        "first_alarm_us": None, "found_us": None,
    }  # fmt: skip
    assert got["track_peaks"] == [0.8, 0.3]


def test_an_alarm_off_the_uav_decides_but_does_not_find() -> None:
    reports = [_report(k, True, (OFF, 1, k >= 2, 0.5)) for k in range(5)]
    uav = np.ones(5, dtype=bool)
    boxes = np.tile(np.array(UAV_BOX, dtype=float), (5, 1))
    rule = clip_alarms(reports, {"any_spike": None}, uav, boxes)["rules"]["any_spike"]
    assert rule["alarmed"] and rule["found_us"] is None and rule["false_tracks"] == 0


def test_box_events_counts_the_events_on_each_box() -> None:
    ev = np.zeros(7, dtype=EVENT_DTYPE)
    ev["t"] = [0, 10, 20, 30, 60, 70, 80]
    ev["x"] = [5, 5, 9, 4, 5, 5, 5]
    ev["y"] = [5, 5, 5, 5, 5, 5, 20]
    boxes = np.array([[4.5, 4.5, 6.0, 6.0], [0.0, 0.0, 10.0, 10.0]])
    # Window 0: x = 5 twice and pixel 4, which covers [4, 5) and so meets x0 = 4.5; not x = 9.
    # Window 1: two of its three events; (5, 20) lies below the box.
    assert box_events(ev, np.array([0, 50]), 50, boxes).tolist() == [3, 2]
    assert box_events(ev[:0], np.array([0]), 50, boxes[:1]).tolist() == [0]


def test_decisions_on_handmade_recordings() -> None:
    got = decision_figures(
        [True, True, False, False, False],
        [True, False, True, False, False],
        ["drone", "drone", "bird", "bird", "none"],
    )
    assert (got["right"], got["uav_alarmed"], got["other_quiet"]) == (3, 1, 2)
    assert got["accuracy"] == pytest.approx(0.6)
    assert got["balanced_accuracy"] == pytest.approx((1 / 2 + 2 / 3) / 2)
    assert got["per_class"] == {
        "bird": {"recordings": 2, "decided_uav": 1},
        "drone": {"recordings": 2, "decided_uav": 1},
        "none": {"recordings": 1, "decided_uav": 0},
    }
    # Only UAV-free recordings: the balanced share is theirs alone.
    assert decision_figures([False], [False], ["bird"])["balanced_accuracy"] == 1.0
    assert decision_figures([], [], [])["accuracy"] is None
    with pytest.raises(ShapeError):
        decision_figures([True], [True, False], ["drone"])


@given(st.lists(st.tuples(st.booleans(), st.booleans()), max_size=30))
def test_decided_right_adds_up(pairs: list[tuple[bool, bool]]) -> None:
    uav = [u for u, _ in pairs]
    said = [a for _, a in pairs]
    got = decision_figures(uav, said, ["drone" if u else "bird" for u in uav])
    assert got["right"] == got["uav_alarmed"] + got["other_quiet"]
    assert got["right"] == sum(u == a for u, a in pairs)
    assert sum(c["decided_uav"] for c in got["per_class"].values()) == sum(said)
    if pairs:
        assert 0.0 <= got["balanced_accuracy"] <= 1.0


# -- a tiny real-footage dataset -------------------------------------------------------------


@pytest.fixture(scope="module")
def footage(
    tmp_path_factory: pytest.TempPathFactory, write_clip: Callable[..., None]
) -> tuple[Path, Path, Path]:
    """Five clips (two drones, two birds, an airplane) of a dark square crossing a bright sky,
    a real dataset built from them, and an untrained 240x180 model that fires on the square."""
    from uavsnn.dataset import build

    tmp = tmp_path_factory.mktemp("footage")
    videos = tmp / "videos"
    videos.mkdir()
    for i, cls in enumerate(("DRONE", "DRONE", "BIRD", "BIRD", "AIRPLANE")):
        path = [(40 + (4 + i) * k, 60 + 2 * k) for k in range(30)]
        write_clip(videos, f"V_{cls}_{i + 1:03d}", path)
    root = build(tmp / "real", "real", videos=videos, n_test=10, n_train=None, seed=1).root
    model = tmp / "m.npz"
    Network({"width": 240, "height": 180, "conv2": {"threshold": 10.0}}, seed=0).save(model)
    return root, videos, model


def _made_as_built(root: Path, videos: Path | None = None) -> None:
    """Each test clip of the dataset at ``root``, made again, has the dataset's raw events in
    every window the split keeps of it."""
    from uavsnn.dataset import load

    clips = clip_set(root, "test", videos)
    test = load(root, "test")
    names = {r["id"]: r["name"] for r in test.manifest["recordings"]}
    assert sorted(w.name for w in clips.clips) == sorted(
        names[int(r)] for r in np.unique(test.recording)
    )
    assert test.raw is not None
    checked = 0
    for whole in clips.clips:
        made = whole.make()[0]
        assert len(made) == whole.events
        mine = np.flatnonzero([names[int(r)] == whole.name for r in test.recording])
        for i in mine.tolist():
            t0 = int(test.windows.t0[i])
            inside = made[(made["t"] >= t0 - L) & (made["t"] < t0 + L)]
            assert np.array_equal(inside, test.raw.window(i))
            checked += 1
    assert checked == len(test)


def test_the_clips_are_made_as_the_build_made_them(footage: tuple[Path, Path, Path]) -> None:
    root, videos, _ = footage
    _made_as_built(root, videos)
    assert all(clip.spec() is None for clip in clip_set(root, "test", videos).clips)


@pytest.mark.parametrize(("domain", "stratify"), [("dvs", False), ("dvs", True), ("sim", False)])
def test_rendered_recordings_are_made_and_streamed_as_built(
    tmp_path: Path, footage: tuple[Path, Path, Path], domain: str, stratify: bool
) -> None:
    """A dvs split's recordings (drawn, or stratified as tuning sets are) and a sim split's
    (their frame rate drawn per scene) are rendered again from their seeds and streamed
    whole; a folder of videos is refused for them."""
    from uavsnn.dataset import SceneSource, build, read_manifest

    sources = {
        "dvs": SceneSource("dvs", (240, 180), 200.0, 0.3),
        "sim": SceneSource("sim", (320, 240), None, 0.4),
    }
    root = build(
        tmp_path / domain, domain, n_test=30, n_train=0, seed=2 if domain == "dvs" else 1,
        stratify=stratify, **{domain: sources[domain]},
    ).root  # fmt: skip
    manifest = read_manifest(root)
    test = set(manifest["splits"]["test"]["recordings"])
    kinds = {r["kind"] for r in manifest["recordings"] if r["id"] in test}
    assert {"uav", "object"} <= kinds  # object scenes: stratified ones take their kinds in turn
    _made_as_built(root)
    # Each clip's scene, drawn again without rendering, is the one its manifest record describes.
    records = {r["name"]: r for r in manifest["recordings"]}
    for clip in clip_set(root).clips:
        spec, record = clip.spec(), records[clip.name]
        assert spec is not None
        assert (spec.background.kind, round(spec.lighting.level, 4)) == (
            record["background"],
            record["lighting"],
        )
        drawn = [
            {
                "kind": o.kind,
                "size_m": round(o.size_m, 4),
                "range_m": round(o.path.start[2], 2),
                "path": o.path.kind,
            }
            for o in spec.objects
        ]
        assert drawn == record["objects"]
    figures = evaluate_clips(Network.load(footage[2]), root)
    assert figures["clips"] == len(clip_set(root).clips) > 1
    assert all(r["windows"] > 0 for r in figures["per_clip"])
    with pytest.raises(ParameterError, match="real footage"):
        clip_set(root, "test", footage[1])


def test_evaluate_clips_decides_every_test_clip(footage: tuple[Path, Path, Path]) -> None:
    root, videos, model = footage
    net = Network.load(model)
    figures = evaluate_clips(net, root, videos=videos)
    rows = figures["per_clip"]
    assert figures["clips"] == len(rows) == len(clip_set(root, "test", videos).clips)
    assert figures["confirm"] == "3/5" and list(figures["rules"]) == ["any_spike"]
    for row in rows:
        assert row["uav"] == ("DRONE" in row["clip"]) and row["windows"] > 0
        assert row["class"] == row["clip"].split("_")[1].lower()
    rule = figures["rules"]["any_spike"]
    alarmed = [r["rules"]["any_spike"]["alarmed"] for r in rows]
    assert rule["right"] == sum(a == r["uav"] for a, r in zip(alarmed, rows, strict=True))
    # The untrained network fires on the square: some clip has a confirmed track.
    assert any(alarmed)
    found = [r for r in rows if r["rules"]["any_spike"]["found_us"] is not None]
    assert rule["found"] == len(found) and all(r["uav"] for r in found)
    assert rule["time_to_alarm_ms"]["n"] == len(found)
    table = clip_table(figures)
    assert f"| any-spike | **{rule['right']} of {len(rows)}" in table
    # The time to first alarm says where its clock starts: the first UAV window, where the UAV
    # is labelled visible for half the window, not its first event.
    assert "time to first alarm from the first UAV window, median" in table
    assert "from the start of each UAV clip's first UAV window" in table
    assert "does not start at the UAV's first event" in table
    # A UAV clip where no track alarmed is named under the table, with its UAV's size.
    quiet = copy.deepcopy(figures)
    row = next(r for r in quiet["per_clip"] if r["uav"])
    row["rules"]["any_spike"]["alarmed"] = False
    n = row["uav_events_per_window"]
    on_it = f"{n:g} {'event' if n == 1 else 'events'} per window on it"
    assert f"{row['clip']} ({row['uav_size_px']:.1f} px, {on_it})" in clip_table(quiet)
    # The square gives the network events on its labelled box.
    assert all(r["uav_events_per_window"] > 0 for r in rows if r["uav"])
    # The same clips give the same figures; a stricter confirmation never alarms more.
    assert evaluate_clips(net, root, videos=videos) == figures
    strict = evaluate_clips(net, root, videos=videos, confirm=Confirm.parse("5/5"))
    assert strict["confirm"] == "5/5"
    assert strict["rules"]["any_spike"]["uav_alarmed"] <= rule["uav_alarmed"]


def test_clips_are_found_from_the_dataset_whatever_the_working_folder(
    footage: tuple[Path, Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A build given --videos as a relative path recorded it as typed, so the clips were not
    # found from another working folder ("read from videos, which is not a folder here").
    root, videos, _ = footage
    manifest = json.loads((root / "manifest.json").read_text())
    (real,) = [s for s in manifest["parameters"]["sources"] if s["domain"] == "real"]
    assert real["videos_from_dataset"] == "../videos"
    # The dataset and its videos moved together, the folder recorded as a build in their
    # parent folder was given it.
    shutil.copytree(root, tmp_path / "real")
    shutil.copytree(videos, tmp_path / "videos")
    moved = json.loads((tmp_path / "real" / "manifest.json").read_text())
    for source in moved["parameters"]["sources"]:
        if source["domain"] == "real":
            source["videos"] = "videos"
    (tmp_path / "real" / "manifest.json").write_text(json.dumps(moved))
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    found = clip_set(tmp_path / "real", "test")
    assert [c.name for c in found.clips] == [c.name for c in clip_set(root, "test").clips]
    # A manifest of a build before (no videos_from_dataset) reads the folder as given.
    del source["videos_from_dataset"]
    (tmp_path / "real" / "manifest.json").write_text(json.dumps(moved))
    with pytest.raises(DatasetError, match="were read from videos, which is not a folder here"):
        clip_set(tmp_path / "real", "test")
    monkeypatch.chdir(tmp_path)
    assert len(clip_set(tmp_path / "real", "test").clips) == len(found.clips)


def test_bad_clip_sets_are_typed_errors(
    footage: tuple[Path, Path, Path], tmp_path: Path, write_clip: Callable[..., None]
) -> None:
    root, videos, model = footage
    net = Network.load(model)
    # The folder given is named as such (it said the clips were read from there).
    with pytest.raises(DatasetError, match=r"the folder of videos .*nowhere is not a folder$"):
        clip_set(root, "test", tmp_path / "nowhere")
    # Without one, the folder the build read is used: when it is gone, that is said.
    moved = tmp_path / "moved"
    shutil.copytree(root, moved)
    manifest = json.loads((moved / "manifest.json").read_text())
    for source in manifest["parameters"]["sources"]:
        if source["domain"] == "real":
            source["videos"] = str(tmp_path / "gone")
            source["videos_from_dataset"] = "../gone"
    (moved / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(DatasetError, match=r"were read from .*gone, which is not a folder here"):
        clip_set(moved, "test")
    with pytest.raises(DatasetError, match="no 'val' split"):
        clip_set(root, "val", videos)
    # A folder without one of the split's clips, and one where a clip is another video.
    other = tmp_path / "other"
    shutil.copytree(videos, other)
    name = clip_set(root, "test", videos).clips[0].name
    for suffix in (".avi", ".csv"):
        (other / f"{name}{suffix}").unlink()
    with pytest.raises(DatasetError, match=f"clip {name} .* is not in"):
        clip_set(root, "test", other)
    write_clip(other, name, [(200 - 3 * k, 100) for k in range(30)])
    # Its box file edited since the build: its windows would be labelled otherwise.
    with pytest.raises(DatasetError, match=f"box file .*{name}.csv of clip {name} changed since"):
        clip_set(root, "test", other)
    # The box file as built, the video another one.
    shutil.copy(videos / f"{name}.csv", other / f"{name}.csv")
    with pytest.raises(DatasetError, match="events here"):
        evaluate_clips(net, root, videos=other)
    with pytest.raises(ParameterError, match="HITS/WINDOWS"):
        evaluate_clips(net, root, videos=videos, confirm=Confirm.parse("2/3+3/5"))
    # A manifest that does not say how a clip was made (an older uavsnn's).
    from uavsnn.dataset.format import read_manifest, write_manifest

    old = tmp_path / "old"
    shutil.copytree(root, old)
    manifest = read_manifest(old)
    first = manifest["splits"]["test"]["recordings"][0]
    del next(r for r in manifest["recordings"] if r["id"] == first)["events"]
    write_manifest(old, manifest)
    with pytest.raises(DatasetError, match="does not say how"):
        clip_set(old, "test", videos)
    wide = Network({"width": 320, "height": 240}, seed=0)
    with pytest.raises(ParameterError, match="320x240"):
        evaluate_clips(wide, root, videos=videos)


def test_evaluate_clips_on_the_command_line(
    footage: tuple[Path, Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    from uavsnn.cli import main

    root, videos, model = footage
    base = ["evaluate", str(model), str(root), "--clips", "--videos", str(videos)]
    assert main([*base, "--json"]) == 0
    got = json.loads(capsys.readouterr().out)["clips"]
    assert got == evaluate_clips(Network.load(model), root, videos=videos)
    assert main(base) == 0
    text = capsys.readouterr().out
    assert "whole clips of the test split, streamed:" in text and "| any-spike | **" in text
    assert main([*base, "--confirm", "2/5", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["clips"]["confirm"] == "2/5"
    refused = (
        ["evaluate", str(model), str(root), "--videos", str(videos)],
        ["evaluate", str(model), str(root), "--ray"],
        [*base, "--confirm", "2/3+3/5"],
    )
    for args in refused:
        assert main(args) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "--clips" in err, args


def test_a_lower_pix2nvs_threshold_is_built_and_streamed_again(
    footage: tuple[Path, Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`dataset build --pix2nvs-threshold` records the threshold; the clips streamed again are
    made with it (their event counts match the build's), with more events than at 0.4."""
    from uavsnn.cli import main
    from uavsnn.dataset import read_manifest

    root, videos, model = footage
    low = tmp_path / "low"
    base = ["dataset", "build", "--domain", "real", "--videos", str(videos), "--n-test", "10"]
    assert main([*base, str(low), "--seed", "1", "--pix2nvs-threshold", "0.2", "--quiet"]) == 0
    source = read_manifest(low)["parameters"]["sources"][0]
    assert source["simulator_params"]["threshold"] == 0.2
    net = Network.load(model)
    at_low = evaluate_clips(net, low, videos=videos)["per_clip"]
    at_default = evaluate_clips(net, root, videos=videos)["per_clip"]
    assert [r["clip"] for r in at_low] == [r["clip"] for r in at_default]
    assert sum(r["events"] for r in at_low) > sum(r["events"] for r in at_default)
    capsys.readouterr()
    dvs = ["dataset", "build", "--domain", "dvs", "--n-test", "10"]  # (--videos is refused)
    for start, bad in ((dvs, ["--pix2nvs-threshold", "0.2"]), (base, ["--pix2nvs-threshold", "-1"]),
                       (base, ["--pix2nvs-threshold", "nan"])):  # fmt: skip
        args = [*start, str(tmp_path / "bad"), *bad]
        assert main(args) == 2, bad
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "threshold" in err, bad
        assert not (tmp_path / "bad").exists()


def test_the_contrast_bench_measures_the_square(
    footage: tuple[Path, Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    bench_script,
) -> None:
    """The dark square (luma 20 on 200) stands out by about ln(201 / 21) = 2.26 and moves
    several pixels a frame: every frame's change passes PIX2NVS's 0.4."""
    root, videos, model = footage
    bench = bench_script("clip_contrast")
    table = bench.rows(str(root), "test", str(videos), 6)
    uav_clips = [w.name for w in clip_set(root, "test", videos).clips if "DRONE" in w.name]
    assert sorted(r["clip"] for r in table) == sorted(uav_clips) and table
    for row in table:
        assert row["frames"] == 30 and row["threshold"] == 0.4
        # About ln(201 / 21): the video's compression rings some pixels darker still.
        assert 0.9 * np.log(201 / 21) < row["contrast"] < 1.3 * np.log(201 / 21)
        assert row["change"] > 2 and row["past_threshold"] == 1.0
    streamed = tmp_path / "clips.json"
    streamed.write_text(json.dumps(evaluate_clips(Network.load(model), root, videos=videos)))
    argv = ["clip_contrast.py", str(root), "--videos", str(videos), "--clips", str(streamed)]
    monkeypatch.setattr("sys.argv", argv)
    bench.main()
    lines = capsys.readouterr().out.splitlines()
    assert "frames past θ = 0.4" in lines[0] and len(lines) == 2 + len(table)
    # --windows: every UAV window of the split gives events on the square's box.
    counts = bench.window_events(str(root), "test")
    assert len(counts) == 5 and counts.min() > 0  # the tiny set's 5 UAV test windows
    monkeypatch.setattr("sys.argv", ["clip_contrast.py", str(root), "--windows"])
    bench.main()
    assert "| none | 0.0 % |" in capsys.readouterr().out
    assert all(
        " | 100 % | " in line and ("| yes |" in line or "| no |" in line) for line in lines[2:]
    )
