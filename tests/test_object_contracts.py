"""What the package's objects promise beyond their main work: a Detector's repr and its fixed
properties (window, overlap, sensor size, step) never raise, not even while another thread's
push holds its engine; one Tracker fed by one thread and
drained by another drains every deleted track exactly once; and Trees compare by their arrays
(``==`` raised "the truth value of an array is ambiguous") and cannot be hashed."""

from __future__ import annotations

import copy
import pickle
import sys
import threading
from dataclasses import replace

import numpy as np
import pytest
from conftest import small_config

from uavsnn import Detector, Network
from uavsnn.events import EVENT_DTYPE
from uavsnn.grouping import WindowObject, WindowReport
from uavsnn.tracks import Tracker, track_windows
from uavsnn.trees import Trees, fit_trees

# -- a Detector's repr ---------------------------------------------------------------------------


def test_a_detectors_repr_never_raises_while_another_thread_pushes() -> None:
    # repr read the engine's counters, which it refuses (StreamError) while a push holds it.
    net = Network(small_config(), seed=4)
    det = Detector(net, window_us=20_000)
    idle = repr(det)
    assert idle == (
        "Detector(window_us=20000, overlap=0.5, sensor_size=(40, 30), events_seen=0, "
        "windows_opened=0, detections=0)"
    )
    n = 3_000_000  # many PUSH_SLICEs: the push lasts while the main thread asks
    events = np.zeros(n, EVENT_DTYPE)
    events["t"] = np.arange(n, dtype=np.uint64) // 4
    events["x"] = np.arange(n) % 40
    events["y"] = (np.arange(n) // 40) % 30
    thread = threading.Thread(target=det.push, args=(events,))
    seen: list[str] = []
    thread.start()
    try:
        while thread.is_alive():
            seen.append(repr(det))
            # What never changes answers too (the engine's getters raised StreamError).
            fixed = (det.window_us, det.overlap, det.sensor_size, det.step_us)
            assert fixed == (20_000, 0.5, (40, 30), 10_000)
    finally:
        thread.join()
    busy = [s for s in seen if "in use" in s]
    if not busy:
        pytest.skip("the push ended before repr met it")
    assert busy[0] == "Detector(window_us=20000, overlap=0.5, sensor_size=(40, 30), in use)"
    assert repr(det).startswith(f"Detector(window_us=20000, overlap=0.5, sensor_size=(40, 30), "
                                f"events_seen={n},")  # fmt: skip


# -- one Tracker, two threads --------------------------------------------------------------------


def _jumping(windows: int, per: int = 8) -> list[WindowReport]:
    """Windows of ``per`` objects each, every one far from the last window's: with
    ``max_misses=1`` each window from the third on deletes ``per`` tracks."""
    out = []
    for k in range(windows):
        objects = tuple(
            WindowObject(box=(100 * j + 50 * (k % 2), 0, 100 * j + 50 * (k % 2) + 4, 4), spikes=1)
            for j in range(per)
        )
        out.append(WindowReport(k, 1000 * k, 1000 * k + 1000, True, np.zeros(0), objects))
    return out


def test_a_tracker_drained_by_another_thread_drains_every_track_once() -> None:
    # drain_ended copied the ended tracks, then cleared them: a track the feeding thread
    # deleted in between was lost (and two drains at once returned one twice).
    reports = _jumping(300)
    tracker = Tracker(max_misses=1)
    drained: list[int] = []
    fed = threading.Event()

    def feed() -> None:
        try:
            for r in reports:
                tracker.update(r)
        finally:
            fed.set()

    def drain() -> None:
        while not fed.is_set():
            drained.extend(t.id for t in tracker.drain_ended())

    threads = [threading.Thread(target=drain), threading.Thread(target=feed)]
    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # switch threads as often as the interpreter can
    try:
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(old)
    ids = drained + [t.id for t in tracker.finish()]
    assert sorted(ids) == list(range(1, 8 * len(reports) + 1))


def test_a_trackers_lock_changes_no_track_and_travels_in_copies() -> None:
    """The tracker copies (track_windows' deepcopy, a process pool's pickle) without its lock,
    each copy with a lock of its own, and tracks as before."""
    reports = _jumping(12, per=3)
    alone = Tracker(max_misses=1)
    want = [alone.update(r) for r in reports]
    given = Tracker(max_misses=1)
    lock = given._lock
    assert list(track_windows(reports, given).reports) == want
    assert given._lock is lock
    after = replace(reports[-1], window=99, t0=99_000, t1=100_000)
    copies = [pickle.loads(pickle.dumps(alone)), copy.deepcopy(alone)]
    for other in copies:
        assert other.live == alone.live and other._lock is not alone._lock
    got = [other.update(after) for other in copies]
    assert got == [alone.update(after)] * 2


# -- Trees compare by their arrays ---------------------------------------------------------------


def _trees() -> Trees:
    rng = np.random.default_rng(3)
    x = rng.normal(size=(200, 4))
    return fit_trees(x, x[:, 0] + x[:, 1] > 0, trees=5, depth=2)


def test_trees_compare_by_their_arrays_and_are_not_hashable() -> None:
    a, b = _trees(), _trees()
    assert a.feature is not b.feature
    assert (a == b) is True and (a != b) is False
    leaf = a.leaf.copy()
    leaf[0, 0] += 1.0
    assert a != replace(a, leaf=leaf)
    assert a != replace(a, base=a.base + 1.0)
    assert a != replace(a, width=None)
    fewer = Trees(a.feature[:2], a.threshold[:2], a.leaf[:2], a.base, a.width)
    assert a != fewer and fewer != a  # other shapes: unequal, not an error
    assert a != "trees" and (a == "trees") is False
    with pytest.raises(TypeError, match="unhashable"):
        hash(a)
