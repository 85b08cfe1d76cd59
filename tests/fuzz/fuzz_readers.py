"""Fuzz uavsnn's readers with atheris (libFuzzer for Python; runs on the stable toolchain).

    python tests/fuzz/fuzz_readers.py TARGET [--seconds S | --runs N] [-- LIBFUZZER_ARGS...]
    python tests/fuzz/fuzz_readers.py TARGET --replay FILE     # one input, e.g. a crash

TARGET is one of the folders of tests/fuzz/corpus (``npz``, ``npy``, ``csv``, ``aedat4``,
``model``, ``stdin_packed``, ``stdin_csv``, ``udp_t64``, ``udp_t32``, ``udp_spif``). The
fuzzer starts from those seeds, writes what it finds new into a temporary folder (never into
the corpus) and stops after ``--seconds`` (default 60) or ``--runs`` inputs. An input fails
when the reader raises anything but an error of the ``uavsnn.errors`` hierarchy, or the
process dies (a Rust panic crossing into Python, an abort, more than 2 GiB of memory);
libFuzzer then writes it to the printed artifact folder. :func:`check` is the whole contract,
shared with the bounded run of ``tests/test_fuzz.py``; docs/robustness.md has the budget and
the results.
"""

from __future__ import annotations

import argparse
import io
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

HERE = Path(__file__).resolve().parent
CORPUS = HERE / "corpus"
SENSOR = (16, 12)  # the seeds' sensor (make_corpus.py)


def _targets() -> dict[str, Callable[[bytes], object]]:
    import numpy as np

    from uavsnn import _core
    from uavsnn.detector import Detector
    from uavsnn.io import read
    from uavsnn.network import Network
    from uavsnn.sources import StdinSource

    scratch = Path(tempfile.mkdtemp(prefix="uavsnn-fuzz-"))
    model = Network.load(CORPUS / "model" / "small")

    def file_reader(suffix: str, **kwargs: object) -> Callable[[bytes], object]:
        def run(data: bytes) -> object:
            path = scratch / f"input{suffix}"
            path.write_bytes(data)
            # Files without geometry read both ways: with and without a size.
            size = kwargs.get("sensor_size", SENSOR if len(data) % 2 else None)
            return read(path, sensor_size=size)  # type: ignore[arg-type]

        return run

    def load_model(data: bytes) -> object:
        path = scratch / "model.npz"
        path.write_bytes(data)
        return Network.load(path)

    def stdin(fmt: str) -> Callable[[bytes], object]:
        def run(data: bytes) -> object:
            source = StdinSource(io.BytesIO(data), fmt=fmt, sensor_size=SENSOR, read_size=64)
            det = Detector(model, window_us=200, overlap=0.5)
            found = [det.push(chunk) for chunk in source]
            found.append(det.flush())
            return np.concatenate(found)

        return run

    def udp(fmt: str) -> Callable[[bytes], object]:
        def run(data: bytes) -> object:
            decoder = _core.PacketDecoder(fmt, *SENSOR)
            # The packet, then its two halves: the decoder's state carries over.
            out = [decoder.decode(data, 5)]
            half = len(data) // 2
            for part in (data[:half], data[half:]):
                try:
                    out.append(decoder.decode(part, 9))
                except UavsnnError:
                    pass
            return out

        return run

    from uavsnn.errors import UavsnnError

    return {
        "npz": file_reader(".npz"),
        "npy": file_reader(".npy"),
        "csv": file_reader(".csv"),
        "aedat4": file_reader(".aedat4"),
        "model": load_model,
        "stdin_packed": stdin("packed"),
        "stdin_csv": stdin("csv"),
        "udp_t64": udp("t64_x16_y16_on8"),
        "udp_t32": udp("t32_x16_y15_on1"),
        "udp_spif": udp("spif"),
    }


TARGETS = (
    "npz",
    "npy",
    "csv",
    "aedat4",
    "model",
    "stdin_packed",
    "stdin_csv",
    "udp_t64",
    "udp_t32",
    "udp_spif",
)
_cache: dict[str, Callable[[bytes], object]] = {}


def check(target: str, data: bytes) -> None:
    """Feed ``data`` to ``target``: it must return, or raise a ``uavsnn.errors`` error."""
    from uavsnn.errors import UavsnnError

    if not _cache:
        _cache.update(_targets())
    try:
        _cache[target](data)
    except UavsnnError:
        pass


def seeds(target: str) -> list[bytes]:
    return [p.read_bytes() for p in sorted((CORPUS / target).iterdir())]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("target", choices=TARGETS)
    budget = parser.add_mutually_exclusive_group()
    budget.add_argument("--seconds", type=int, default=60, help="time budget (default 60)")
    budget.add_argument("--runs", type=int, help="number of inputs instead of a time budget")
    budget.add_argument("--replay", type=Path, help="run one input and exit")
    parser.add_argument("libfuzzer", nargs="*", help="more libFuzzer flags, after '--'")
    args = parser.parse_args(argv)
    if args.replay is not None:
        check(args.target, args.replay.read_bytes())
        print(f"{args.replay}: ok")
        return 0

    import atheris

    # Coverage feedback from uavsnn's own Python modules only (NumPy and faery stay plain,
    # and the Rust decoders are not instrumented: tests/fuzz_decoders.rs covers those).
    import faery  # noqa: F401
    import numpy  # noqa: F401

    with atheris.instrument_imports(include=["uavsnn"]):
        import uavsnn.io
        import uavsnn.sources  # noqa: F401
    check(args.target, b"")  # build the targets before fuzzing starts
    found = tempfile.mkdtemp(prefix=f"uavsnn-fuzz-{args.target}-")
    limit = f"-runs={args.runs}" if args.runs is not None else f"-max_total_time={args.seconds}"
    flags = [limit, "-rss_limit_mb=2048", f"-artifact_prefix={found}/", "-print_final_stats=1"]
    print(f"fuzzing {args.target}: new inputs and failures go to {found}", flush=True)
    atheris.Setup(
        [sys.argv[0], *flags, *args.libfuzzer, found, str(CORPUS / args.target)],
        lambda data: check(args.target, data),
    )
    atheris.Fuzz()
    return 0


if __name__ == "__main__":
    sys.exit(main())
