"""The readers under fuzzed bytes, a bounded run inside the suite (docs/robustness.md): every
seed of tests/fuzz/corpus and every input the fuzzers once failed on (tests/fuzz/regressions)
replays cleanly, hypothesis feeds each target random and mutated bytes, and, where atheris is
installed, each atheris harness runs a few hundred inputs. The contract is
``tests/fuzz/fuzz_readers.py``'s ``check``: a reader returns or raises a ``uavsnn.errors``
error, nothing else."""

from __future__ import annotations

import importlib.util
import io
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uavsnn.sources import StdinSource

FUZZ = Path(__file__).resolve().parent / "fuzz"
spec = importlib.util.spec_from_file_location("fuzz_readers", FUZZ / "fuzz_readers.py")
assert spec is not None and spec.loader is not None
fuzz = importlib.util.module_from_spec(spec)
spec.loader.exec_module(fuzz)


def regressions(target: str) -> list[bytes]:
    folder = FUZZ / "regressions" / target
    return [p.read_bytes() for p in sorted(folder.iterdir())] if folder.is_dir() else []


@pytest.mark.parametrize("target", fuzz.TARGETS)
def test_seeds_and_past_failures_replay(target: str) -> None:
    inputs = fuzz.seeds(target) + regressions(target)
    assert inputs
    for data in inputs:
        fuzz.check(target, data)


@st.composite
def mutated(draw: st.DrawFn, target: str) -> bytes:
    """A seed with a few bytes overwritten, inserted or cut, or plain random bytes."""
    if draw(st.booleans()):
        return draw(st.binary(max_size=300))
    data = bytearray(draw(st.sampled_from(fuzz.seeds(target))))
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(data)))
        kind = draw(st.sampled_from(["set", "insert", "cut"]))
        if kind == "set" and at < len(data):
            data[at] = draw(st.integers(0, 255))
        elif kind == "insert":
            data[at:at] = draw(st.binary(min_size=1, max_size=12))
        else:
            del data[at : at + draw(st.integers(1, 16))]
    return bytes(data)


@pytest.mark.parametrize("target", fuzz.TARGETS)
@settings(max_examples=60, deadline=None)
@given(data=st.data())
def test_fuzzed_bytes_give_typed_errors(target: str, data: st.DataObject) -> None:
    fuzz.check(target, data.draw(mutated(target)))


def test_a_csv_time_beyond_64_bits_is_a_dropped_line() -> None:
    """Found by the atheris harness: a time of 20 digits made NumPy raise OverflowError out of
    the standard-input reader; it is a malformed line like a negative time."""
    text = b"t,x,y,p\n5,1,2,1\n115555555555555555555555,7,1,1\n7,2,2,0\n"
    source = StdinSource(io.BytesIO(text), fmt="csv", sensor_size=(16, 12))
    got = [e for chunk in source for e in chunk]
    assert [int(e["t"]) for e in got] == [5, 7]
    assert source.stats.dropped == 1


@pytest.mark.parametrize("target", fuzz.TARGETS)
def test_atheris_harness_runs(target: str, tmp_path: Path) -> None:
    pytest.importorskip("atheris")
    done = subprocess.run(
        [sys.executable, str(FUZZ / "fuzz_readers.py"), target, "--runs", "200"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
        check=False,
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert "Done 200 runs" in done.stderr


@pytest.mark.parametrize("shape", [(0,), (2,)])
def test_a_sub_array_field_is_an_event_error(shape: tuple[int, ...], tmp_path: Path) -> None:
    """Found by the atheris harness: an .npy whose 'y' field holds an array per event made
    convert raise NumPy's ValueError ("could not broadcast") instead of a typed error."""
    import numpy as np

    from uavsnn import EventError, RecordingFileError
    from uavsnn.events import convert
    from uavsnn.io import read

    dtype = np.dtype([("t", "<u8"), ("x", "<u2"), ("y", "<u2", shape), ("p", "?")])
    events = np.zeros(3, dtype=dtype)
    with pytest.raises(EventError, match="field 'y' must hold one number per event"):
        convert(events)
    np.save(tmp_path / "e.npy", events)
    with pytest.raises(RecordingFileError, match="one number per event"):
        read(tmp_path / "e.npy", sensor_size=(16, 12))
