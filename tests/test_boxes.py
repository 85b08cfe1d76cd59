"""uavsnn.boxes: the one box mask the detector, identification and the rotor cue share."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from uavsnn import EVENT_DTYPE, EventError, ParameterError
from uavsnn.boxes import box_mask, in_box, xywh


def events_at(points: list[tuple[int, int]]) -> np.ndarray:
    ev = np.zeros(len(points), dtype=EVENT_DTYPE)
    ev["t"] = np.arange(len(points))
    if points:
        ev["x"], ev["y"] = np.array(points).T
    ev["p"] = np.arange(len(points)) % 2 == 0
    return ev


def test_a_box_holds_its_first_row_and_column_not_its_last() -> None:
    ev = events_at([(2, 3), (4, 3), (5, 3), (2, 6), (2, 7), (1, 3), (3, 2), (4, 6)])
    assert box_mask(ev, (2, 3, 5, 7)).tolist() == [1, 1, 0, 1, 0, 0, 0, 1]
    inside = in_box(ev, (2, 3, 5, 7))
    assert inside.dtype == EVENT_DTYPE
    assert inside["t"].tolist() == [0, 1, 3, 7]  # in their order
    assert xywh((2, 3, 5, 7)) == (2, 3, 3, 4)


def test_an_empty_box_or_one_off_the_sensor_holds_nothing() -> None:
    ev = events_at([(0, 0), (65_535, 65_535), (7, 7)])
    assert not box_mask(ev, (7, 7, 7, 9)).any()
    assert not box_mask(ev, (8, 8, 2, 2)).any()
    assert box_mask(ev, (-5, -5, 1, 1)).tolist() == [True, False, False]
    assert box_mask(ev, (65_535, 65_535, 70_000, 70_000)).tolist() == [False, True, False]
    assert len(in_box(ev[:0], (0, 0, 5, 5))) == 0


@given(
    points=st.lists(st.tuples(st.integers(0, 40), st.integers(0, 30)), max_size=60),
    box=st.tuples(
        st.integers(-5, 45), st.integers(-5, 35), st.integers(-5, 45), st.integers(-5, 35)
    ),
)
def test_in_box_is_the_half_open_rule(points, box) -> None:
    x0, y0, x1, y1 = box
    expected = [x0 <= x < x1 and y0 <= y < y1 for x, y in points]
    ev = events_at(points)
    assert box_mask(ev, box).tolist() == expected
    assert in_box(ev, box)["t"].tolist() == [i for i, e in enumerate(expected) if e]


@pytest.mark.parametrize(
    "box", [(0, 0, 4), "abcd", None, (0, 0, "a", 4), (0.9, 0, 4, 4), (0, 0, 4, True)]
)
def test_a_bad_box_is_a_parameter_error(box) -> None:
    # A fraction was truncated (0.9 read as 0) and True read as 1.
    ev = events_at([(1, 1)])
    with pytest.raises(ParameterError, match="box"):
        box_mask(ev, box)
    with pytest.raises(ParameterError, match="box"):
        xywh(box)


def test_whole_floats_and_numpy_integers_are_box_corners() -> None:
    ev = events_at([(1, 1), (3, 2)])
    want = box_mask(ev, (0, 0, 2, 2))
    for box in [(0.0, 0.0, 2.0, 2.0), tuple(np.array([0, 0, 2, 2], np.uint16))]:
        assert box_mask(ev, box).tolist() == want.tolist()
    assert xywh((np.int64(1), 2.0, 5, 6)) == (1, 2, 4, 4)


@pytest.mark.parametrize("events", [np.zeros(3), np.zeros(2, dtype=[("t", "<u8")]), [1, 2]])
def test_events_without_coordinates_are_an_event_error(events) -> None:
    with pytest.raises(EventError, match="x and y"):
        in_box(events, (0, 0, 2, 2))
