"""UDP event sources: faery's and aestream's packet formats over a real loopback socket, and
malformed packets counted as drops. (The end-to-end detection test over UDP is in
``test_detector.py``.)"""

from __future__ import annotations

import socket
import threading

import numpy as np
import pytest

from uavsnn import EVENT_DTYPE, ParameterError
from uavsnn.sources import PACKET_FORMATS, UdpSource, open_source

faery = pytest.importorskip("faery")

SIZE = (240, 180)
LOOPBACK = "127.0.0.1"


def make_events(n: int, seed: int = 0, t0: int = 1_000) -> np.ndarray:
    rng = np.random.default_rng(seed)
    ev = np.zeros(n, dtype=EVENT_DTYPE)
    ev["t"] = t0 + np.cumsum(rng.integers(0, 50, n))
    ev["x"] = rng.integers(0, SIZE[0], n)
    ev["y"] = rng.integers(0, SIZE[1], n)
    ev["p"] = rng.integers(0, 2, n).astype(bool)
    return ev


def spif_packet(events: np.ndarray, *, with_time: bool) -> bytes:
    """Encode as aestream's ``DVSToUDP`` does: one little-endian u32 word per event (bit 31 set
    when no time follows, x in 30..16, polarity in 15, y in 14..0), then the u32 time word."""
    x = events["x"].astype(np.uint32) & 0x7FFF
    y = events["y"].astype(np.uint32) & 0x7FFF
    word = (x << 16) | (events["p"].astype(np.uint32) << 15) | y
    if not with_time:
        return (word | np.uint32(0x8000_0000)).astype("<u4").tobytes()
    pairs = np.empty((len(events), 2), dtype="<u4")
    pairs[:, 0] = word
    pairs[:, 1] = events["t"] & 0xFFFF_FFFF
    return pairs.tobytes()


def receive_all(source: UdpSource) -> tuple[threading.Thread, list[np.ndarray]]:
    """Start the source in a thread (it stops by itself); the list fills with its chunks. A
    daemon, so that a source that fails to stop fails its test instead of hanging the run."""
    chunks: list[np.ndarray] = []
    thread = threading.Thread(target=lambda: chunks.extend(source), daemon=True)
    thread.start()
    return thread, chunks


def sender() -> socket.socket:
    return socket.socket(socket.AF_INET, socket.SOCK_DGRAM)


@pytest.mark.parametrize("fmt", ["t64_x16_y16_on8", "t32_x16_y15_on1"])
def test_faery_encoder_round_trips(fmt: str) -> None:
    events = make_events(1000)
    per_packet = 100
    with UdpSource(
        LOOPBACK, 0, fmt=fmt, sensor_size=SIZE, max_packets=len(events) // per_packet
    ) as source:
        thread, chunks = receive_all(source)
        as_faery = events.astype(faery.EVENTS_DTYPE)  # same layout, "on" for "p"
        faery.events_stream_from_array(as_faery, dimensions=SIZE).to_udp(
            source.address, events_per_packet=per_packet, format=fmt
        )
        thread.join(timeout=10)
        assert not thread.is_alive()
    got = np.concatenate(chunks)
    np.testing.assert_array_equal(got, events)
    assert source.stats.dropped == 0
    assert source.stats.events == len(events)


@pytest.mark.parametrize("with_time", [True, False])
def test_aestream_spif_packets(with_time: bool) -> None:
    events = make_events(300, seed=1)
    packets = [events[i : i + 64] for i in range(0, len(events), 64)]
    with UdpSource(LOOPBACK, 0, fmt="spif", sensor_size=SIZE, max_packets=len(packets)) as source:
        thread, chunks = receive_all(source)
        with sender() as s:
            for p in packets:
                s.sendto(spif_packet(p, with_time=with_time), source.address)
        thread.join(timeout=10)
        assert not thread.is_alive()
    got = np.concatenate(chunks)
    for field in ("x", "y", "p"):
        np.testing.assert_array_equal(got[field], events[field])
    if with_time:
        np.testing.assert_array_equal(got["t"], events["t"])
    else:
        # Stamped on arrival: one time per packet, never decreasing.
        assert np.all(np.diff(got["t"].astype(np.int64)) >= 0)
        assert all(len(np.unique(c["t"])) == 1 for c in chunks)


def test_thirty_two_bit_times_unwrap_across_packets() -> None:
    events = make_events(4, seed=2)
    events["t"] = [(1 << 32) - 50, (1 << 32) - 1, (1 << 32) + 3, (1 << 32) + 90]
    with UdpSource(LOOPBACK, 0, fmt="t32_x16_y15_on1", sensor_size=SIZE, max_packets=4) as source:
        thread, chunks = receive_all(source)
        as_faery = events.astype(faery.EVENTS_DTYPE)
        faery.events_stream_from_array(as_faery, dimensions=SIZE).to_udp(
            source.address, events_per_packet=1, format="t32_x16_y15_on1"
        )
        thread.join(timeout=10)
        assert not thread.is_alive()
    np.testing.assert_array_equal(np.concatenate(chunks), events)


@pytest.mark.parametrize("fmt", PACKET_FORMATS)
def test_malformed_packets_are_counted_and_skipped(fmt: str) -> None:
    def encode(ev: np.ndarray) -> bytes:
        if fmt == "t64_x16_y16_on8":
            return ev.tobytes()
        if fmt == "spif":
            return spif_packet(ev, with_time=True)
        packed = np.zeros(len(ev), dtype=[("t", "<u4"), ("x", "<u2"), ("yon", "<u2")])
        packed["t"] = ev["t"]
        packed["x"] = ev["x"]
        packed["yon"] = (ev["y"] << 1) | ev["p"]
        return packed.tobytes()

    good = make_events(30, seed=3)
    first, second, third = good[:10], good[10:20], good[20:]
    outside = good[10:12].copy()
    outside["x"][1] = SIZE[0]
    backwards = first[:1]
    bad = [
        encode(second)[:-1],  # truncated: not a whole number of records
        encode(outside),  # an event outside the sensor
        b"\x01\x02\x03",  # garbage
    ]
    with UdpSource(LOOPBACK, 0, fmt=fmt, sensor_size=SIZE, max_packets=3 + len(bad) + 1) as source:
        thread, chunks = receive_all(source)
        with sender() as s:
            s.sendto(encode(first), source.address)
            for packet in bad:
                s.sendto(packet, source.address)
            s.sendto(encode(second), source.address)
            s.sendto(encode(backwards), source.address)  # earlier than what came before
            s.sendto(encode(third), source.address)
        thread.join(timeout=10)
        assert not thread.is_alive()
    np.testing.assert_array_equal(np.concatenate(chunks), good)
    assert source.stats.dropped == len(bad) + 1
    assert source.stats.packets == 3 + len(bad) + 1


def test_idle_timeout_ends_a_silent_stream() -> None:
    with UdpSource(LOOPBACK, 0, sensor_size=SIZE, idle_timeout=0.2) as source:
        assert list(source) == []
    assert source.stats.packets == 0


def test_bad_udp_parameters_are_typed_errors() -> None:
    with pytest.raises(ParameterError, match="format"):
        UdpSource(LOOPBACK, 0, fmt="t16", sensor_size=SIZE)
    with pytest.raises(ParameterError, match="max_packets"):
        UdpSource(LOOPBACK, 0, sensor_size=SIZE, max_packets=0)
    with pytest.raises(ParameterError, match="idle_timeout"):
        UdpSource(LOOPBACK, 0, sensor_size=SIZE, idle_timeout=-1)
    with pytest.raises(ParameterError, match="sensor_size"):
        UdpSource(LOOPBACK, 0, sensor_size=(0, 10))
    with pytest.raises(ParameterError, match="udp://HOST:PORT"):
        open_source("udp://127.0.0.1", sensor_size=SIZE)
    with pytest.raises(ParameterError, match="sensor size"):
        open_source("udp://127.0.0.1:0")
    with UdpSource(LOOPBACK, 0, sensor_size=SIZE) as taken:
        with pytest.raises(ParameterError, match="cannot listen"):
            UdpSource(LOOPBACK, taken.address[1], sensor_size=SIZE)
