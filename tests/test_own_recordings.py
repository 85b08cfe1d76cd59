"""docs/dataset.md, "Your own event recordings": the code there runs as written, on event files
of one's own (a recording with a drone-like blob, and ones without), and what it reports holds
(the windows, labels and recordings it builds; figures on the test recordings)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn.events import EVENT_DTYPE, Recording
from uavsnn.io import write_npz

DOC = Path(__file__).resolve().parent.parent / "docs" / "dataset.md"


def _doc_code() -> str:
    text = DOC.read_text(encoding="utf-8")
    section = text[text.index("### Your own event recordings") :]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)  # type: ignore[union-attr]


def _recording(path: Path, seed: int, blob: bool) -> Path:
    """0.3 s of a 346x260 camera: noise, and with ``blob`` a small moving square."""
    rng = np.random.default_rng(seed)
    n = 6000
    ev = np.zeros(n, EVENT_DTYPE)
    ev["t"] = np.sort(rng.integers(0, 300_000, n))
    ev["x"] = rng.integers(0, 346, n)
    ev["y"] = rng.integers(0, 260, n)
    ev["p"] = rng.integers(0, 2, n)
    if blob:
        k = np.arange(0, n, 2)
        ev["x"][k] = 100 + (ev["t"][k] // 10_000) % 60 + rng.integers(0, 6, len(k))
        ev["y"][k] = 120 + rng.integers(0, 6, len(k))
    write_npz(Recording(ev, (346, 260)), path)
    return path


def test_the_documented_code_for_your_own_recordings_runs(tmp_path: Path) -> None:
    files = [_recording(tmp_path / f"r{i}.npz", i, blob=i % 2 == 0) for i in range(4)]

    def uav(i: int) -> Any:
        return lambda t0, t1: i % 2 == 0 and t0 >= 100_000  # in view from 0.1 s on

    code = _doc_code().replace("windows_per_layer=20_000", "windows_per_layer=20")
    code = code.replace("print(figures.accuracy, figures.confusion.tolist())", "")
    scope: dict[str, Any] = {
        "my_train_recordings": [(files[i], uav(i)) for i in (0, 1)],
        "my_test_recordings": [(files[i], uav(i)) for i in (2, 3)],
    }
    exec(compile(code, str(DOC), "exec"), scope)  # the documented code itself
    test_set, figures = scope["test_set"], scope["figures"]
    assert test_set.windows.sensor_size == (240, 180)
    assert set(np.unique(test_set.recording).tolist()) == {0, 1}
    assert test_set.label.any() and not test_set.label.all()
    assert set(np.unique(test_set.cls).tolist()) == {"drone", "none"}
    assert figures.windows == len(test_set) and sum(map(sum, figures.confusion.tolist())) == len(
        test_set
    )
    assert np.isnan(figures.accuracy_interval).all()  # two test recordings: no interval
