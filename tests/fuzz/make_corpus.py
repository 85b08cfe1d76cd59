"""Write the fuzzers' seed corpus (tests/fuzz/corpus/TARGET/*): small valid inputs of every
parser, plus a few edge cases. Rerun after a format change:

    python tests/fuzz/make_corpus.py

The fuzzers (tests/fuzz/fuzz_readers.py for the Python readers, tests/fuzz_decoders.rs for
the Rust decoders) start from these and mutate them; docs/robustness.md says how to run them.
"""

from __future__ import annotations

import io
import struct
import tempfile
from pathlib import Path

import numpy as np

from uavsnn import EVENT_DTYPE, Recording
from uavsnn.io import write_npz
from uavsnn.network import Network

CORPUS = Path(__file__).resolve().parent / "corpus"
#: The sensor every seed's events lie in (and the fuzz targets check against).
SENSOR = (16, 12)
#: A network small enough that its model file is 2.5 kB.
SMALL_MODEL = {
    "width": SENSOR[0],
    "height": SENSOR[1],
    "conv1": {"maps": 2},
    "conv2": {"maps": 2, "kernel": 3},
    "conv3": {"maps": 1, "kernel": 3},
}


def events(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    ev = np.zeros(n, dtype=EVENT_DTYPE)
    ev["t"] = 1_000 + np.cumsum(rng.integers(0, 50, n))
    ev["x"] = rng.integers(0, SENSOR[0], n)
    ev["y"] = rng.integers(0, SENSOR[1], n)
    ev["p"] = rng.random(n) < 0.5
    return ev


def t32(ev: np.ndarray) -> bytes:
    return b"".join(
        struct.pack("<IHH", int(e["t"]) & 0xFFFFFFFF, int(e["x"]), int(e["y"]) << 1 | int(e["p"]))
        for e in ev
    )


def spif(ev: np.ndarray, stamped: bool) -> bytes:
    words = []
    for e in ev:
        word = int(e["x"]) << 16 | int(e["p"]) << 15 | int(e["y"])
        if stamped:
            words += [word, int(e["t"]) & 0xFFFFFFFF]
        else:
            words.append(word | 1 << 31)
    return struct.pack(f"<{len(words)}I", *words)


def csv(ev: np.ndarray, header: bool) -> bytes:
    lines = ["t,x,y,p"] if header else []
    lines += [f"{e['t']},{e['x']},{e['y']},{int(e['p'])}" for e in ev]
    return ("\n".join(lines) + "\n").encode()


def npz(recording: Recording) -> bytes:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "r.npz"
        write_npz(recording, path)
        return path.read_bytes()


def npy(array: np.ndarray) -> bytes:
    out = io.BytesIO()
    np.save(out, array, allow_pickle=False)
    return out.getvalue()


def aedat4(ev: np.ndarray) -> bytes:
    """An AEDAT4 file of ``ev`` as faery writes it (its IOHeader, one LZ4 packet, the data
    table)."""
    import faery

    out = np.zeros(len(ev), faery.EVENTS_DTYPE)
    for name in ("t", "x", "y"):
        out[name] = ev[name]
    out["on"] = ev["p"]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "seed.aedat4"
        faery.events_stream_from_array(out, SENSOR).to_file(path, zero_t0=False)
        return path.read_bytes()


def seeds() -> dict[str, dict[str, bytes]]:
    a, b = events(20, 1), events(3, 2)
    wrapped = events(4, 3)
    wrapped["t"] += (1 << 32) - 1_030  # crosses the 32-bit wrap
    with tempfile.TemporaryDirectory() as tmp:
        Network(SMALL_MODEL, seed=0).save(Path(tmp) / "m.npz")
        model_bytes = (Path(tmp) / "m.npz").read_bytes()
    return {
        "udp_t64": {"20": a.tobytes(), "3": b.tobytes(), "empty": b"", "partial": b"\0" * 12},
        "udp_t32": {"20": t32(a), "wrap": t32(wrapped), "3": t32(b)},
        "udp_spif": {"stamped": spif(a, True), "unstamped": spif(b, False)},
        "stdin_packed": {"20": a.tobytes(), "cut": a.tobytes()[:-5]},
        "stdin_csv": {"header": csv(a, True), "bare": csv(b, False), "junk": b"t,x\n1,2,3\n"},
        "csv": {"header": csv(a, True), "bare": csv(b, False)},
        "aedat4": {"events": aedat4(a)},
        "npy": {"events": npy(a), "empty": npy(a[:0]), "ints": npy(np.arange(6))},
        "npz": {"recording": npz(Recording(a, SENSOR)), "empty": npz(Recording(a[:0], SENSOR))},
        "model": {"small": model_bytes},
    }


def main() -> None:
    for target, files in seeds().items():
        folder = CORPUS / target
        folder.mkdir(parents=True, exist_ok=True)
        for old in folder.iterdir():
            old.unlink()
        for name, data in files.items():
            (folder / name).write_bytes(data)
    print(f"wrote {sum(len(f) for f in seeds().values())} seeds under {CORPUS}")


if __name__ == "__main__":
    main()
