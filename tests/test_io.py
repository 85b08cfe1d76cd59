"""Reading and writing recordings: golden real files, round trips through every format, and
typed errors for files that are missing, empty, truncated, corrupt or of an unknown type."""

from __future__ import annotations

import json
import os
import re
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import uavsnn
from uavsnn import _csv as csv_reader
from uavsnn import _prophesee as prophesee
from uavsnn import io
from uavsnn.cli import main
from uavsnn.cli.info import summary
from uavsnn.events import EVENT_DTYPE, Recording

# Third-party facts, not our results: event counts, first/last timestamps and sensors of the real
# recordings, as listed in ../shared/data/README.md (decoded by faery 0.7.1 and cross-checked
# there with two other decoders). The Gen3 RAW headers carry no geometry: 640x480 is given.
GOLDEN = {
    "aestream_davis346_lab.aedat4": ((346, 260), None, 117_667, 1633953690975950, 1633953691105949),
    "tonic_dvxplorer_person.aedat4": (
        (320, 240),
        None,
        111_954,
        1605537493718345,
        1605537494308262,
    ),
    "prophesee_gen3_spinner_evt2.raw": ((640, 480), (640, 480), 539_481, 1317888, 1367888),
    "prophesee_gen3_sparklers_evt2.raw": ((640, 480), (640, 480), 521_252, 913716224, 913812095),
    "prophesee_gen4_driving_evt3.raw": ((1280, 720), (1280, 720), 219_596, 11718656, 11727467),
}


@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_golden_recordings(shared_data: Path, name: str) -> None:
    sensor, given, count, first, last = GOLDEN[name]
    rec = io.read(shared_data / "dvs" / name, sensor_size=given)
    assert rec.sensor_size == sensor
    assert len(rec) == count
    assert (int(rec.events["t"][0]), int(rec.events["t"][-1])) == (first, last)
    assert rec.events.dtype == EVENT_DTYPE
    assert rec.metadata["sensor_size_source"] == ("file" if given is None else "argument")


def test_raw_without_geometry_takes_the_cameras_size_and_says_so(shared_data: Path) -> None:
    # Gen3 headers carry no geometry, only plugin_name hal_plugin_gen3_fx3: 640x480, not
    # faery's 1280x720 (which made --downsample drop half the events).
    for name in ("prophesee_gen3_spinner_evt2.raw", "prophesee_gen3_sparklers_evt2.raw"):
        rec = io.read(shared_data / "dvs" / name)
        assert rec.sensor_size == (640, 480)
        assert rec.metadata["sensor_size_source"] == "camera"
        assert rec.metadata["camera"] == "gen3"
        assert len(rec) == len(io.read(shared_data / "dvs" / name, sensor_size=(640, 480)))
        assert (
            "sensor_size_note"
            not in io.read(shared_data / "dvs" / name, sensor_size=(640, 480)).metadata
        )


def test_a_size_given_against_the_named_camera_is_taken_and_said(
    shared_data: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # --sensor-size 1280x720 on a Gen3 file was taken without a word (info: "as given").
    path = shared_data / "dvs" / "prophesee_gen3_spinner_evt2.raw"
    rec = io.read(path, sensor_size=(1280, 720))
    assert rec.sensor_size == (1280, 720) and rec.metadata["sensor_size_source"] == "argument"
    note = rec.metadata["sensor_size_note"]
    assert note == (
        "prophesee_gen3_spinner_evt2.raw's header names a gen3 camera, whose sensor is 640x480, "
        "and 1280x720 was given: the given size is taken"
    )
    from uavsnn.cli import main

    assert main(["info", str(path), "--sensor-size", "1280x720"]) == 0
    assert f"note:        {note}" in capsys.readouterr().out


def test_raw_without_geometry_or_camera_falls_back_and_says_so(
    shared_data: Path, tmp_path: Path
) -> None:
    data = (shared_data / "dvs" / "prophesee_gen3_spinner_evt2.raw").read_bytes()
    anonymous = tmp_path / "anonymous.raw"
    anonymous.write_bytes(data.replace(b"% plugin_name hal_plugin_gen3_fx3\n", b""))
    rec = io.read(anonymous)
    assert rec.sensor_size == io.FAERY_FALLBACK_SIZE
    assert rec.metadata["sensor_size_source"] == "fallback"
    assert len(rec) == len(io.read(shared_data / "dvs" / "prophesee_gen3_spinner_evt2.raw"))
    # The stand-in is refused by the detector's check, even for a model of its size: this
    # 640x480 camera's events ran in the corner of a 1280x720 model without a word.
    from uavsnn.sources import FileSource, check_fits

    for model_size in (io.FAERY_FALLBACK_SIZE, (640, 480), (240, 180)):
        with pytest.raises(uavsnn.ParameterError, match="records no sensor size"):
            check_fits(FileSource(anonymous), model_size)
    check_fits(FileSource(anonymous, sensor_size=(640, 480)), (640, 480))  # given, it fits


def test_raw_without_a_version_line_is_read_as_evt3_and_the_error_says_so(
    shared_data: Path, tmp_path: Path
) -> None:
    # The EVT 2.0 spinner without its header: read as EVT 3.0, its error advised a sensor size,
    # which failed again.
    data = (shared_data / "dvs" / "prophesee_gen3_spinner_evt2.raw").read_bytes()
    start = 0
    while data[start : start + 1] == b"%":
        start = data.index(b"\n", start) + 1
    bare = tmp_path / "bare.raw"
    bare.write_bytes(data[start:])
    for size in (None, (640, 480)):
        with pytest.raises(uavsnn.RecordingFileError) as caught:
            io.read(bare, sensor_size=size)
        assert "names no EVT version, so it was read as EVT 3.0" in str(caught.value)
        assert "needs a '% evt 2.0' line in its header" in str(caught.value)
        assert ("give sensor_size; or its header" in str(caught.value)) == (size is None)
    bare.write_bytes(b"% evt 2.0\n" + data[start:])  # the advice taken
    assert len(io.read(bare, sensor_size=(640, 480))) == 539_481


def test_sensor_size_contradicting_the_file_is_refused(shared_data: Path) -> None:
    with pytest.raises(uavsnn.ParameterError, match=r"contradicts the file's \(320, 240\)"):
        io.read(shared_data / "dvs" / "tonic_dvxplorer_person.aedat4", sensor_size=(640, 480))


def _events(n: int = 500, size: tuple[int, int] = (64, 48), seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    ev = np.zeros(n, EVENT_DTYPE)
    ev["t"] = np.sort(rng.integers(1_000, 500_000, n))
    ev["x"] = rng.integers(0, size[0], n)
    ev["y"] = rng.integers(0, size[1], n)
    ev["p"] = rng.random(n) < 0.5
    return ev


@pytest.mark.parametrize("ext", ["aedat4", "es", "dat", "raw", "csv"])
def test_every_faery_format_round_trips(tmp_path: Path, ext: str) -> None:
    faery = pytest.importorskip("faery")
    ev = _events()
    path = tmp_path / f"rec.{ext}"
    faery.events_stream_from_array(ev.astype(faery.EVENTS_DTYPE), (64, 48)).to_file(
        path, zero_t0=False
    )
    rec = io.read(path, sensor_size=(64, 48))
    np.testing.assert_array_equal(rec.events, ev)
    assert rec.sensor_size == (64, 48)
    # CSV has no geometry; the others write it in their header.
    assert rec.metadata["sensor_size_source"] == ("argument" if ext == "csv" else "file")
    assert rec.metadata["format"] == io.FORMATS[f".{ext}"]


def test_every_format_reads_whatever_the_case_of_its_extension(tmp_path: Path) -> None:
    # faery was handed the file to guess its format from the suffix, which it takes in lower
    # case only: "UP.RAW", "UP.EVT" and "UP.CSV" were refused ("unsupported file extension").
    faery = pytest.importorskip("faery")
    ev = _events()
    for ext in ("aedat4", "es", "dat", "raw", "csv", "npz", "npy"):
        lower = tmp_path / f"rec.{ext}"
        if ext == "npz":
            io.write_npz(Recording(ev, (64, 48)), lower)
        elif ext == "npy":
            np.save(lower, ev)
        else:
            stream = faery.events_stream_from_array(ev.astype(faery.EVENTS_DTYPE), (64, 48))
            stream.to_file(lower, zero_t0=False)
        names = [f"REC.{ext.upper()}", f"Rec.{ext[:1].upper()}{ext[1:]}"]
        names += ["REC.EVT"] if ext == "raw" else []
        for name in names:
            shutil.copyfile(lower, tmp_path / name)
            rec = io.read(tmp_path / name, sensor_size=(64, 48))
            np.testing.assert_array_equal(rec.events, ev)
            assert rec.metadata["format"] == io.FORMATS[f".{ext}"], name
    # Written with an upper-case suffix, read back the same.
    io.write_npz(Recording(ev, (64, 48)), tmp_path / "OUT.NPZ")
    np.testing.assert_array_equal(io.read(tmp_path / "OUT.NPZ").events, ev)


def test_npz_round_trip_is_exact_and_atomic(tmp_path: Path) -> None:
    rec = Recording(_events(), (64, 48), {"scene": "lab", "seed": np.int64(3)})
    path = tmp_path / "rec.npz"
    path.write_bytes(b"old content")
    io.write_npz(rec, path)
    back = io.read(path)
    np.testing.assert_array_equal(back.events, rec.events)
    assert back.sensor_size == rec.sensor_size
    assert back.metadata["scene"] == "lab" and back.metadata["seed"] == 3
    assert [p.name for p in tmp_path.iterdir()] == ["rec.npz"]  # no temporary left behind


def test_write_npz_leaves_the_old_file_when_it_fails(tmp_path: Path) -> None:
    path = tmp_path / "rec.npz"
    io.write_npz(Recording(_events(10), (64, 48)), path)
    before = path.read_bytes()
    with pytest.raises(uavsnn.ParameterError, match="not JSON-serialisable"):
        io.write_npz(Recording(_events(20), (64, 48), {"bad": object()}), path)
    with pytest.raises(uavsnn.RecordingFileError, match="cannot write"):
        io.write_npz(Recording(_events(20), (64, 48)), tmp_path / "missing" / "rec.npz")
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["rec.npz"]


def test_write_npz_into_a_missing_folder_names_the_path_not_a_temporary_file(
    tmp_path: Path,
) -> None:
    # The error named the hidden temporary file beside it ("nodir/.rec.npz.36f74a899a13.tmp").
    path = tmp_path / "nodir" / "rec.npz"
    with pytest.raises(uavsnn.RecordingFileError) as caught:
        io.write_npz(Recording(_events(10), (64, 48)), path)
    assert str(caught.value) == f"{path}: cannot write: {os.strerror(2)}"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("change", "message"),
    [(("x", 0, 1000), r"event 0: \(x=1000"), (("t", 5, 0), "event 5: t=0 goes backwards")],
)
def test_write_npz_refuses_events_changed_after_the_recording_was_built(
    tmp_path: Path, change: tuple[str, int, int], message: str
) -> None:
    # What it would write, io.read would refuse.
    rec = Recording(_events(10), (64, 48))
    field, index, value = change
    rec.events[field][index] = value
    path = tmp_path / "rec.npz"
    path.write_bytes(b"old content")
    with pytest.raises(uavsnn.EventError, match=message):
        io.write_npz(rec, path)
    assert path.read_bytes() == b"old content"
    assert [p.name for p in tmp_path.iterdir()] == ["rec.npz"]


@pytest.mark.parametrize("name", ["rec", "rec.npy", "rec.npz.tmp"])
def test_write_npz_refuses_a_path_that_is_no_npz(tmp_path: Path, name: str) -> None:
    # io.read knows a recording by its suffix: it would refuse these as of unknown type.
    with pytest.raises(uavsnn.ParameterError, match=r"must end in \.npz"):
        io.write_npz(Recording(_events(10), (64, 48)), tmp_path / name)
    assert list(tmp_path.iterdir()) == []
    io.write_npz(Recording(_events(10), (64, 48)), tmp_path / "rec.NPZ")
    assert len(io.read(tmp_path / "rec.NPZ")) == 10


def test_a_path_of_bytes_is_a_parameter_error(tmp_path: Path) -> None:
    path = tmp_path / "rec.npz"
    with pytest.raises(uavsnn.ParameterError, match="path"):
        io.write_npz(Recording(_events(10), (64, 48)), bytes(path))
    assert not path.exists()
    io.write_npz(Recording(_events(10), (64, 48)), path)
    with pytest.raises(uavsnn.ParameterError, match="path"):
        io.read(bytes(path))


def test_npy_infers_or_takes_the_sensor(tmp_path: Path) -> None:
    ev = _events()
    path = tmp_path / "ev.npy"
    np.save(path, ev)
    rec = io.read(path)
    assert rec.sensor_size == (int(ev["x"].max()) + 1, int(ev["y"].max()) + 1)
    assert rec.metadata["sensor_size_source"] == "inferred"
    assert io.read(path, sensor_size=(100, 100)).sensor_size == (100, 100)
    np.save(path, ev[:0])
    with pytest.raises(uavsnn.ParameterError, match="needs sensor_size"):
        io.read(path)
    assert len(io.read(path, sensor_size=(4, 4))) == 0


def test_missing_empty_and_unknown_files(tmp_path: Path) -> None:
    with pytest.raises(uavsnn.RecordingFileError, match="no such file"):
        io.read(tmp_path / "absent.aedat4")
    for ext in ("aedat4", "raw", "npz", "csv"):
        (tmp_path / f"empty.{ext}").write_bytes(b"")
        with pytest.raises(uavsnn.RecordingFileError, match="empty"):
            io.read(tmp_path / f"empty.{ext}")
    (tmp_path / "rec.mp4").write_bytes(b"\0" * 10)
    with pytest.raises(uavsnn.RecordingFileError, match=r"unknown file type '\.mp4'") as e:
        io.read(tmp_path / "rec.mp4")
    assert "uavsnn simulate rec.mp4 -o EVENTS.npz" in str(e.value)  # a video: how to read it
    (tmp_path / "rec.xyz").write_bytes(b"\0" * 10)
    with pytest.raises(uavsnn.RecordingFileError, match=r"unknown file type '\.xyz'") as e:
        io.read(tmp_path / "rec.xyz")
    assert "simulate" not in str(e.value)


@pytest.mark.parametrize("ext", ["aedat4", "raw", "dat", "es", "npz", "npy"])
def test_garbage_bytes_are_a_recording_file_error(tmp_path: Path, ext: str) -> None:
    path = tmp_path / f"garbage.{ext}"
    path.write_bytes(np.random.default_rng(1).bytes(4099))
    with pytest.raises(uavsnn.RecordingFileError, match=r"garbage\."):
        io.read(path, sensor_size=(640, 480))


def test_truncated_real_files_are_refused(shared_data: Path, tmp_path: Path) -> None:
    for name in ["tonic_dvxplorer_person.aedat4", *(n for n in GOLDEN if n.endswith(".raw"))]:
        data = (shared_data / "dvs" / name).read_bytes()
        n = len(data) // 2
        n += 1 if n % 2 == 0 else 0  # inside an EVT word (2 or 4 bytes)
        path = tmp_path / name
        path.write_bytes(data[:n])
        with pytest.raises(uavsnn.RecordingFileError, match=re.escape(name)):
            io.read(path, sensor_size=GOLDEN[name][1])


def _header_length(data: bytes) -> int:
    """Bytes of a RAW/DAT file's ``%`` header lines."""
    pos = 0
    while data[pos : pos + 1] == b"%":
        pos = data.index(b"\n", pos) + 1
    return pos


def test_truncated_dat_files_are_refused(tmp_path: Path) -> None:
    faery = pytest.importorskip("faery")
    path = tmp_path / "rec.dat"
    faery.events_stream_from_array(_events().astype(faery.EVENTS_DTYPE), (64, 48)).to_file(
        path, zero_t0=False
    )
    data = path.read_bytes()
    head = _header_length(data)
    record = data[head + 1]  # a type byte, a size byte, then the records
    cut = tmp_path / "cut.dat"
    cut.write_bytes(data[: len(data) - 3])
    with pytest.raises(uavsnn.RecordingFileError, match=f"whole number of {record}-byte DAT"):
        io.read(cut, sensor_size=(64, 48))
    cut.write_bytes(data[: head + 1])
    with pytest.raises(uavsnn.RecordingFileError, match="truncated after its header"):
        io.read(cut, sensor_size=(64, 48))


def _dat(path: Path, times: list[int]) -> Path:
    """A DAT file of CD events (type 0x0C, 8-byte records: the time in the low 32 bits, then
    x, y and the polarity) at pixel (1, 2), ON, at these 32-bit times."""
    head = b"% Width 640\n% Height 480\n"
    records = np.array([t | (1 << 32) | (2 << 46) | (1 << 60) for t in times], "<u8")
    path.write_bytes(head + bytes([0x0C, 8]) + records.tobytes())
    return path


def test_dat_times_going_backwards_are_refused_and_their_rollover_is_read(tmp_path: Path) -> None:
    # faery clamps a time earlier than the one before to it: 10, 5, 20 read as 10, 10, 20.
    back = _dat(tmp_path / "back.dat", [10, 5, 20])
    message = r"back\.dat: event 1 \(byte 35\): time 5 is earlier than the time before it \(10\)"
    with pytest.raises(uavsnn.RecordingFileError, match=message):
        io.read(back)
    # A jump back of more than 2^31 µs is the 32-bit time rolling over, read as such; an
    # earlier time after it is refused as well, as it reads.
    wrap = 2**32
    rolled = io.read(_dat(tmp_path / "rolled.dat", [10, wrap - 5, 3, 3, 7]))
    assert rolled.events["t"].tolist() == [10, wrap - 5, wrap + 3, wrap + 3, wrap + 7]
    assert rolled.events[["x", "y", "p"]].tolist() == [(1, 2, True)] * 5
    with pytest.raises(uavsnn.RecordingFileError, match=f"event 3 .*time {wrap + 1} is earlier"):
        io.read(_dat(tmp_path / "late.dat", [10, wrap - 5, 3, 1]))
    assert len(io.read(_dat(tmp_path / "none.dat", []))) == 0


def test_npz_sensor_size_contradicting_the_file_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "rec.npz"
    io.write_npz(Recording(_events(), (64, 48)), path)
    assert io.read(path, sensor_size=(64, 48)).sensor_size == (64, 48)
    with pytest.raises(uavsnn.ParameterError, match=r"contradicts the file's \(64, 48\)"):
        io.read(path, sensor_size=(65, 48))


def test_truncated_header_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "cut.raw"
    path.write_bytes(b"% evt 2.0\n% firmware_ver")
    with pytest.raises(uavsnn.RecordingFileError, match="truncated inside its header"):
        io.read(path, sensor_size=(640, 480))


def test_npz_without_the_arrays_or_with_pickles_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "bad.npz"
    np.savez(path, events=_events(5))
    with pytest.raises(uavsnn.RecordingFileError, match=r"missing \['sensor_size'\]"):
        io.read(path)
    np.savez(path, events=np.array([{"t": 1}], dtype=object), sensor_size=np.array([4, 4]))
    with pytest.raises(uavsnn.RecordingFileError, match=r"cannot read as \.npz"):
        io.read(path)
    ev = _events(5)
    ev["t"] = ev["t"][::-1]
    np.savez(path, events=ev, sensor_size=np.array([64, 48]))
    with pytest.raises(uavsnn.RecordingFileError, match="goes backwards"):
        io.read(path)


def test_corrupt_events_in_a_valid_container_are_a_file_error(tmp_path: Path) -> None:
    faery = pytest.importorskip("faery")
    ev = _events(50)
    path = tmp_path / "rec.csv"
    faery.events_stream_from_array(ev.astype(faery.EVENTS_DTYPE), (64, 48)).to_file(path)
    with pytest.raises(uavsnn.RecordingFileError, match=r"rec\.csv"):
        io.read(path, sensor_size=(10, 10))  # events beyond the given sensor


def test_info_command_reports_counts_and_rates(
    shared_data: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = shared_data / "dvs" / "prophesee_gen3_spinner_evt2.raw"
    assert main(["info", str(path), "--json", "--sensor-size", "640x480"]) == 0
    info = json.loads(capsys.readouterr().out)
    rec = io.read(path, sensor_size=(640, 480))
    t = rec.events["t"].astype(np.int64)
    assert info["events"] == len(rec) and info["sensor_size"] == [640, 480]
    assert info["duration_us"] == t[-1] - t[0]
    assert info["mean_rate_ev_per_s"] == pytest.approx((len(t) - 1) / ((t[-1] - t[0]) * 1e-6))
    busiest = np.bincount((t - t[0]) // 1000).max()
    assert info["peak_rate_ev_per_s"] == busiest * 1000
    assert info["on_fraction"] == pytest.approx(rec.events["p"].mean())
    assert main(["info", str(path)]) == 0
    text = capsys.readouterr().out
    assert "640x480 (the gen3 camera named in the header" in text
    assert "busiest 1 ms bin" in text
    assert f"events:      {len(rec):,} ({rec.events['p'].mean():.0%} ON)" in text


def test_info_gives_no_peak_rate_for_events_shorter_than_a_bin(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 207 events over 18 µs: one 1 ms bin's count, times 1000, would read 207,000 ev/s
    # against a mean of 11.5 M ev/s.
    ev = _events(207)
    ev["t"] = np.linspace(1_000, 1_018, len(ev)).astype(np.uint64)
    assert summary(Recording(ev, (64, 48)))["peak_rate_ev_per_s"] is None
    ev["t"][-1] = 2_000  # one whole bin: a peak again
    assert summary(Recording(ev, (64, 48)))["peak_rate_ev_per_s"] == 206_000
    path = tmp_path / "short.npz"
    ev["t"][-1] = 1_018
    np.savez(path, events=ev, sensor_size=np.array([64, 48]))
    assert main(["info", str(path)]) == 0
    assert "peak rate:   n/a (the events span less than 1 ms)" in capsys.readouterr().out


def test_info_mean_rate_is_not_above_the_peak_for_events_spread_evenly(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 1,001 events over 0..1000 µs read a mean of 1,001,000 ev/s against a peak of 1,000,000:
    # N over last - first counts one interval too many.
    ev = np.zeros(1001, EVENT_DTYPE)
    ev["t"] = np.arange(1001)
    info = summary(Recording(ev, (64, 48)))
    assert info["mean_rate_ev_per_s"] == info["peak_rate_ev_per_s"] == 1_000_000
    # Events every `step` µs over 1 to 3 ms: a mean of 1 / step at most their busiest bin's.
    for step in (1, 2, 3, 7, 10):
        for count in range(1000 // step + 1, 3000 // step + 2):
            ev = np.zeros(count, EVENT_DTYPE)
            ev["t"] = step * np.arange(count)
            info = summary(Recording(ev, (64, 48)))
            if info["peak_rate_ev_per_s"] is not None:
                assert info["mean_rate_ev_per_s"] <= info["peak_rate_ev_per_s"], (step, count)
    path = tmp_path / "ms.npz"
    ev = np.zeros(1001, EVENT_DTYPE)
    ev["t"] = np.arange(1001)
    io.write_npz(Recording(ev, (64, 48)), path)
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "mean rate:   1,000,000 ev/s" in out and "peak rate:   1,000,000 ev/s" in out


def test_info_command_survives_bad_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "bad.aedat4"
    shutil.copyfile(__file__, path)
    assert main(["info", str(path)]) == 2
    assert "bad.aedat4" in capsys.readouterr().err


def _evt21_word(v: int, legacy: bool) -> bytes:
    """A 64-bit EVT 2.1 word's bytes: little-endian, or (``legacy``) as the IMX636 sends it,
    its high 32-bit half first, each half little-endian."""
    if legacy:
        return (v >> 32).to_bytes(4, "little") + (v & 0xFFFF_FFFF).to_bytes(4, "little")
    return int(v).to_bytes(8, "little")


def _evt21(head: bytes, tmp_path: Path, name: str, *, legacy: bool = False) -> Path:
    """A small EVT 2.1 file: TIME_HIGH words and CD words with pixel masks (Prophesee's
    layout; faery 0.7 cannot decode this format), its words as :func:`_evt21_word` writes
    them."""

    def word(v: int) -> bytes:
        return _evt21_word(v, legacy)

    def time_high(t: int) -> bytes:
        return word((0x8 << 60) | ((t >> 6) << 32))

    def cd(on: bool, t: int, x: int, y: int, mask: int) -> bytes:
        return word((int(on) << 60) | ((t & 63) << 54) | (x << 43) | (y << 32) | mask)

    data = (
        cd(True, 5, 0, 0, 1)  # before any TIME_HIGH: no time, skipped
        + time_high(1000)
        + cd(True, 1000, 32, 5, 0b101)
        + cd(False, 1010, 64, 7, 1)
        + word(0xE << 60)  # an "others" word: no CD event
        + time_high(2000)
        + cd(True, 2001, 0, 319, 1 << 31)
    )
    path = tmp_path / name
    path.write_bytes(head + b"% end\n" + data)
    return path


def test_evt21_and_genx320_format_lines_are_read(tmp_path: Path) -> None:
    expected = [
        (1000, 32, 5, True),
        (1000, 34, 5, True),
        (1010, 64, 7, False),
        (2001, 31, 319, True),
    ]
    plugin = b"% plugin_name hal_plugin_genx320_evk\n"
    written = {
        "evt": _evt21(b"% evt 2.1\n", tmp_path, "a.raw"),
        "format": _evt21(plugin + b"% format EVT21;height=320;width=320\n", tmp_path, "b.raw"),
        "camera": _evt21(plugin + b"% format EVT21\n", tmp_path, "c.raw"),
    }
    for how, path in written.items():
        rec = io.read(path, sensor_size=(320, 320) if how == "evt" else None)
        assert rec.events.tolist() == expected, how
        assert rec.sensor_size == (320, 320)
    assert io.read(written["format"]).metadata["sensor_size_source"] == "file"
    camera = io.read(written["camera"]).metadata
    assert (camera["sensor_size_source"], camera["camera"]) == ("camera", "genx320")
    with pytest.raises(uavsnn.ParameterError, match="contradicts"):
        io.read(written["format"], sensor_size=(640, 480))
    # A cut word is still refused as truncated.
    cut = tmp_path / "cut.raw"
    cut.write_bytes(written["format"].read_bytes()[:-3])
    with pytest.raises(uavsnn.RecordingFileError, match="truncated"):
        io.read(cut)


def test_evt21_of_the_imx636_family_is_read_with_its_halves_swapped(tmp_path: Path) -> None:
    # OpenEB writes "endianness=legacy" for the IMX636, Gen4.1 and IMX646: each 64-bit word's
    # halves high first (Prophesee: 0x0102030405060708 arrives as 04 03 02 01 08 07 06 05).
    # Read as plain little-endian words, the file gave no event and no error.
    assert _evt21_word(0x0102030405060708, True) == bytes([4, 3, 2, 1, 8, 7, 6, 5])
    assert _evt21_word(0x0102030405060708, False) == bytes([8, 7, 6, 5, 4, 3, 2, 1])
    head = b"% format EVT21;height=720;width=1280;endianness=legacy\n"
    rec = io.read(_evt21(head, tmp_path, "imx636.raw", legacy=True))
    assert rec.sensor_size == (1280, 720)
    assert rec.events.tolist() == [
        (1000, 32, 5, True),
        (1000, 34, 5, True),
        (1010, 64, 7, False),
        (2001, 31, 319, True),
    ]
    big = _evt21(b"% format EVT21;height=720;width=1280;endianness=big\n", tmp_path, "b.raw")
    with pytest.raises(uavsnn.RecordingFileError, match="endianness=big is not read"):
        io.read(big)


def _small_aedat4(path: Path) -> bytes:
    """A small AEDAT4 file, as faery writes it: its bytes."""
    faery = pytest.importorskip("faery")
    ev = np.zeros(10, faery.EVENTS_DTYPE)
    ev["t"] = np.arange(10)
    faery.events_stream_from_array(ev, (64, 48)).to_file(path, zero_t0=False)
    return path.read_bytes()


def test_aedat4_description_not_utf8_is_refused_not_an_abort(tmp_path: Path) -> None:
    # faery 0.7 panicked inside its decoder and aborted the interpreter (SIGABRT): run the read
    # in a child process.
    path = tmp_path / "latin1.aedat4"
    data = bytearray(_small_aedat4(path))
    data[data.index(b'type="string">EVTS') + 15] = 0xE9
    path.write_bytes(data)
    code = (
        "import sys, uavsnn, uavsnn.io\n"
        "try:\n"
        f"    uavsnn.io.read({str(path)!r})\n"
        "except uavsnn.RecordingFileError as exc:\n"
        "    print(exc)\n"
        "    sys.exit(3)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=False
    )
    assert done.returncode == 3, done.stderr[-2000:]
    assert "latin1.aedat4" in done.stdout and "not UTF-8: byte 0xE9" in done.stdout
    assert "panicked" not in done.stderr


def test_aedat4_sizes_beyond_the_file_or_zero_are_refused_before_faery(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "rec.aedat4"
    good = _small_aedat4(path)
    (length,) = struct.unpack_from("<I", good, 14)
    packet = 18 + length  # the first packet header: i32 stream id, u32 size
    (first,) = struct.unpack_from("<I", good, packet + 4)
    cases = {
        (14, 0xFFFFFFFF): "corrupt AEDAT4 header: it claims 4294967295 bytes",
        (packet + 4, 0xFFFFFFFF): "packet at byte .* claims 4294967295 bytes",
        (packet + 4, 0): "packet at byte .*: its size is 0",
        # Into the data table: faery decoded its bytes and allocated 4 GB (an abort where
        # memory is capped).
        (packet + 4, first + 4): "packets: they end at byte .*, not at the data table",
    }
    for (at, value), message in cases.items():
        data = bytearray(good)
        data[at : at + 4] = struct.pack("<I", value)
        path.write_bytes(data)
        with pytest.raises(uavsnn.RecordingFileError, match=f"rec.aedat4: .*{message}"):
            io.read(path)
    assert "panicked" not in capfd.readouterr().err
    path.write_bytes(good)
    assert len(io.read(path)) == 10


@pytest.mark.parametrize("ext", ["npy", "csv", "raw", "dat", "aedat4"])
def test_unreadable_files_are_a_recording_file_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, ext: str
) -> None:
    path = tmp_path / f"locked.{ext}"
    path.write_bytes(b"% evt 2.0\n0,1,1,1\n")

    def refuse(file: object, *args: object, **kwargs: object) -> object:
        raise PermissionError(13, "Permission denied", str(file))

    with monkeypatch.context() as patch:
        # The readers' own open() calls (RAW/DAT headers are read by uavsnn._prophesee, CSV
        # files checked by uavsnn._csv).
        for module in (io, prophesee, csv_reader):
            patch.setattr(module, "open", refuse, raising=False)
        with pytest.raises(uavsnn.RecordingFileError, match=r"locked\..*Permission denied"):
            io.read(path, sensor_size=(64, 48))
    # Root reads a chmod 000 file; Windows keeps no such mode.
    if hasattr(os, "geteuid") and os.geteuid() != 0:
        path.chmod(0)
        try:
            with pytest.raises(uavsnn.RecordingFileError, match=r"locked\."):
                io.read(path, sensor_size=(64, 48))
        finally:
            path.chmod(0o600)


def test_csv_byte_order_mark_and_numeric_first_lines_lose_nothing(tmp_path: Path) -> None:
    path = tmp_path / "rec.csv"
    for text in ("\ufeff5,2,3,1\n6,4,5,0\n", "\ufefft,x,y,p\n5,2,3,1\n6,4,5,0\n"):
        path.write_bytes(text.encode())
        rec = io.read(path, sensor_size=(64, 48))
        assert rec.events.tolist() == [(5, 2, 3, True), (6, 4, 5, False)], text
    path.write_bytes("\ufeff7,2,3,1\n6,4,5,0\n".encode())
    with pytest.raises(uavsnn.RecordingFileError, match="line 2: time 6 is earlier"):
        io.read(path, sensor_size=(64, 48))
    for first in ("0.5", "1e5"):
        path.write_text(f"{first},2,3,1\n")
        with pytest.raises(uavsnn.RecordingFileError, match=r"line 1: .*must be integers"):
            io.read(path, sensor_size=(64, 48))


@pytest.mark.parametrize(
    "text",
    [
        "5,2,3,1\n6,4,5,-1\n",  # OFF as -1 (tonic, many datasets' CSVs)
        "x,y,t,p\n2,3,5,1\n4,5,6,0\n",  # columns named in another order
        "Timestamp, X, Y, Polarity\n5,2,3,1\n6,4,5,-1\n",
        "\ufeffx,y,p,t\n2,3,1,5\n4,5,-1,6\n",
        "\ufeff5,2,3,1\n6,4,5,-1\n",
        "t,x,y,p\n5,2,3,1\n6,4,5,-1\n",
    ],
)
def test_csv_columns_named_by_the_header_and_off_as_minus_one(tmp_path: Path, text: str) -> None:
    path = tmp_path / "rec.csv"
    path.write_bytes(text.encode())
    rec = io.read(path, sensor_size=(64, 48))
    assert rec.events.tolist() == [(5, 2, 3, True), (6, 4, 5, False)]


def test_csv_off_events_written_both_ways_are_refused(tmp_path: Path) -> None:
    path = tmp_path / "mixed.csv"
    path.write_text("5,2,3,-1\n6,4,5,1\n7,4,5,0\n")
    with pytest.raises(uavsnn.RecordingFileError, match=r"line 3: an OFF event written 0.*line 1"):
        io.read(path, sensor_size=(64, 48))
    # A header naming fewer than the four fields leaves the usual order (t, x, y, p).
    path.write_text("time,x,y,brightness\n5,2,3,1\n")
    assert io.read(path, sensor_size=(64, 48)).events.tolist() == [(5, 2, 3, True)]


@pytest.mark.parametrize(
    "text",
    [
        "t,x,y,p\n5,2,3,1\n6,4,5,0\n\n",  # a blank last line (faery refused it)
        "t,x,y,p\r\n5,2,3,1\r\n6,4,5,0\r\n\r\n \r\n\t\n",
        "t,x,y,p\n5,2,3,1\n\n\n6,4,5,0\n  ",
        "\n\nt,x,y,p\n5,2,3,1\n6,4,5,0\n",  # blank lines before the header
        "\n5,2,3,1\n\n6,4,5,0\n",
        "\n\nx,y,t,p\n2,3,5,1\n\n4,5,6,-1\n",
        "\ufeff5,2,3,1\n\n6,4,5,0\n\n",
        "\ufeff\nt,x,y,p\n5,2,3,1\n6,4,5,0\n",
    ],
)
def test_csv_blank_lines_are_skipped(tmp_path: Path, text: str) -> None:
    path = tmp_path / "rec.csv"
    path.write_bytes(text.encode())
    rec = io.read(path, sensor_size=(64, 48))
    assert rec.events.tolist() == [(5, 2, 3, True), (6, 4, 5, False)]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("t,x,y,p\n5,1,2,1\n6,a,2,1\n", "line 3: '6,a,2,1': x 'a' is not an integer"),
        ("t,x,y,p\n5,1,2,1\n\n6,a,2,1\n\n", "line 4: '6,a,2,1': x 'a' is not an integer"),
        ("\n5,1,2,1\n6,1\n", r"line 3: '6,1': no y \(field 3\)"),
        ("t,x,y,p\n\n5,1,2,1\n-6,1,2,1\n", "line 4: '-6,1,2,1': t '-6' is not a whole"),
        ("t,x,y,p\n5,1,2,1\n6,1,2,2\n", "line 3: '6,1,2,2': p '2' is neither 1 nor 0"),
        ("5,1,2,1\n\n6,64,2,1\n", "line 3: '6,64,2,1': x=64, y=2 is off the 64x48 sensor"),
        # faery reads "+6" as 6: a time that goes backwards too.
        ("10,1,2,1\n+6,1,2,1\n", "line 2: time 6 is earlier than the time before it"),
    ],
)
def test_csv_lines_faery_cannot_read_are_refused_naming_the_line(
    tmp_path: Path, text: str, message: str
) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(uavsnn.RecordingFileError, match=f"^{re.escape(str(path))}: {message}"):
        io.read(path, sensor_size=(64, 48))


def test_an_npz_with_tonic_sensor_size_reads(tmp_path: Path) -> None:
    path = tmp_path / "tonic.npz"
    np.savez(path, events=_events(20), sensor_size=np.array([64, 48, 2]))
    rec = io.read(path)
    assert rec.sensor_size == (64, 48)
    np.testing.assert_array_equal(rec.events, _events(20))


def test_csv_times_beyond_the_engine_limit_are_refused(tmp_path: Path) -> None:
    path = tmp_path / "late.csv"
    for t in (2**63, 2**62 + 1, 2**64 + 5):
        path.write_text(f"1,2,3,1\n{t},2,3,1\n")
        with pytest.raises(uavsnn.RecordingFileError, match=f"late.csv: line 2: time {t} is"):
            io.read(path, sensor_size=(64, 48))
    path.write_text(f"{2**62},2,3,1\n")
    assert int(io.read(path, sensor_size=(64, 48)).events["t"][0]) == 2**62


@pytest.mark.parametrize("stored", [["lab", 3], "lab", 3.5, None])
def test_npz_metadata_other_than_an_object_is_kept(stored: object, tmp_path: Path) -> None:
    # A writer other than this package may store a list or a string: it was dropped.
    path = tmp_path / "other.npz"
    np.savez(
        path,
        events=_events(3),
        sensor_size=np.array([64, 48]),
        metadata=np.array(json.dumps(stored)),
    )
    meta = io.read(path).metadata
    assert meta["stored"] == stored and meta["format"] == "npz"


def test_npz_metadata_nested_too_deeply_is_a_file_error(tmp_path: Path) -> None:
    path = tmp_path / "deep.npz"
    np.savez(
        path,
        events=_events(3),
        sensor_size=np.array([64, 48]),
        metadata=np.array("[" * 100_000 + "]" * 100_000),
    )
    with pytest.raises(uavsnn.RecordingFileError, match=r"deep\.npz: bad 'metadata'"):
        io.read(path)


_EVT2_WORDS = np.array([0x8 << 28 | 1, 1 << 28 | (1 << 11) | 1], "<u4").tobytes()


@pytest.mark.parametrize(
    ("name", "head", "field"),
    [
        ("a.raw", b"% evt 2.0\n% geometry 64x48x3\n", "% geometry 64x48x3"),
        ("b.raw", b"% evt 2.0\n% geometry 70000x70000\n", "% geometry 70000x70000"),
        ("c.raw", b"% evt 2.0\n% geometry abc\n", "% geometry abc"),
        ("d.raw", b"% format EVT21;height=abc\n", "% format EVT21;height=abc"),
        ("e.raw", b"% format EVT21;height=0;width=0\n", "% format EVT21;height=0;width=0"),
        ("f.dat", b"% Width 70000\n% Height 48\n", "% Width 70000 and % Height 48"),
    ],
)
def test_header_geometry_that_cannot_be_a_sensor_is_refused(
    tmp_path: Path, name: str, head: bytes, field: str
) -> None:
    path = tmp_path / name
    if name.endswith(".dat"):
        data = b"\x00\x08" + np.zeros(2, "<u8").tobytes()  # type, size, two records
    elif b"EVT21" in head:
        data = np.array([(8 << 60) | (1 << 32), (1 << 60) | (5 << 32) | 1], "<u8").tobytes()
    else:
        data = _EVT2_WORDS
    path.write_bytes(head + b"% end\n" + data)
    with pytest.raises(uavsnn.RecordingFileError, match=re.escape(f"{name}: corrupt header: ")):
        io.read(path)
    with pytest.raises(uavsnn.RecordingFileError, match=re.escape(repr(field))):
        io.read(path)


def test_header_geometry_that_is_a_sensor_is_taken(tmp_path: Path) -> None:
    for head in (b"% geometry 64x48\n", b"% format EVT2;width=64;height=48\n"):
        path = tmp_path / "ok.raw"
        path.write_bytes(b"% evt 2.0\n" + head + b"% end\n" + _EVT2_WORDS)
        rec = io.read(path)
        assert (rec.sensor_size, rec.metadata["sensor_size_source"]) == ((64, 48), "file")


def test_npy_events_beyond_any_sensor_are_a_file_error(tmp_path: Path) -> None:
    ev = _events(5)
    ev["x"][2] = 65535  # the inferred width would be 65536
    path = tmp_path / "wide.npy"
    np.save(path, ev)
    with pytest.raises(uavsnn.RecordingFileError, match=r"wide\.npy: events reach x=65535"):
        io.read(path)


@pytest.mark.parametrize("suffix", [".npy", ".npz"])
def test_a_plain_column_array_says_how_to_convert_it(tmp_path: Path, suffix: str) -> None:
    # The reader has no layout= argument: its message named one.
    plain = np.zeros((3, 4), np.int64)
    path = tmp_path / f"plain{suffix}"
    if suffix == ".npy":
        np.save(path, plain)
    else:
        np.savez(path, events=plain, sensor_size=np.array([10, 10]))
    with pytest.raises(uavsnn.RecordingFileError, match=r"uavsnn\.events\.convert\(array, layout"):
        io.read(path, sensor_size=(10, 10))
