"""One network or one detector used from two threads: a call that meets another is refused with
a StreamError before it changes anything, including where the engine lets the object go part
way through a call (between train_layer's chunks, after a push_windows' engine part) and where
a signal handler stops a long push part way."""

from __future__ import annotations

import os
import signal
import threading
import time
from typing import Any

import numpy as np
import pytest
from conftest import blob_events, small_config

from uavsnn import Detector, Network, StreamError
from uavsnn.events import EVENT_DTYPE
from uavsnn.tracks import Tracker
from uavsnn.windows import make_windows


def _windows(n: int = 4000) -> Any:
    from uavsnn import Recording

    return make_windows(Recording(blob_events(1, n), (40, 30)), 20_000, 0.5)


def test_another_thread_is_refused_between_train_layers_chunks() -> None:
    """train_layer let the network go between its chunks (for its callback): another thread's
    infer read half-trained weights there, and its set_weights changed them under training."""
    net = Network(small_config(), seed=2)
    windows = _windows()
    reference = net.copy()
    reference.train_layer("conv2", windows, every=8)
    in_callback, tried = threading.Event(), threading.Event()
    start_weights = net.weights("conv2")
    seen: list[str] = []

    def other() -> None:
        in_callback.wait(30)
        calls = (lambda: net.infer(windows), lambda: net.set_weights("conv2", start_weights))
        for call in calls:
            try:
                call()
                seen.append("ran")
            except StreamError as exc:
                seen.append(str(exc))
        tried.set()

    reads: list[np.ndarray] = []

    def callback(done: int, total: int, convergence: float) -> None:
        reads.append(net.weights("conv2"))  # the training thread's own read goes on
        if not in_callback.is_set():
            in_callback.set()
            assert tried.wait(30)

    thread = threading.Thread(target=other)
    thread.start()
    net.train_layer("conv2", windows, every=8, callback=callback)
    thread.join(30)
    assert len(seen) == 2 and all("in use by another thread" in s for s in seen), seen
    assert reads and np.array_equal(net.weights("conv2"), reference.weights("conv2"))
    # Once training ends, the network is anyone's again.
    net.infer(windows)


class _Waiting(Tracker):
    """A tracker that waits, inside a push_windows' Python part, until told to go on."""

    def __init__(self) -> None:
        super().__init__()
        self.inside, self.go = threading.Event(), threading.Event()

    def update(self, report: Any) -> Any:
        if not self.inside.is_set():
            self.inside.set()
            assert self.go.wait(30)
        return super().update(report)


def test_a_detector_refuses_another_threads_call_during_push_windows_python_part() -> None:
    """The guard covered the engine part only: another thread's advance_windows (or reset)
    went through while push_windows grouped and tracked its windows, and detections were lost
    (or the tracker saw window 0 twice)."""
    net = Network(small_config(), seed=4)
    events = blob_events(3, 6000)
    want = [
        (w.window, w.detected, w.spikes)
        for d in [Detector(net, window_us=20_000)]
        for w in [*d.push_windows(events), *d.flush_windows()]
    ]
    tracker = _Waiting()
    det = Detector(net, window_us=20_000, tracker=tracker)
    got: list[Any] = []
    thread = threading.Thread(target=lambda: got.extend(det.push_windows(events)))
    thread.start()
    assert tracker.inside.wait(30)
    for call in (lambda: det.advance_windows(int(events["t"][-1])), det.reset,
                 lambda: det.push(events[:0])):  # fmt: skip
        with pytest.raises(StreamError, match="in use by another call"):
            call()
    tracker.go.set()
    thread.join(30)
    got += det.flush_windows()
    assert not det.interrupted
    assert [(w.window, w.detected, w.spikes) for w in got] == want


def test_a_signal_handlers_error_inside_a_long_push_leaves_the_detector_interrupted() -> None:
    """The engine runs Python's signal handlers between a long push's slices; a handler that
    raised one of the package's errors (a status read refused while the push holds the
    detector) was taken for a refusal of the chunk: the detector said it was as it was, and
    the chunk sent again was refused as going back in time."""
    net = Network(small_config(), seed=4)
    det = Detector(net, window_us=20_000)
    n = 3_000_000
    events = np.zeros(n, EVENT_DTYPE)
    events["t"] = np.arange(n, dtype=np.uint64) // 4
    events["x"] = np.arange(n) % 40
    events["y"] = (np.arange(n) // 40) % 30
    pushing, stop = threading.Event(), threading.Event()

    def status(signum: int, frame: Any) -> None:
        _ = det.events_seen  # refused while the push holds the detector

    def nag() -> None:
        # A signal every 2 ms while the push runs: the first that lands between two of its
        # slices is handled there (those before it, outside the engine, read freely).
        pushing.wait(10)
        while not stop.is_set():
            os.kill(os.getpid(), signal.SIGUSR1)
            time.sleep(0.002)

    old = signal.signal(signal.SIGUSR1, status)
    sender = threading.Thread(target=nag)
    try:
        sender.start()
        pushing.set()
        try:
            det.push(events)
            refused = None
        except StreamError as exc:
            refused = exc
        finally:
            stop.set()
            sender.join()
        time.sleep(0.01)  # a last signal sent, handled here
    finally:
        signal.signal(signal.SIGUSR1, old)
    if refused is None:
        pytest.skip("no signal arrived while the engine held the push")
    assert "in use by another thread" in str(refused)
    assert det.interrupted
    with pytest.raises(StreamError, match="interrupted part way"):
        det.push(events[-1:])
