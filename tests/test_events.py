"""Events and recordings: the canonical dtype, conversion from other layouts, validation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import uavsnn
from uavsnn.events import EVENT_DTYPE, LAYOUTS, Recording, convert

# Other layouts, as their libraries define them (OpenEB's EventCD is padded to 16 bytes).
TONIC_DTYPE = np.dtype([("x", "<i2"), ("y", "<i2"), ("t", "<i8"), ("p", "?")])
AESTREAM_DTYPE = np.dtype([("timestamp", "<u8"), ("x", "<u2"), ("y", "<u2"), ("polarity", "<u1")])
OPENEB_DTYPE = np.dtype(
    {
        "names": ["x", "y", "p", "t"],
        "formats": ["<u2", "<u2", "<i2", "<i8"],
        "offsets": [0, 2, 4, 8],
        "itemsize": 16,
    }
)


def canonical(t, x, y, p) -> np.ndarray:
    out = np.zeros(len(t), EVENT_DTYPE)
    out["t"], out["x"], out["y"], out["p"] = t, x, y, p
    return out


def test_tonic_dtype_matches_the_library() -> None:
    tonic_io = pytest.importorskip("tonic.io")
    assert tonic_io.make_structured_array([1], [2], [3], [True]).dtype == TONIC_DTYPE


def test_a_tonic_dataset_sensor_size_is_taken_as_it_is() -> None:
    tonic = pytest.importorskip("tonic")
    events = tonic.io.make_structured_array([2, 33], [3, 33], [1, 5], [True, False])  # x, y, t, p
    size = tonic.datasets.NMNIST.sensor_size  # (34, 34, 2): width, height, polarities
    assert len(size) == 3
    got = convert(events, sensor_size=size)
    assert got.tolist() == [(1, 2, 3, True), (5, 33, 33, False)]
    assert uavsnn.Recording(got, size).sensor_size == (34, 34)


@pytest.mark.parametrize(
    ("dtype", "names", "pol"),
    [
        (TONIC_DTYPE, ("t", "x", "y", "p"), [1, 0, 1]),
        (AESTREAM_DTYPE, ("timestamp", "x", "y", "polarity"), [1, 0, 1]),
        (OPENEB_DTYPE, ("t", "x", "y", "p"), [1, -1, 1]),
    ],
)
def test_other_layouts_convert_field_by_field(dtype, names, pol) -> None:
    src = np.zeros(3, dtype)
    for name, values in zip(names, ([5, 6, 9], [1, 2, 3], [4, 5, 6], pol), strict=True):
        src[name] = values
    out = convert(src)
    assert out.dtype == EVENT_DTYPE
    np.testing.assert_array_equal(out, canonical([5, 6, 9], [1, 2, 3], [4, 5, 6], [1, 0, 1]))


def test_faery_dtype_with_its_on_title_is_normalised() -> None:
    faery = pytest.importorskip("faery")
    src = np.zeros(2, faery.EVENTS_DTYPE)
    src["t"], src["x"], src["y"], src["on"] = [1, 2], [3, 4], [5, 6], [True, False]
    out = convert(src)
    assert out.dtype == EVENT_DTYPE  # no title left behind
    np.testing.assert_array_equal(out, canonical([1, 2], [3, 4], [5, 6], [1, 0]))


@given(
    st.lists(
        st.tuples(
            st.integers(0, 2**40), st.integers(0, 65535), st.integers(0, 65535), st.booleans()
        ),
        max_size=50,
    ),
    st.sampled_from(sorted(LAYOUTS)),
    st.booleans(),
)
def test_every_layout_round_trips(rows, layout, plus_minus) -> None:
    expected = canonical(*zip(*rows, strict=True)) if rows else np.zeros(0, EVENT_DTYPE)
    columns = {
        "t": expected["t"].astype(np.int64),
        "x": expected["x"],
        "y": expected["y"],
        "p": np.where(expected["p"], 1, -1 if plus_minus else 0),
    }
    roles = dict(zip(("t", "x", "y", "p"), _roles(layout), strict=True))
    order = LAYOUTS[layout]
    # As a structured array with that layout's names...
    src = np.zeros(len(rows), [(name, "<i8") for name in order])
    for role, name in roles.items():
        src[name] = columns[role]
    np.testing.assert_array_equal(convert(src, layout=layout), expected)
    # ... and as a plain (N, 4) array in that layout's column order.
    by_name = {name: columns[role] for role, name in roles.items()}
    plain = np.stack([by_name[name].astype(np.int64) for name in order], axis=1).reshape(-1, 4)
    np.testing.assert_array_equal(convert(plain, layout=layout), expected)


def _roles(layout: str) -> tuple[str, str, str, str]:
    names = LAYOUTS[layout]
    t = "timestamp" if "timestamp" in names else "t"
    p = next(n for n in ("p", "on", "polarity") if n in names)
    return (t, "x", "y", p)


def test_bad_polarity_names_the_event() -> None:
    src = np.zeros(4, TONIC_DTYPE)
    src["p"] = np.array([0, 1, 1, 0], bool)
    src = src.astype([("x", "<i2"), ("y", "<i2"), ("t", "<i8"), ("p", "<i1")])
    src["p"][2] = 2
    with pytest.raises(uavsnn.EventError, match=r"event 2: polarity 2"):
        convert(src)
    src["p"] = [1, -1, 0, 1]  # 0 in a ±1 stream
    with pytest.raises(uavsnn.EventError, match=r"event 2: polarity 0 .*-1/\+1"):
        convert(src)
    floats = np.zeros(2, [("t", "<u8"), ("x", "<u2"), ("y", "<u2"), ("p", "<f4")])
    floats["p"] = [1.0, np.nan]
    with pytest.raises(uavsnn.EventError, match=r"event 1: polarity nan"):
        convert(floats)


def test_float_times_and_negative_coordinates_are_refused() -> None:
    src = np.zeros(2, [("t", "<f8"), ("x", "<i4"), ("y", "<i4"), ("p", "?")])
    with pytest.raises(uavsnn.EventError, match="t must be integers, got float64"):
        convert(src)
    src = np.zeros(3, [("t", "<i8"), ("x", "<i4"), ("y", "<i4"), ("p", "?")])
    src["x"][1] = -1
    with pytest.raises(uavsnn.EventError, match=r"event 1: x=-1 is negative"):
        convert(src)
    src["x"][1] = 0
    src["t"][2] = -5
    with pytest.raises(uavsnn.EventError, match=r"event 2: t=-5 is negative"):
        convert(src)
    src["t"][2] = 0
    src["y"][0] = 70000
    with pytest.raises(uavsnn.EventError, match=r"event 0: y=70000 exceeds 65535"):
        convert(src)


def test_range_checks_hold_at_their_edges() -> None:
    # 65535 fits a uint16 coordinate; 65536 would wrap to 0 and is refused.
    src = np.zeros(2, [("t", "<i8"), ("x", "<i4"), ("y", "<i4"), ("p", "?")])
    src["x"] = [65535, 0]
    assert convert(src)["x"].tolist() == [65535, 0]
    src["x"][1] = 65536
    with pytest.raises(uavsnn.EventError, match=r"event 1: x=65536 exceeds 65535"):
        convert(src)
    # A single event is checked too (a negative time would wrap to a huge uint64).
    one = np.zeros(1, [("t", "<i8"), ("x", "<i4"), ("y", "<i4"), ("p", "?")])
    one["t"] = -1
    with pytest.raises(uavsnn.EventError, match=r"event 0: t=-1 is negative"):
        convert(one)


def test_layout_must_be_known_and_plain_arrays_need_one() -> None:
    with pytest.raises(uavsnn.ParameterError, match="unknown layout"):
        convert(np.zeros(1, EVENT_DTYPE), layout="dvs")
    with pytest.raises(uavsnn.EventError, match="name its column order"):
        convert(np.zeros((3, 4), np.int64))
    with pytest.raises(uavsnn.EventError, match=r"shape \(N, 4\)"):
        convert(np.zeros((3, 3), np.int64), layout="tonic")
    with pytest.raises(uavsnn.EventError, match="cannot tell the layout"):
        convert(np.zeros(2, [("a", "<i8"), ("b", "<i8")]))
    with pytest.raises(uavsnn.EventError, match=r"needs fields \['timestamp', 'polarity'\]"):
        convert(np.zeros(2, TONIC_DTYPE), layout="aestream")


def test_sensor_size_check_names_the_event() -> None:
    src = canonical([1, 2, 3], [0, 10, 2], [0, 0, 5], [1, 1, 1])
    assert len(convert(src, sensor_size=(11, 6))) == 3
    with pytest.raises(uavsnn.EventError, match=r"event 2: \(x=2, y=5\) is outside the 11x5"):
        convert(src, sensor_size=(11, 5))
    # x = width is off the sensor (columns are 0 .. width - 1).
    with pytest.raises(uavsnn.EventError, match=r"event 1: \(x=10, y=0\) is outside the 10x6"):
        convert(src, sensor_size=(10, 6))


def test_recording_rejects_unsorted_offsensor_and_wrong_dtype() -> None:
    ev = canonical([1, 3, 2], [0, 1, 2], [0, 0, 0], [1, 0, 1])
    with pytest.raises(uavsnn.EventError, match=r"event 2: t=2 goes backwards"):
        Recording(ev, (4, 4))
    ev = canonical([1, 2, 3], [0, 1, 4], [0, 0, 0], [1, 0, 1])
    with pytest.raises(uavsnn.EventError, match=r"event 2: \(x=4, y=0\) is outside the 4x4"):
        Recording(ev, (4, 4))
    with pytest.raises(uavsnn.EventError, match="dtype"):
        Recording(np.zeros(3, TONIC_DTYPE), (4, 4))
    with pytest.raises(uavsnn.ParameterError, match="sensor_size"):
        Recording(np.zeros(0, EVENT_DTYPE), (0, 4))


def test_an_empty_recording_is_valid() -> None:
    rec = Recording(np.zeros(0, EVENT_DTYPE), (4, 4))
    assert len(rec) == 0
    assert rec.duration_us == 0


@pytest.mark.parametrize("metadata", [None, [("scene", "lab")], "scene=lab", 3])
def test_recording_metadata_must_be_a_mapping(metadata: object) -> None:
    # None would break filters.denoise ({**rec.metadata}); a list would be written by
    # io.write_npz and dropped by io.read.
    ev = canonical([1, 2], [0, 1], [0, 0], [1, 0])
    with pytest.raises(uavsnn.ParameterError, match="metadata must be a mapping"):
        Recording(ev, (4, 4), metadata)  # type: ignore[arg-type]


def test_recording_metadata_is_its_own_dict() -> None:
    from types import MappingProxyType

    given = {"scene": "lab"}
    rec = Recording(canonical([1], [0], [0], [1]), (4, 4), given)
    assert rec.metadata == given and rec.metadata is not given
    given["scene"] = "changed"
    assert rec.metadata == {"scene": "lab"}
    proxy = Recording(rec.events, (4, 4), MappingProxyType({"seed": 3}))  # type: ignore[arg-type]
    assert type(proxy.metadata) is dict and proxy.metadata == {"seed": 3}
