"""The package as a user imports it: the submodules the docs call through ``import uavsnn``
(``uavsnn.io.read(...)``), and the names a type checker sees."""

from __future__ import annotations

import pkgutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import uavsnn


def test_every_public_submodule_is_reachable_from_the_package() -> None:
    found = {m.name for m in pkgutil.iter_modules(uavsnn.__path__) if not m.name.startswith("_")}
    assert found == uavsnn.SUBMODULES
    assert uavsnn.SUBMODULES <= set(dir(uavsnn))


def test_window_reports_can_still_be_imported_from_the_detector_module() -> None:
    # They lived in uavsnn.detector before uavsnn.grouping: a program's imports, and reports
    # pickled by an older uavsnn (Ray sends them between processes), still find them there.
    import pickle

    import uavsnn.detector
    import uavsnn.grouping

    for name in uavsnn.grouping.__all__:
        assert getattr(uavsnn.detector, name) is getattr(uavsnn.grouping, name)
        assert name in uavsnn.detector.__all__
    old = pickle.dumps(uavsnn.grouping.WindowObject(box=(1, 2, 3, 4), spikes=5)).replace(
        b"uavsnn.grouping", b"uavsnn.detector"
    )
    assert pickle.loads(old) == uavsnn.grouping.WindowObject(box=(1, 2, 3, 4), spikes=5)


def test_submodules_are_imported_on_first_use() -> None:
    # A fresh interpreter: ``import uavsnn`` leaves the simulator and the file readers
    # unimported, and the docs' dotted calls import them.
    code = textwrap.dedent(
        """
        import sys
        import uavsnn
        assert "uavsnn.sim" not in sys.modules and "uavsnn.io" not in sys.modules
        assert uavsnn.io.read is sys.modules["uavsnn.io"].read
        assert callable(uavsnn.sim.emulate_dvs) and callable(uavsnn.dataset.find_clips)
        try:
            uavsnn.nosuch
        except AttributeError as exc:
            assert "'uavsnn' has no attribute 'nosuch'" in str(exc)
        else:
            raise SystemExit("uavsnn.nosuch was found")
        """
    )
    subprocess.run([sys.executable, "-W", "error", "-c", code], check=True, timeout=120)


MYPY = [sys.executable, "-m", "mypy", "--strict", "--no-error-summary"]


def test_a_type_checker_sees_the_real_names(tmp_path: Path) -> None:
    pytest.importorskip("mypy", reason="mypy (the test extra) checks what a user's checker sees")
    script = tmp_path / "user.py"
    script.write_text(
        textwrap.dedent(
            """
            import numpy as np
            import uavsnn.detector

            ok = np.zeros(2, dtype=uavsnn.detector.DETECTION_DTYPE)
            bad = uavsnn.detector.WINDOW_DETECTON_DTYPE

            # Every submodule as an attribute of the package, as the docs call them (a
            # checker saw none that the package's own imports did not happen to load).
            import uavsnn
            from uavsnn.sources import FileSource

            calls = (uavsnn.evaluation.evaluate, uavsnn.roc.roc_curve, uavsnn.training.train)
            names = (uavsnn.clips, uavsnn.bench, uavsnn.pictures, uavsnn.report, uavsnn.io)
            # A source's own type through `with` (it was EventSource: no `recording`).
            with FileSource("r.npz") as source:
                events = source.recording.events
            """
        )
    )
    run = subprocess.run(
        [*MYPY, f"--cache-dir={tmp_path / 'cache'}", str(script)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    # The misspelt name is caught, the deprecated one still types as a dtype, and the rest
    # type-checks.
    errors = run.stdout.strip().splitlines()
    assert len(errors) == 1 and ':6: error: Module has no attribute "WINDOW_DETECTON' in errors[0]
