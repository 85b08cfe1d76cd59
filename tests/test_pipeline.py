"""The commands of the whole path: ``uavsnn train``, ``evaluate``, ``demo`` (held-out accuracy
well above chance) and ``reproduce`` at a tiny size; their errors."""

from __future__ import annotations

import json
import platform
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from uavsnn import Network
from uavsnn.cli import main
from uavsnn.dataset import SceneSource, build
from uavsnn.experiments import NOISE_FRACTIONS, PAPER_TABLE3_BY_SHARE, describe_cpu
from uavsnn.network import _add_arrays

DVS = SceneSource("dvs", (240, 180), 200.0, 0.3)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("pipeline") / "set"
    build(root, "dvs", n_test=20, n_train=24, seed=11, dvs=DVS)
    return root


def test_train_then_evaluate(
    dataset: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = tmp_path / "m.npz"
    args = ["train", str(dataset), "-o", str(model), "--windows-per-layer", "100"]
    assert main([*args, "--set", "conv2.threshold=15", "--json", "--quiet"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert set(summary["layers"]) == {"conv2", "conv3"} and model.exists()
    assert summary["layers"]["conv2"]["windows_seen"] >= 100

    # The same network, its identification fitted again without STDP.
    again = tmp_path / "again.npz"
    only = ["train", str(dataset), "-o", str(again), "--identify-only", str(model)]
    assert main([*only, "--identify-model", "logistic", "--json"]) == 0
    refit = json.loads(capsys.readouterr().out)
    assert refit["network"] == str(model) and refit["identify"]["model"] == "logistic"
    assert isinstance(refit["identify"]["tune_lacks"], list)
    with np.load(model) as a, np.load(again) as b:
        weights = [k for k in a.files if not k.startswith("identify.")]
        assert weights and all(np.array_equal(a[k], b[k]) for k in weights)
    assert Network.load(again).identification is not None
    # Tuned on held-out training recordings, the text says a separate tuning set does better;
    # given one (other recordings: another seed), it does not.
    held_out = "tuned on a quarter of the training recordings held out"
    assert main([*only, "--identify-model", "logistic", "--quiet"]) == 0
    assert held_out in capsys.readouterr().out
    tune = tmp_path / "tune"
    build(tune, "dvs", n_test=2, n_train=24, seed=12, dvs=DVS)
    assert main([*only, "--identify-model", "logistic", "--tune", str(tune), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "a separate tuning set" in text and held_out not in text
    # The refit tracks at the sensor's gate (24 px), whatever gate MODEL records, and records it.
    assert Network.load(model).identification.gate_px == pytest.approx(24.0)
    odd = tmp_path / "odd.npz"
    shutil.copy(model, odd)
    _add_arrays(str(odd), {"identify.gate_px": np.array(12.0)})
    assert Network.load(odd).identification.gate_px == 12.0
    regated = tmp_path / "regated.npz"
    refit_odd = ["train", str(dataset), "-o", str(regated), "--identify-only", str(odd)]
    assert main([*refit_odd, "--identify-model", "logistic", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["identify"]["gate_px"] == pytest.approx(24.0)
    assert Network.load(regated).identification.gate_px == pytest.approx(24.0)
    for bad in (["--no-identify"], ["--set", "conv2.threshold=9"], ["--resume"]):
        assert main([*only, *bad, "--quiet"]) == 2
        assert "--identify-only" in capsys.readouterr().err
    # Track alarm thresholds set on a few streamed UAV-free recordings of seed 5.
    tracked = tmp_path / "tracked.npz"
    track = ["train", str(dataset), "-o", str(tracked), "--identify-only", str(model)]
    assert main([*track, "--track-minutes", "0.05", "--track-seed", "5", "--json"]) == 0
    tracks = json.loads(capsys.readouterr().out)["identify"]["tracks"]
    assert tracks["seed"] == 5 and tracks["recordings"] == 3
    ident = Network.load(tracked).identification
    assert ident is not None and ident.track_alarm_minutes == pytest.approx(0.05)
    assert [list(p) for p in ident.track_alarm_thresholds] == tracks["track_alarm_thresholds"]
    assert [r for r, _ in ident.track_alarm_thresholds] == [0.1, 1.0]
    assert ident.track_alarm_confirm == (3, 5) and tracks["confirm"] == "3/5"
    assert main([*track, "--track-minutes", "0.05", "--track-confirm", "2/5", "--quiet"]) == 0
    capsys.readouterr()
    ident = Network.load(tracked).identification
    assert ident is not None and ident.track_alarm_confirm == (2, 5)
    for bad in (
        ["--track-minutes", "-1"],
        ["--track-minutes", "1", "--no-identify"],
        ["--ray"],
        ["--track-confirm", "2/5"],
        ["--track-minutes", "1", "--track-confirm", "2/3+3/5"],
    ):
        assert main([*track, *bad, "--quiet"]) == 2
        assert "--track-" in capsys.readouterr().err
    missing = ["train", str(dataset), "-o", str(again), "--identify-only", str(tmp_path / "no")]
    assert main(missing) == 2 and "error" in capsys.readouterr().err

    report = tmp_path / "report"
    assert (
        main(["evaluate", str(model), str(dataset), "--json", "--noise", "--report", str(report)])
        == 0
    )
    figures = json.loads(capsys.readouterr().out)
    (tp, fn), (fp, tn) = figures["confusion"]
    assert tp + fn == 10 and fp + tn == 10 and figures["windows"] == 20
    assert figures["accuracy"] == (tp + tn) / 20
    assert {p["mode"] for p in figures["noise"]} == {"pent", "static"}
    assert (report / "report.md").exists() and (report / "confusion.png").exists()
    text = (report / "report.md").read_text()
    assert f"{tp} (TP)" in text and "![confusion](confusion.png)" in text
    # The text output gives the noise sweep for both rules where the model has identification.
    assert main(["evaluate", str(model), str(dataset), "--noise"]) == 0
    printed = capsys.readouterr().out.splitlines()
    lines = [ln for ln in printed if ln.startswith("  noise ")]
    assert len(lines) == len(figures["noise"]) == 2 * len(NOISE_FRACTIONS)
    assert any("with identification" in line for line in lines)  # the model has one
    # Under each level's first line, PENT's accuracy lead over static by rule, as the JSON's.
    leads = [ln for ln in printed if ln.startswith("    accuracy lead over static")]
    with_leads = [p for p in figures["noise"] if "accuracy_leads" in p]
    assert len(leads) == len(with_leads) == len(NOISE_FRACTIONS)
    for line, point in zip(leads, with_leads, strict=True):
        lead = point["accuracy_leads"]["static"]["any_spike"]
        lo, hi = lead["interval"]
        # None (null): too few test recordings for an interval (evaluation.MIN_INTERVAL_RECORDINGS)
        drawn = "–" if lo is None else f"{100 * lo:+.1f} to {100 * hi:+.1f}"
        assert f"any-spike {100 * lead['lead']:+.1f} ({drawn})" in line
    # Without a train split, the static threshold is set on the windows scored, and it says so.
    bare = tmp_path / "bare"
    shutil.copytree(dataset, bare)
    (bare / "train.npz").unlink()
    assert main(["evaluate", str(model), str(bare), "--noise", "--json"]) == 0
    assert "has no train split: the static threshold" in capsys.readouterr().err
    # --noise-shares: the shares given (SPEC §5's six for table3), no noise first.
    table3 = [0.0, *PAPER_TABLE3_BY_SHARE]
    for shares, want in (("0.02,0.005", [0.0, 0.02, 0.005]), ("table3", table3)):
        argv = ["evaluate", str(model), str(dataset), "--noise", "--noise-shares", shares]
        assert main([*argv, "--json"]) == 0
        swept = json.loads(capsys.readouterr().out)["noise"]
        assert [p["fraction"] for p in swept if p["mode"] == "static"] == want
        assert [p["fraction"] for p in swept if p["mode"] == "pent"] == want
    for line, point in zip(lines, figures["noise"], strict=True):
        assert f"{100 * point['accuracy']:.1f} %" in line
        ident = point.get("identified")
        assert ("with identification" in line) == (ident is not None)
        if ident is not None:
            assert line.endswith(f"with identification {100 * ident['accuracy']:.1f} %")


def test_commands_fail_cleanly_on_bad_input(
    dataset: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = tmp_path / "small.npz"
    assert main(["train", str(dataset), "-o", str(model), "--set", "width=120", "--quiet"]) == 2
    assert "error" in capsys.readouterr().err and not model.exists()
    assert main(["train", str(tmp_path / "nothing"), "-o", str(model), "--quiet"]) == 2
    assert "does not exist" in capsys.readouterr().err
    # a model of another sensor size than the dataset's
    Network({"width": 120, "height": 90}, seed=0).save(model)
    assert main(["evaluate", str(model), str(dataset)]) == 2
    assert "sensor is 240x180 but the model's input is 120x90" in capsys.readouterr().err
    refit = tmp_path / "refit.npz"
    assert main(["train", str(dataset), "-o", str(refit), "--identify-only", str(model)]) == 2
    assert "120x90" in capsys.readouterr().err and not refit.exists()
    assert main(["evaluate", str(tmp_path / "missing.npz"), str(dataset)]) == 2


def test_demo_is_well_above_chance_on_held_out_windows(tmp_path: Path) -> None:
    from uavsnn.cli.demo import run_demo

    figures = run_demo(tmp_path / "demo", seed=0)
    test = figures["test"]
    assert test["windows"] == 200
    assert test["accuracy"] >= 0.65, test["confusion"]
    assert Network.load(tmp_path / "demo" / "model.npz").trained_on is not None
    for name in (
        "report.md",
        "results.json",
        "model.npz",
        "features-conv2.png",
        "snr.png",
        "pent.png",
    ):
        assert (tmp_path / "demo" / name).exists(), name
    text = (tmp_path / "demo" / "report.md").read_text()
    assert "Accuracy" in text
    # Every picture is followed by its caption.
    from uavsnn.report import CAPTIONS

    pictures = sorted(p.stem for p in (tmp_path / "demo").glob("*.png"))
    assert pictures
    for name in pictures:
        assert f"![{name}](" in text and f"*{name}: {CAPTIONS[name]}*" in text, name


def test_reproduce_at_a_tiny_size(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], write_clip: Callable[..., None]
) -> None:
    out = tmp_path / "repro"
    # Real footage: five clips of a dark square crossing a bright sky, at two sensor sizes.
    videos = tmp_path / "videos"
    videos.mkdir()
    for i, cls in enumerate(("DRONE", "DRONE", "BIRD", "BIRD", "AIRPLANE")):
        write_clip(
            videos, f"V_{cls}_{i + 1:03d}", [(40 + (4 + i) * k, 60 + 2 * k) for k in range(30)]
        )
    # 40 training windows: enough objects of both kinds to fit identification.
    args = ["reproduce", "--out", str(out), "--n-train", "40", "--n-test", "20"]
    args += ["--free-minutes", "0.05", "--track-minutes", "0.05"]
    args += ["--videos", str(videos), "--real-sensors", "240x180,320x240,240x180"]
    assert main([*args, "--windows-per-layer", "32", "--quiet"]) == 0
    text = (out / "RESULTS.md").read_text()
    assert "## Table 2" in text and "| combined |" in text and "## Table 3" in text
    assert "Not run:" not in text  # the real footage ran
    raw = (out / "results.json").read_text()
    results = json.loads(raw)
    assert set(results["table2"]) == {"dvs", "sim", "combined", "combined, Table 1 as published"}
    # The streams' peak scores are summarised, not logged.
    assert '"track_peaks"' not in raw and '"window_peaks"' not in raw
    assert len(results["noise"]) == 2 * len(NOISE_FRACTIONS)
    # Both rules: each network's identification fit is reported, fitted or skipped with why.
    assert "| with identification |" in text
    # Track level: the combined network's test recordings followed as streams.
    assert "### Tracks" in text and "| any-spike |" in text
    assert results["tracks"]["recordings"] == len(results["tracks"]["per_recording"])
    # The ablation, for the streamed networks with identification.
    from uavsnn.identify import GROUPS

    with_ident = {n for n in ("combined", "dvs") if results["table2"][n]["identification"]}
    assert set(results["ablation"]) == with_ident
    for rows in results["ablation"].values():
        assert list(rows) == list(GROUPS) and all("tracks" in r for r in rows.values())
    assert ("### Ablation" in text) == bool(with_ident)
    # The same test recordings streamed whole, for both streamed networks.
    assert "### Tracks: the test recordings streamed whole" in text
    assert set(results["clips"]) == {"combined", "dvs"}
    for clips in results["clips"].values():
        assert clips["clips"] == results["tracks"]["recordings"] == len(clips["per_clip"])
    for entry in results["table2"].values():
        fit = entry["identify_fit"]
        assert ("skipped" in fit) == (entry["identification"] is None)
        # Tuned on recordings of another seed (SPEC §5), never on a quarter of its own.
        assert fit.get("tune", "a separate tuning set") == "a separate tuning set"
    assert results["tune_seed"] == 1
    # A combined network's identification is fitted on the dvs windows of its training data
    # and tuned on the dvs tuning set: fitting the saved network again on those gives the
    # same score and threshold.
    from uavsnn.dataset import load
    from uavsnn.experiments import fit_identification

    for name, model in (("combined", "model-combined.npz"), ("dvs", "model-dvs.npz")):
        fit = results["table2"][name]["identify_fit"]
        if "skipped" not in fit:
            again = fit_identification(
                Network.load(out / model), load(out / "data/dvs", "train"),
                load(out / "data/tune-dvs", "train"),
            )  # fmt: skip
            assert (again["model"], again["threshold"]) == (fit["model"], fit["threshold"])
    # False alarms over fresh UAV-free recording (3 recordings of 1 s here).
    assert set(results["false_alarms"]) == {"combined", "dvs"}
    assert "### False alarms over" in text and "**The dvs network.**" in text
    for free in results["false_alarms"].values():
        assert free["recordings"] == 3 and set(free["rules"]) <= {
            "any_spike", "identified", "identified_at_0.01", "identified_at_0.05",
            "identified_tracks_at_0.1", "identified_tracks_at_1",
        }  # fmt: skip
    # Track alarm thresholds set on 3 recordings of the tuning seed, for the networks with
    # identification among the streamed ones.
    tuned = []
    for name in ("combined", "dvs"):
        fit = results["table2"][name]["identify_fit"]
        assert ("tracks" in fit) == ("skipped" not in fit)
        if "tracks" in fit:
            assert fit["tracks"]["seed"] == 1 and fit["tracks"]["recordings"] == 3
            assert "identified_tracks_at_0.1" in results["false_alarms"][name]["rules"]
            assert f"The {name} network's track alarm thresholds" in text
            tuned.append(name)
    assert tuned
    for domain in ("dvs", "sim"):
        manifest = json.loads((out / f"data/tune-{domain}/manifest.json").read_text())
        assert manifest["seed"] == 1 and manifest["parameters"]["n_train"] == 40
    # The real footage at each size asked for (once each): the run's own size as "real",
    # the other under its name, each with its dataset, model, windows and streamed clips, and
    # a table of both sizes first.
    assert set(results["real_sensors"]) == {"320x240"}
    for entry, sensor in (
        (results["real"], [240, 180]),
        (results["real_sensors"]["320x240"], [320, 240]),
    ):
        assert entry["sensor"] == sensor and entry["clips"]["clips"] >= 1
        assert entry["confusion"] and "any_spike" in entry["clips"]["rules"]
    real_manifest = json.loads((out / "data/real-320x240/manifest.json").read_text())
    assert real_manifest["parameters"]["sensor_size"] == [320, 240]
    assert Network.load(out / "model-real-320x240.npz").config["width"] == 320
    assert Network.load(out / "model-real.npz").config["width"] == 240
    # Each model records what it learned from: evaluated on its own training split, it is
    # warned of; on its test split, not (uavsnn.provenance).
    from uavsnn.dataset import load as load_split

    for model, split, trained in (
        ("model-dvs.npz", "train", True), ("model-dvs.npz", "test", False),
        ("model-combined.npz", "train", True), ("model-real.npz", "train", True),
    ):  # fmt: skip
        net = Network.load(out / model)
        assert net.trained_on is not None and net.trained_on.window_us == 50_000
        data = "data/real" if "real" in model else "data/dvs"
        shared = net.trained_on.shared_with(load_split(out / data, split).manifest, split)
        assert bool(shared) is trained, (model, split)
    sizes = text.index("## Real footage at each sensor size")
    assert (
        sizes < text.index("## Real footage at 240x180") < text.index("## Real footage at 320x240")
    )
    assert "| 240x180 |" in text[sizes:] and "| 320x240 |" in text[sizes:]
    assert "the real footage at 240x180 and 320x240" in text
    # What the figures may depend on besides the code and the seed is written beside them.
    env = results["environment"]
    assert env["numpy"] == np.__version__ and env["python"] == platform.python_version()
    assert f"NumPy {np.__version__}" in text


def test_a_dataset_of_another_sensor_or_size_is_not_reused(tmp_path: Path) -> None:
    """reproduce reuses a dataset only when it was built with the same seed, sensor and
    window counts (a rerun with --sensor 640x480 once would have reused the 240x180 set)."""
    from uavsnn.dataset import build
    from uavsnn.experiments import have_dataset

    root = tmp_path / "set"
    build(root, "dvs", n_test=4, n_train=0, seed=3, sensor=(64, 48))
    assert have_dataset(root, 3)
    assert have_dataset(root, 3, sensor_size=(64, 48), n_test=4, n_train=0)
    assert not have_dataset(root, 4)
    assert not have_dataset(root, 3, sensor_size=(240, 180))
    assert not have_dataset(root, 3, n_test=8)
    assert not have_dataset(root, 3, no_such_parameter=1)
    assert not have_dataset(tmp_path / "nothing", 3)


def test_reproduce_refuses_a_bad_sensor_before_writing(tmp_path: Path, capsys) -> None:
    out = tmp_path / "repro"
    assert main(["reproduce", "--out", str(out), "--sensor", "640by480", "--quiet"]) == 2
    assert "sensor must be WIDTHxHEIGHT" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--seed", "3", "--tune-seed", "3"], "--tune-seed must be a non-negative seed other"),
        (["--tune-seed", "-1"], "--tune-seed must be a non-negative seed other"),
        (["--n-tune", "1"], "--n-tune must be an even number of windows from 2"),
        (["--free-minutes", "-1"], "--free-minutes must be in"),
        (["--track-minutes", "601"], "--track-minutes must be in"),
        (["--real-sensors", "640x480,big"], "sensor must be WIDTHxHEIGHT"),
        (["--real-sensors", " , "], "--real-sensors needs at least one WxH"),
    ],
)
def test_reproduce_refuses_to_tune_on_the_test_seed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], message: str
) -> None:
    out = tmp_path / "repro"
    assert main(["reproduce", "--out", str(out), "--quiet", *extra]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_describe_cpu_tells_apart_cpus_of_one_name() -> None:
    zen3 = "processor\t: 0\nvendor_id\t: AuthenticAMD\ncpu family\t: 25\nmodel\t\t: 1\n"
    zen3 += "model name\t: AMD EPYC\nflags\t\t: fpu sse2 avx avx2 fma\n\nprocessor\t: 1\n"
    zen3 += "cpu family\t: 26\nmodel name\t: other\nflags\t\t: avx512f\n"
    assert describe_cpu(zen3) == "AMD EPYC (family 25, model 1; AVX2)"
    zen5 = "cpu family\t: 26\nmodel\t\t: 2\nmodel name\t: AMD EPYC\n"
    zen5 += "flags\t: avx2 avx512f avx512bw\n"
    assert describe_cpu(zen5) == "AMD EPYC (family 26, model 2; AVX-512)"
    assert describe_cpu("model name\t: Some CPU\nflags\t: sse2\n") == "Some CPU (no AVX2)"
    assert describe_cpu("") is None and describe_cpu("processor\t: 0\n") is None
