"""One progress rule for every long command: a tqdm bar on a terminal, plain lines (when the
work starts, at most every EVERY_S seconds, when it ends; never a carriage return) when
standard error is piped, nothing with --quiet."""

from __future__ import annotations

import errno
import io
import os
import subprocess
import sys
from pathlib import Path

from uavsnn.progress import EVERY_S, LineProgress, bar


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_lines_start_at_most_every_interval_and_end() -> None:
    out, clock = io.StringIO(), Clock()
    p = LineProgress(100, "train conv2", " window", stream=out, clock=clock)
    for i in range(100):
        clock.now = i * 1.0  # 1 s per step: a line every EVERY_S steps
        p.set_postfix_str(f"C={i}")
        p.update(1)
    p.close()
    p.close()  # once only
    lines = out.getvalue().splitlines()
    assert "\r" not in out.getvalue()
    assert lines[0] == "train conv2: 0/100 windows (0 s)"
    assert lines[-1] == "train conv2: 100/100 windows [C=99] (99 s) done"
    assert len(lines) == 2 + int(99 // EVERY_S)
    assert lines[1].startswith("train conv2: 11/100 windows [C=10] (10 s)")


def test_a_progress_line_the_reader_cannot_take_does_not_stop_the_work() -> None:
    """Standard error piped to a reader that went away: Linux raises BrokenPipeError,
    Windows OSError(EINVAL); either way the work goes on without its progress lines."""

    class Gone(io.StringIO):
        def __init__(self, exc: OSError) -> None:
            super().__init__()
            self.exc = exc

        def write(self, text: str) -> int:
            raise self.exc

    for exc in (BrokenPipeError(), OSError(errno.EINVAL, "Invalid argument")):
        clock = Clock()
        p = LineProgress(10, "train conv2", stream=Gone(exc), clock=clock)
        clock.now = 100.0
        p.update(10)
        p.close()
        assert p.n == 10


def test_bar_is_lines_when_stderr_is_not_a_terminal(capsys) -> None:
    p = bar(total=3, desc="x", unit="step")
    assert isinstance(p, LineProgress)
    p.update(3)
    p.close()
    assert capsys.readouterr().err == "x: 0/3 steps (0 s)\nx: 3/3 steps (0 s) done\n"


def run(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "uavsnn", *args],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        cwd=cwd,
        env=dict(os.environ),
    )


def test_piped_commands_print_plain_progress_lines(tmp_path: Path) -> None:
    """bench, dataset build and train, their standard error piped: plain lines, no carriage
    return; --quiet: none."""
    done = run("bench", "--events", "3000", "--repeat", "1", "--density", "1", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stderr.splitlines() == ["bench: 0/1 density (0 s)", "bench: 1/1 density (0 s) done"]
    quiet = run("bench", "--events", "3000", "--repeat", "1", "--density", "1", "--quiet",
                cwd=tmp_path)  # fmt: skip
    assert quiet.returncode == 0 and quiet.stderr == ""

    # A tiny dataset, then a model trained on it: the same rule.
    built = run("dataset", "build", "data", "--domain", "dvs", "--n-train", "20", "--n-test", "10",
                cwd=tmp_path)  # fmt: skip
    assert built.returncode == 0, built.stderr
    lines = built.stderr.splitlines()
    assert "\r" not in built.stderr and lines[0] == "dataset: started"
    assert " steps (" in lines[-1] and lines[-1].endswith(" done")
    trained = run("train", "data", "-o", "m.npz", "--windows-per-layer", "20", cwd=tmp_path)
    assert trained.returncode == 0, trained.stderr
    lines = trained.stderr.splitlines()
    assert "\r" not in trained.stderr
    for layer in ("conv2", "conv3"):
        assert f"train {layer}: 0/20 windows (0 s)" in lines
        assert any(
            s.startswith(f"train {layer}: 20/20 windows [C=") and s.endswith("done") for s in lines
        )


def test_piped_simulate_prints_lines_not_carriage_returns(tmp_path: Path) -> None:
    from test_video import write_video

    video = write_video(tmp_path / "square.avi")
    done = run("simulate", str(video), "-o", "out.npz", "--size", "120x90", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "\r" not in done.stderr
    lines = [s for s in done.stderr.splitlines() if s.startswith("square.avi:")]
    assert lines[0].startswith("square.avi: 0/") and lines[-1].endswith(" done")


def test_a_line_counts_its_unit_in_the_plural_but_for_one() -> None:
    # "bench: 0/3 density", "dataset: 8 step": tqdm's unit is a singular (its "step/s").
    for total, unit, want in ((3, "density", "0/3 densities"), (2, "day", "0/2 days"),
                              (1, "density", "0/1 density")):  # fmt: skip
        out = io.StringIO()
        LineProgress(total, "x", unit, stream=out, clock=Clock())
        assert out.getvalue().startswith(f"x: {want} ("), out.getvalue()


def test_an_unknown_total_starts_with_started_not_zero_steps() -> None:
    # `dataset build` counts steps of a total it does not know: its first line read "0 steps".
    out, clock = io.StringIO(), Clock()
    p = LineProgress(None, "dataset", " step", stream=out, clock=clock)
    clock.now = 20.0
    p.update(2)
    p.close()
    assert out.getvalue().splitlines() == [
        "dataset: started",
        "dataset: 2 steps (20 s)",
        "dataset: 2 steps (20 s) done",
    ]
