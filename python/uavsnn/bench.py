"""How fast the engine runs on this machine: the figures of ``uavsnn bench``.

The windows are the synthetic scenes of the Criterion benches (``benches/engine.rs``): short
edges sweeping sideways for 80 % of the active pixels, uniform noise for the rest, the first spike
per pixel, at a given share of the sensor's pixels per window. Each figure is paired with a
reference measured in the same run, so that the ratios hold on a busy machine too:

- **one thread**: ``Network.infer(threads=1)``, the least wall time of ``repeat`` runs, as ns
  per input event and events per second (Python's share of the call included); and the
  real-time factor, the event time the windows cover over that time;
- **all threads**: the same batch on ``threads`` workers, wall time; its reference is the
  one-thread run's wall time (the scaling);
- **stream**: the same spikes as one stream through :class:`uavsnn.Detector` (windows of the
  same length, no overlap) in chunks of ``chunk_us`` of event time, wall time; its reference is
  again the one-thread batch's wall time.

The three kinds of run take turns, ``repeat`` times, so that a machine whose speed drifts slows
them alike; each timed run comes right after an untimed run of its own kind, so that no kind is
timed in the wake of another (a one-thread batch timed right after a stream ran about a fifth
slower: ``--threads 1`` read 1.12-1.18x one).

The network's activity, and so its cost, depends on its weights: pass a trained model to see
what a deployment costs (an untrained network's conv2 and conv3 fire less).
"""

from __future__ import annotations

import itertools
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any, TypeVar

import numpy as np

from uavsnn._validate import check_int
from uavsnn.detector import Detector
from uavsnn.errors import ParameterError
from uavsnn.events import EVENT_DTYPE
from uavsnn.network import LAYERS, MAX_THREADS, Inference, Network
from uavsnn.windows import Windows

__all__ = [
    "DEFAULT_EVENTS",
    "DENSITIES",
    "MAX_BENCH_REPEAT",
    "MAX_BENCH_SPIKES",
    "BenchRow",
    "bench",
    "bench_density",
    "synthetic_spikes",
    "synthetic_windows",
]

#: Shares of the pixels active per window that ``uavsnn bench`` measures by default (as the
#: Criterion benches do).
DENSITIES = (0.001, 0.01, 0.05)

#: Input events per density that :func:`bench_density` sizes its windows for by default.
DEFAULT_EVENTS = 300_000

#: The most input spikes one density's bench windows hold (about 1.2 GB with their stream):
#: ``windows`` or ``events`` asking for more is refused, not hours of work and all memory.
MAX_BENCH_SPIKES = 10**8

#: The most runs of each figure (``repeat``; the default is 5): more is refused, not a bench
#: that runs for days.
MAX_BENCH_REPEAT = 100

_T = TypeVar("_T")


def _active_pixels(width: int, height: int, density: float) -> int:
    """The pixels a bench window of ``density`` aims at (at least one)."""
    return max(1, round(width * height * density))


def synthetic_spikes(
    rng: np.random.Generator,
    width: int,
    height: int,
    density: float,
    t0: int,
    length_us: int = 50_000,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One window of the bench scenes: ``density`` of the pixels active, 80 % on short edges
    (5–20 px) sweeping sideways for 1–4 px, 20 % uniform noise; the first spike per pixel,
    sorted by time, inside ``[t0, t0 + length_us)``. Returns ``(t, x, y)`` as uint64/uint16."""
    target = _active_pixels(width, height, density)
    seen = np.zeros((height, width), dtype=bool)
    spikes: list[tuple[int, int, int]] = []

    def add(t: int, x: int, y: int) -> None:
        if 0 <= x < width and 0 <= y < height and not seen[y, x]:
            seen[y, x] = True
            spikes.append((t, x, y))

    while len(spikes) < target * 4 // 5:
        x0, y0 = rng.uniform(0, width), rng.uniform(0, height)
        angle = rng.uniform(0, np.pi)
        length, sweep = int(rng.integers(5, 21)), int(rng.integers(1, 5))
        start, pace = int(rng.integers(0, length_us // 2)), int(rng.integers(50, 500))
        for s in range(sweep):
            for i in range(length):
                x = x0 + i * np.cos(angle) - s * np.sin(angle)
                y = y0 + i * np.sin(angle) + s * np.cos(angle)
                add(min(t0 + start + s * pace + i * 7, t0 + length_us - 1), int(x), int(y))
    while len(spikes) < target:
        add(
            t0 + int(rng.integers(0, length_us)),
            int(rng.integers(width)),
            int(rng.integers(height)),
        )
    spikes.sort(key=lambda s: s[0])
    t, x, y = (np.array(c) for c in zip(*spikes, strict=True))
    return t.astype(np.uint64), x.astype(np.uint16), y.astype(np.uint16)


def synthetic_windows(
    width: int,
    height: int,
    density: float,
    count: int,
    *,
    seed: int = 0,
    length_us: int = 50_000,
) -> Windows:
    """``count`` consecutive bench windows (window ``i`` starts at ``i · length_us``)."""
    if not 0 < density <= 1:
        raise ParameterError(f"density must be in (0, 1], got {density}")
    if count < 1:
        raise ParameterError(f"count must be at least 1, got {count}")
    rng = np.random.default_rng(seed)
    parts = [
        synthetic_spikes(rng, width, height, density, i * length_us, length_us)
        for i in range(count)
    ]
    lengths = [len(p[0]) for p in parts]
    return Windows(
        sensor_size=(width, height),
        length_us=length_us,
        t0=np.arange(count, dtype=np.uint64) * np.uint64(length_us),
        offsets=np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
        t=np.concatenate([p[0] for p in parts]),
        x=np.concatenate([p[1] for p in parts]),
        y=np.concatenate([p[2] for p in parts]),
        n_preceding=np.zeros(count, dtype=np.int64),
    )


@dataclass(frozen=True)
class BenchRow:
    """The figures of one density (see the module docs for what each measures)."""

    sensor: str
    density_percent: float
    windows: int
    events: int
    spikes_per_window: dict[str, float]
    detected_windows: int
    one_thread_ns_per_event: float
    one_thread_events_per_s: float
    real_time_factor: float
    threads: int
    all_threads_events_per_s: float
    scaling: float
    stream_events_per_s: float
    stream_vs_batch: float
    stream_chunk_us: int

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def _timed(fn: Callable[[], _T]) -> tuple[float, _T]:
    """Wall time of one call of ``fn``, and its result."""
    start = time.perf_counter()
    out = fn()
    return time.perf_counter() - start, out


def _after_one(fn: Callable[[], _T]) -> tuple[float, _T]:
    """Wall time of a call of ``fn`` made right after an untimed one, and its result."""
    fn()
    return _timed(fn)


def _stream(network: Network, windows: Windows, chunk_us: int) -> Callable[[], None]:
    """A run that pushes the windows' spikes through a new Detector as one stream."""
    events = np.zeros(len(windows.t), dtype=EVENT_DTYPE)
    events["t"], events["x"], events["y"], events["p"] = windows.t, windows.x, windows.y, True
    t_end = int(windows.t0[-1]) + windows.length_us
    edges = np.searchsorted(events["t"], np.arange(0, t_end + chunk_us, chunk_us, dtype=np.uint64))
    chunks = [events[a:b] for a, b in itertools.pairwise(edges) if b > a]

    def run() -> None:
        det = Detector(network, window_us=windows.length_us, overlap=0.0, start_us=0)
        for chunk in chunks:
            det.push(chunk)
        det.flush()

    return run


def bench_density(
    network: Network,
    density: float,
    *,
    windows: int | None = None,
    events: int = DEFAULT_EVENTS,
    threads: int | None = None,
    repeat: int = 5,
    chunk_us: int = 1_000,
    seed: int = 0,
) -> BenchRow:
    """Measure the engine on ``windows`` bench windows at ``density`` (see the module docs);
    by default on as many windows as hold about ``events`` input events (at most 10,000), so
    that the fixed cost of a call does not weigh on sparse windows. ``events`` is not read
    when ``windows`` is given (``uavsnn bench`` refuses both).

    Raises:
        ParameterError: ``repeat`` outside ``1..=MAX_BENCH_REPEAT``, ``threads`` outside
            ``1..=uavsnn.network.MAX_THREADS`` (both checked before any run), or windows of
            more than :data:`MAX_BENCH_SPIKES` spikes.
    """
    repeat = check_int("repeat", repeat, 1, MAX_BENCH_REPEAT)
    if chunk_us < 1:
        raise ParameterError(f"chunk_us must be at least 1, got {chunk_us}")
    # Checked before any run (Network.infer would refuse it only after the one-thread run).
    workers = (
        min(os.cpu_count() or 1, MAX_THREADS)
        if threads is None
        else check_int("threads", threads, 1, MAX_THREADS)
    )
    width, height = int(network.config["width"]), int(network.config["height"])
    per_window = _active_pixels(width, height, density)
    if windows is None:
        windows = min(10_000, max(1, -(-check_int("events", events, 1) // per_window)))
    windows = check_int("windows", windows, 1)
    if windows * per_window > MAX_BENCH_SPIKES:
        raise ParameterError(
            f"{windows} windows of {per_window} spikes ({width}x{height} at {density:.3g} "
            f"active) hold more than {MAX_BENCH_SPIKES:,} spikes, the most a bench makes: ask "
            "for fewer windows or events"
        )
    data = synthetic_windows(width, height, density, windows, seed=seed)
    spikes = len(data.t)
    stream = _stream(network, data, chunk_us)
    one_wall_s = all_wall_s = stream_s = float("inf")

    def run_one() -> Inference:
        return network.infer(data, threads=1)

    def run_all() -> Inference:
        return network.infer(data, threads=workers)

    for _ in range(repeat):
        one_s, result = _after_one(run_one)
        all_s, _ = _after_one(run_all)
        stream_one_s, _ = _after_one(stream)
        one_wall_s, all_wall_s = min(one_wall_s, one_s), min(all_wall_s, all_s)
        stream_s = min(stream_s, stream_one_s)
    per_layer = result.counts.mean(axis=0)
    return BenchRow(
        sensor=f"{width}x{height}",
        density_percent=100 * density,
        windows=windows,
        events=spikes,
        spikes_per_window={name: float(v) for name, v in zip(LAYERS, per_layer, strict=True)},
        detected_windows=int(result.detected.sum()),
        one_thread_ns_per_event=one_wall_s / spikes * 1e9,
        one_thread_events_per_s=spikes / one_wall_s,
        real_time_factor=windows * data.length_us * 1e-6 / one_wall_s,
        threads=workers,
        all_threads_events_per_s=spikes / all_wall_s,
        scaling=one_wall_s / all_wall_s,
        stream_events_per_s=spikes / stream_s,
        stream_vs_batch=one_wall_s / stream_s,
        stream_chunk_us=chunk_us,
    )


def bench(
    network: Network, densities: Sequence[float] = DENSITIES, **kwargs: Any
) -> list[BenchRow]:
    """:func:`bench_density` at each of ``densities``."""
    return [bench_density(network, d, **kwargs) for d in densities]
