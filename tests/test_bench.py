"""``uavsnn bench`` and :mod:`uavsnn.bench`: the bench windows, the figures' consistency with
the runs they come from, and bad input."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from uavsnn import Network, ParameterError
from uavsnn.bench import bench_density, synthetic_windows
from uavsnn.cli import main


def test_synthetic_windows_hold_the_share_of_pixels_asked_for() -> None:
    w = synthetic_windows(64, 48, 0.02, 4, seed=3, length_us=10_000)
    assert len(w) == 4 and w.sensor_size == (64, 48) and w.length_us == 10_000
    target = round(64 * 48 * 0.02)
    for i in range(4):
        t, x, y = w.spikes(i)
        # At least the target (an edge may overshoot it), each pixel once, in time order.
        assert target <= len(t) <= target + 80
        assert len(set(zip(x.tolist(), y.tolist(), strict=True))) == len(t)
        assert np.all(np.diff(t.astype(np.int64)) >= 0)
        assert int(t.min()) >= i * 10_000 and int(t.max()) < (i + 1) * 10_000
    again = synthetic_windows(64, 48, 0.02, 4, seed=3, length_us=10_000)
    assert np.array_equal(w.t, again.t) and np.array_equal(w.x, again.x)
    other = synthetic_windows(64, 48, 0.02, 4, seed=4, length_us=10_000)
    assert not np.array_equal(w.x, other.x)


@pytest.mark.parametrize(("density", "count"), [(0.0, 1), (1.5, 1), (0.01, 0)])
def test_synthetic_windows_refuse_bad_sizes(density: float, count: int) -> None:
    with pytest.raises(ParameterError):
        synthetic_windows(64, 48, density, count)


def test_figures_come_from_the_runs_they_describe() -> None:
    # Low thresholds, so that conv3 fires on some windows of the untrained network.
    net = Network(
        {"width": 64, "height": 48, "conv2": {"threshold": 8.0}, "conv3": {"threshold": 1.0}},
        seed=2,
    )
    row = bench_density(net, 0.05, windows=6, threads=2, repeat=2, seed=5)
    data = synthetic_windows(64, 48, 0.05, 6, seed=5)
    direct = net.infer(data, threads=1)
    assert row.sensor == "64x48" and row.windows == 6 and row.events == len(data.t)
    assert row.spikes_per_window["conv1"] == pytest.approx(direct.counts[:, 0].mean())
    assert row.spikes_per_window["conv3"] == pytest.approx(direct.counts[:, 4].mean())
    assert row.detected_windows == int(direct.detected.sum()) > 0
    assert row.threads == 2
    assert row.one_thread_ns_per_event * row.one_thread_events_per_s == pytest.approx(1e9)
    for value in (row.real_time_factor, row.scaling, row.stream_vs_batch):
        assert math.isfinite(value) and value > 0


def test_each_timed_run_follows_an_untimed_run_of_its_kind(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # The one-thread batch was timed right after the stream, which slowed it by about a fifth:
    # `--threads 1` read 1.12-1.18x one.
    import uavsnn.bench as bench_module

    calls: list[str] = []
    net = Network({"width": 32, "height": 24}, seed=1)
    infer = Network.infer

    def recorded(self: Network, windows: object, **kwargs: object) -> object:
        calls.append(f"batch {kwargs.get('threads')}")
        return infer(self, windows, **kwargs)

    def timed(fn: object) -> tuple[float, object]:
        calls.append("timed")
        return bench_module.time.perf_counter(), fn()

    class Recorded(bench_module.Detector):
        def __init__(self, *args: object, **kwargs: object) -> None:
            calls.append("stream")
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(Network, "infer", recorded)
    monkeypatch.setattr(bench_module, "_timed", timed)
    monkeypatch.setattr(bench_module, "Detector", Recorded)
    bench_density(net, 0.05, windows=2, threads=2, repeat=2, seed=1)
    one_round = ["batch 1", "timed", "batch 1", "batch 2", "timed", "batch 2"]
    one_round += ["stream", "timed", "stream"]
    assert calls == one_round * 2


def test_default_windows_hold_about_the_events_asked_for() -> None:
    net = Network({"width": 64, "height": 48}, seed=0)
    row = bench_density(net, 0.01, events=400, repeat=1)
    per_window = round(64 * 48 * 0.01)
    assert row.windows == math.ceil(400 / per_window)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"repeat": 0},
        {"threads": 0},
        {"chunk_us": 0},
        {"windows": 0},
        {"windows": 1.5},
        {"windows": None, "events": 0},
    ],
)
def test_bench_refuses_bad_parameters(kwargs: dict[str, int]) -> None:
    net = Network({"width": 64, "height": 48}, seed=0)
    with pytest.raises(ParameterError):
        bench_density(net, 0.01, **{"windows": 1, **kwargs})


def test_bench_refuses_more_spikes_than_it_makes_before_making_them() -> None:
    # 1280x720 at 5 %: 46,080 spikes a window; 10,000 windows (the most the default takes)
    # were 460 million spikes and gigabytes, asked for with --events 1e10.
    net = Network({"width": 1280, "height": 720}, seed=0)
    for kwargs in ({"windows": 3000}, {"windows": None, "events": 10**10}):
        with pytest.raises(ParameterError, match="more than 100,000,000 spikes"):
            bench_density(net, 0.05, repeat=1, **kwargs)


def test_cli_windows_is_a_count_named_in_its_error(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["bench", "--size", "64x48", "--windows", "0"])
    assert exc.value.code == 2
    assert "--windows" in capsys.readouterr().err


def test_cli_json_and_text(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["bench", "--size", "64x48", "--density", "1,5", "--windows", "2", "--repeat", "1"]
    assert main([*args, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["model"] is None
    assert [r["density_percent"] for r in out["rows"]] == [1.0, 5.0]
    assert all(r["sensor"] == "64x48" and r["windows"] == 2 for r in out["rows"])
    assert all(r["stream_chunk_us"] == 1000 for r in out["rows"])
    assert main([*args, "--json", "--chunk-ms", "12.5"]) == 0
    assert {r["stream_chunk_us"] for r in json.loads(capsys.readouterr().out)["rows"]} == {12500}

    model = tmp_path / "m.npz"
    Network({"width": 80, "height": 60}, seed=1).save(model)
    assert main(["bench", "--model", str(model), "--density", "1", "--windows", "1"]) == 0
    text = capsys.readouterr().out
    assert "80x60 1 %" in text and "ns/event" in text and "real time" in text


def test_cli_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "--model", str(tmp_path / "missing.npz")]) == 2
    assert "error" in capsys.readouterr().err
    for size in ("0x48", "64", "axb"):
        assert main(["bench", "--size", size, "--windows", "1"]) == 2
    for bad in (["--density", "0"], ["--density", "150"], ["--density", "x"]):
        with pytest.raises(SystemExit) as exc:
            main(["bench", *bad])
        assert exc.value.code == 2
    for chunk in ("0", "-1", "nan", "inf", "1e9"):
        assert main(["bench", "--size", "64x48", "--windows", "1", "--chunk-ms", chunk]) == 2
        assert "--chunk-ms must be" in capsys.readouterr().err


def test_cli_events_as_its_help_writes_them(capsys: pytest.CaptureFixture[str]) -> None:
    # The help gives the default as 3e5, which the option refused ("invalid int value"); and a
    # count of 0 or below ran one window instead of being refused.
    from uavsnn.cli import _build_parser

    parser = _build_parser("bench")
    assert parser.parse_args(["bench", "--events", "3e5"]).events == 300_000
    assert parser.parse_args(["bench", "--events", "1000"]).events == 1000
    for bad in ("0", "-5", "2.5", "nan", "1e400"):
        with pytest.raises(SystemExit) as exc:
            main(["bench", "--events", bad])
        assert exc.value.code == 2
        assert "whole number" in capsys.readouterr().err
