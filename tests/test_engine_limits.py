"""The engine's limits: inputs that would index out of bounds, wrap an integer, or ask for more
memory than a documented cap are refused with a typed error before anything is read or
allocated, and leave stateful objects usable. Each test stays cheap: the refusal comes before
the allocation."""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np
import pytest

import uavsnn
from uavsnn import _core
from uavsnn.events import EVENT_DTYPE, Recording
from uavsnn.filters import denoise
from uavsnn.network import Network
from uavsnn.sim.dvs import DvsEmulator, DvsParams
from uavsnn.sim.pix2nvs import Pix2NvsSimulator
from uavsnn.windows import Windows, add_noise, make_windows

U64_MAX = 2**64 - 1
MAX_TIME_US = 1 << 62
HUGE = (65535, 65535)


def empty_windows(sensor_size: tuple[int, int], n: int = 1, t0: int = 0) -> Windows:
    return Windows(
        sensor_size,
        10,
        np.full(n, t0, np.uint64),
        np.zeros(n + 1, np.int64),
        np.zeros(0, np.uint64),
        np.zeros(0, np.uint16),
        np.zeros(0, np.uint16),
        np.zeros(n, np.int64),
    )


def events(rows: list[tuple[int, int, int]]) -> np.ndarray:
    out = np.zeros(len(rows), EVENT_DTYPE)
    for i, (t, x, y) in enumerate(rows):
        out[i] = (t, x, y, True)
    return out


# 1. Offsets are all checked before any spike is read.
@pytest.mark.parametrize("middle", [100, -1])
def test_windows_offsets_past_the_spikes_are_refused(middle: int) -> None:
    zeros = np.zeros(5, np.uint64)
    small = np.zeros(5, np.uint16)
    with pytest.raises(uavsnn.ShapeError, match="non-decreasing"):
        Windows((4, 4), 10, [0, 0], [0, middle, 5], zeros, small, small, [0, 0])
    # The raw check too (it backs every binding that takes windows).
    with pytest.raises(uavsnn.ShapeError, match="offsets"):
        _core.check_windows(
            4, 4, 10, np.zeros(2, np.uint64), np.array([0, middle, 5]), zeros, small, small
        )


# 2. Sub-frame patches whose offsets wrap are refused, and the emulator is left as it was.
@pytest.mark.parametrize(("x0", "y0"), [(U64_MAX, 0), (0, U64_MAX - 1), (2**63, 2**63)])
def test_dvs_patch_offsets_that_wrap_are_refused(x0: int, y0: int) -> None:
    emu = DvsEmulator((4, 4), params=DvsParams(), seed=0)
    frame = np.full((4, 4), 10.0, np.float32)
    emu.process_frame(frame, 0)
    patch = (x0, y0, np.array([5], np.uint64), np.ones((1, 2, 2), np.float32))
    with pytest.raises(uavsnn.SimulationError, match="does not lie on the 4x4 sensor"):
        emu.process_frame(frame, 10, [patch])
    assert emu.frames_seen == 1
    # The same frame time is still free.
    emu.process_frame(frame, 10, [(0, 0, np.array([5], np.uint64), np.ones((1, 2, 2), np.float32))])
    assert emu.frames_seen == 2


@pytest.mark.parametrize("corner", [(-1, 0), (0, -1), (1.5, 0), (True, 0)])
def test_dvs_patch_corners_that_are_no_pixels_are_refused(corner: tuple[object, object]) -> None:
    # A negative corner was Python's OverflowError from the binding, a fraction truncated.
    emu = DvsEmulator((4, 4), params=DvsParams(), seed=0)
    frame = np.full((4, 4), 10.0, np.float32)
    patch = (*corner, np.array([5], np.uint64), np.ones((1, 2, 2), np.float32))
    with pytest.raises(uavsnn.SimulationError, match="corner must be whole pixels"):
        emu.process_frame(frame, 0, [patch])
    assert emu.frames_seen == 0


# 3. Training windows x epochs are capped (MAX_WINDOWS) before the order is allocated.
@pytest.mark.parametrize(("n", "epochs"), [(2, 2**61), (16, 2**60), (0, 2**61), (2, 50_000_000)])
def test_train_layer_epochs_are_capped(n: int, epochs: int) -> None:
    net = Network({"width": 16, "height": 16})
    before = net.copy()
    with pytest.raises(uavsnn.ParameterError, match="MAX_WINDOWS"):
        net.train_layer("conv2", empty_windows((16, 16), n), epochs=epochs)
    assert net == before
    assert net.train_layer("conv2", empty_windows((16, 16), 2), epochs=2).windows_seen == 4


# 4. Weights and per-window state are capped in the config.
@pytest.mark.parametrize(
    ("config", "fragment"),
    [
        ({"conv2": {"kernel": 65535}}, "MAX_WEIGHTS"),
        ({"conv1": {"maps": 65535}, "conv2": {"maps": 65535}}, "MAX_WEIGHTS"),
        ({"width": 65535, "height": 65535}, "MAX_WINDOW_STATE_BYTES"),
        (
            {"pool1": {"kernel": 65535, "stride": 65535}, "conv1": {"maps": 200}},
            "MAX_WINDOW_STATE_BYTES",
        ),
    ],
)
def test_network_configs_beyond_memory_are_refused(config: dict, fragment: str) -> None:
    with pytest.raises(uavsnn.ParameterError, match=fragment):
        Network(config)


def test_large_real_sensors_are_accepted() -> None:
    assert Network({"width": 1280, "height": 720}).shapes["conv1"] == (4, 720, 1280)
    assert Network({"width": 2048, "height": 2048}).shapes["conv1"] == (4, 2048, 2048)


def test_live_windows_whose_states_exceed_memory_are_refused() -> None:
    # One window's state of an 8000x8000 network is about 2.6 GB: allowed alone, but an
    # overlap of 0.5 keeps two windows live (the process aborted allocating the second).
    from uavsnn.detector import Detector

    net = Network({"width": 8000, "height": 8000})
    with pytest.raises(uavsnn.ParameterError, match=r"overlap.*2 live windows.*MAX_ALLOC_BYTES"):
        Detector(net, overlap=0.5)


def test_the_first_event_past_the_largest_streamed_time_is_named() -> None:
    # The chunk's last event was named ("event 2") though event 1 is the first past the limit.
    from uavsnn.detector import Detector

    det = Detector(Network({"width": 16, "height": 16}))
    events = np.zeros(3, dtype=EVENT_DTYPE)
    events["t"] = [1, MAX_TIME_US + 5, MAX_TIME_US + 6]
    with pytest.raises(uavsnn.EventError, match=rf"^event 1: t={MAX_TIME_US + 5} is beyond"):
        det.push(events)
    assert len(det.push(events[:1])) == 0  # the refused chunk changed nothing


def test_a_model_file_listing_an_entry_twice_is_refused(tmp_path) -> None:
    # A zip directory may name one stored entry many times (a 10 MB file asked for 655 GB).
    import warnings
    import zipfile

    path = tmp_path / "m.npz"
    Network(seed=1).save(path)
    with zipfile.ZipFile(path) as z:
        conv3 = z.read("conv3.npy")
    with warnings.catch_warnings(), zipfile.ZipFile(path, "a") as z:
        warnings.simplefilter("ignore")  # zipfile warns of the duplicate name it writes
        z.writestr("conv3.npy", conv3)
    with pytest.raises(uavsnn.ModelFileError, match=r"conv3\.npy appears twice"):
        Network.load(path)


# 5. Allocations sized by a sensor are capped (MAX_ALLOC_BYTES).
def test_denoise_on_a_huge_sensor_is_refused() -> None:
    rec = Recording(np.zeros(0, EVENT_DTYPE), HUGE)
    with pytest.raises(uavsnn.ParameterError, match="MAX_ALLOC_BYTES"):
        denoise(rec, 1000)


def test_pix2nvs_on_huge_frames_is_refused() -> None:
    with pytest.raises(uavsnn.ParameterError, match="MAX_ALLOC_BYTES"):
        Pix2NvsSimulator(HUGE)


def test_dvs_on_a_huge_sensor_is_refused() -> None:
    with pytest.raises(uavsnn.ParameterError, match="MAX_ALLOC_BYTES"):
        DvsEmulator(HUGE)


def test_noise_frames_and_windowing_on_a_huge_sensor_are_refused() -> None:
    w = empty_windows(HUGE)
    with pytest.raises(uavsnn.ParameterError, match="MAX_ALLOC_BYTES"):
        add_noise(w, 0.0, seed=0)
    with pytest.raises(uavsnn.ParameterError, match="MAX_ALLOC_BYTES"):
        w.frames()
    with pytest.raises(uavsnn.ParameterError, match="MAX_ALLOC_BYTES"):
        make_windows(Recording(events([(0, 1, 1)]), HUGE), 10)


def test_many_frames_are_refused_but_a_few_are_not() -> None:
    w = empty_windows((1280, 720), n=2000)
    assert w.frames([0, 1]).shape == (2, 720, 1280)
    with pytest.raises(uavsnn.ParameterError, match="fewer windows"):
        w.frames()


def _busy_windows(seed: int) -> Windows:
    """Windows of 240x180 busy enough that a call on them takes a while: 2 s of 200,000
    events/s in windows of 10 ms."""
    rng = np.random.default_rng(seed)
    n = 400_000
    ev = np.zeros(n, EVENT_DTYPE)
    ev["t"] = np.sort(rng.integers(0, 2_000_000, n))
    ev["x"] = rng.integers(0, 240, n)
    ev["y"] = rng.integers(0, 180, n)
    return make_windows(Recording(ev, (240, 180)), 10_000, overlap=0.5)


def _refused_while(hold: Any, calls: dict[str, Any]) -> dict[str, bool]:
    """Run ``hold`` again and again in another thread, and each of ``calls`` until it is
    refused with the StreamError of a network in use (at most 20 s): which were."""
    errors: list[Exception] = []
    done = threading.Event()

    def run() -> None:
        try:
            while not done.is_set():
                try:
                    hold()
                except uavsnn.StreamError:
                    pass  # one of the calls below held the network: typed too
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    worker = threading.Thread(target=run)
    worker.start()
    refused = dict.fromkeys(calls, False)
    give_up = time.monotonic() + 20.0  # a loaded machine may start the worker late
    try:
        while not all(refused.values()) and time.monotonic() < give_up:
            for name, call in calls.items():
                if refused[name]:
                    continue
                # A call that lets the GIL go holding the network (run_window, save) would
                # meet the worker at each of its attempts: leave it the GIL without it first.
                time.sleep(0.02)
                try:
                    call()
                except uavsnn.StreamError as exc:
                    assert "in use by another thread" in str(exc)
                    refused[name] = True
    finally:
        done.set()
        worker.join()
    assert not errors, errors
    return refused


# 6. A network in use by another thread refuses train_layer with a typed error.
def test_train_layer_while_another_thread_infers_is_refused() -> None:
    net = Network({"width": 240, "height": 180})
    many = _busy_windows(0)
    few = many.select([0, 1])
    refused = _refused_while(
        lambda: net.infer(many, threads=1),
        {"train_layer": lambda: net.train_layer("conv2", few, every=1)},
    )
    assert refused["train_layer"], "train_layer never overlapped infer"
    # Usable afterwards.
    assert net.train_layer("conv2", few).windows_seen == 2
    assert len(net.infer(few).detected) == 2


def test_every_call_on_a_network_another_thread_trains_is_refused(tmp_path) -> None:
    """Not only infer: reading the weights, the config or a copy while train_layer writes
    them, and writing them while infer reads them, is a StreamError, not pyo3's RuntimeError."""
    net = Network({"width": 240, "height": 180})
    many = _busy_windows(1)
    t, x, y = many.spikes(0)
    w1 = net.weights("conv1")
    other = net.copy()
    reads = {
        "weights": lambda: net.weights("conv1"),
        "config": lambda: net.config,
        "shapes": lambda: net.shapes,
        "conv1_thresholds": lambda: net.conv1_thresholds(100),
        "run_window": lambda: net.run_window(t, x, y, int(many.t0[0])),
        "save": lambda: net.save(tmp_path / "m.npz"),
        "copy": lambda: net.copy(),
        "==": lambda: net == other,
    }
    writes = {
        "set_weights": lambda: net.set_weights("conv1", w1),
        "stdp_step": lambda: net.stdp_step("conv2", t, x, y, int(many.t0[0])),
    }

    # train_layer holds the network for writing through its whole run (every=10**6).
    train = _refused_while(lambda: net.train_layer("conv2", many, every=10**6), reads | writes)
    assert all(train.values()), train
    # infer holds it for reading: writes are refused.
    infer = _refused_while(lambda: net.infer(many, threads=1), writes)
    assert all(infer.values()), infer
    assert net.weights("conv1").shape == w1.shape and net.copy() == net


# 7. Window starts past MAX_TIME_US are refused, so noise times cannot wrap.
def test_window_starts_past_max_time_are_refused() -> None:
    with pytest.raises(uavsnn.ParameterError, match="t0"):
        empty_windows((4, 4), t0=U64_MAX - 5)
    with pytest.raises(uavsnn.ParameterError, match="t0"):
        empty_windows((4, 4), t0=MAX_TIME_US + 1)
    noisy, _ = add_noise(empty_windows((4, 4), t0=MAX_TIME_US), 1.0, seed=0)
    assert len(noisy.t) == 16
    assert (noisy.t >= MAX_TIME_US).all()


def test_the_noise_sweep_runs_its_largest_level_first(monkeypatch: pytest.MonkeyPatch) -> None:
    """What fails for its size fails before the others have run for hours; the points keep
    the order of the fractions and each level the seed of its share, whatever the others."""
    from uavsnn import experiments

    calls: list[tuple[float, int]] = []

    def level(networks: object, data: object, fraction: float, *, seed: int, threads: object):
        calls.append((fraction, seed))
        return [fraction]

    monkeypatch.setattr(experiments, "noise_level", level)
    points = experiments.noise_sweep({}, None, (0.0, 0.2, 0.05), seed=10)  # type: ignore[arg-type]
    assert calls[0] == (0.2, 200_010)
    assert sorted(calls) == [(0.0, 10), (0.05, 50_010), (0.2, 200_010)]
    assert points == [0.0, 0.2, 0.05]
    # A share alone, or in another list, draws the same noise.
    calls.clear()
    experiments.noise_sweep({}, None, (0.05,), seed=10)  # type: ignore[arg-type]
    experiments.noise_sweep({}, None, (0.01, 0.05, 0.015), seed=10)  # type: ignore[arg-type]
    assert [s for f, s in calls if f == 0.05] == [50_010, 50_010]
    assert len({s for _, s in calls}) == 3
    for bad in (float("nan"), -0.01, 1.5):
        with pytest.raises(uavsnn.ParameterError, match="noise share"):
            experiments.noise_seed(0, bad)
    # A bad share in a sweep is refused before any level has run.
    calls.clear()
    with pytest.raises(uavsnn.ParameterError, match="noise share"):
        experiments.noise_sweep({}, None, (0.2, 0.05, 1.5), seed=10)  # type: ignore[arg-type]
    assert calls == []
