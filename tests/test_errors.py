"""The exception hierarchy and the mapping of engine errors onto it."""

from __future__ import annotations

import numpy as np
import pytest

import uavsnn
from uavsnn import _core


def test_every_error_is_a_uavsnn_error() -> None:
    for name in uavsnn.errors.__all__:
        cls = getattr(uavsnn.errors, name)
        assert issubclass(cls, uavsnn.UavsnnError)


def test_engine_errors_arrive_as_typed_exceptions_with_their_message() -> None:
    events = np.zeros(2, uavsnn.EVENT_DTYPE)
    events["t"] = [5, 4]
    with pytest.raises(uavsnn.EventError, match=r"event 1: t=4 goes backwards"):
        _core.validate_events(events.view(np.uint8), 10, 10)
    with pytest.raises(ValueError, match="sensor_size"):
        _core.validate_events(events[:0].view(np.uint8), 0, 10)


def test_version_is_exposed() -> None:
    assert uavsnn.__version__.count(".") == 2


def test_a_rust_panic_arrives_as_an_internal_error_and_the_engine_carries_on() -> None:
    net = uavsnn.Network({"width": 32, "height": 24}, seed=0)
    t = np.arange(40, dtype=np.uint64)
    x, y = (t % 8 + 10).astype(np.uint16), (t // 8 + 10).astype(np.uint16)
    before = net.run_window(t, x, y, 0)
    assert before.counts[0] > 0, "the test needs conv1 spikes"
    with pytest.raises(uavsnn.InternalError, match="deliberate panic"):
        _core._panic_for_test()
    after = net.run_window(t, x, y, 0)
    assert np.array_equal(after.counts, before.counts)
    assert np.array_equal(after["conv1"], before["conv1"])
