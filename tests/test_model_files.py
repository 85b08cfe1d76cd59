"""Model files as a tester probed them: a damaged identification (a version-3 file without its
trees, arrays without ``identify.version``, an array missing or of the wrong shape) is a
``ModelFileError`` naming the array, not a model loaded otherwise; ``Network.save`` with an
identification gives a ``ModelFileError`` for every path it cannot write (and takes names as long
as the temporary names allow); a network whose window states would not fit in
``uavsnn.windows.MEMORY_LIMIT`` is refused before the engine aborts on them; ``uavsnn info``
sends a damaged model to the model loader; identifications compare with ``==`` and are not
hashable; a recording smaller than the model is not told to ``--downsample``; a float32 share or
rate selects its operating point."""

from __future__ import annotations

import copy
import re
import warnings
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import SMALL_SENSOR, one_line_exit_2, random_events, small_config

import uavsnn.windows
from uavsnn import Detector, Network
from uavsnn.cli import main
from uavsnn.cli.info import is_model_file
from uavsnn.errors import ModelFileError, ParameterError
from uavsnn.events import Recording
from uavsnn.features import FEATURES
from uavsnn.identifier import Identifier
from uavsnn.io import write_npz
from uavsnn.sources import FileSource, check_fits
from uavsnn.trees import Trees

TREE_ARRAYS = (
    "identify.tree_feature",
    "identify.tree_threshold",
    "identify.tree_leaf",
    "identify.tree_base",
)
CLASS_ARRAYS = ("identify.classes", "identify.class_coef", "identify.class_l2")


def identifier(*, trees: bool = False) -> Identifier:
    """A model made by hand: logistic, with a class model and two false-alarm shares (and
    trees when asked)."""
    k = len(FEATURES)
    class_coef = np.zeros((3, k + 1))
    class_coef[1, 0] = 1.0
    return Identifier(
        FEATURES,
        np.linspace(-1, 1, k + 1),
        np.arange(k) * 0.5,
        np.ones(k) * 2,
        0.3,
        0.1,
        classes=("uav", "bird", "clutter"),
        class_coef=class_coef,
        class_l2=0.5,
        alarm_thresholds=((0.01, 0.9), (0.05, 0.7)),
        track_alarm_thresholds=((0.1, 0.8),),
        track_alarm_minutes=10.0,
        trees=Trees(
            np.array([[0, k - 1], [3, 0]]),
            np.array([[0.0, 0.5], [-0.25, 1.0]]),
            np.array([[-1.0, 0.0, 1.0, 2.0], [0.5, -0.5, 0.25, 0.0]]),
            -0.2,
        )
        if trees
        else None,
    )


def saved(tmp_path: Path, *, trees: bool = False) -> Path:
    net = Network(small_config(), seed=1)
    net.identification = identifier(trees=trees)
    path = tmp_path / "model.npz"
    net.save(path)
    return path


def without(path: Path, names: tuple[str, ...]) -> None:
    """Rewrite the model file ``path`` without the arrays ``names``."""
    with zipfile.ZipFile(path) as archive:
        kept = [(i, archive.read(i)) for i in archive.infolist()]
    with zipfile.ZipFile(path, "w") as archive:
        for info, data in kept:
            if info.filename.removesuffix(".npy") not in names:
                archive.writestr(info, data)


def replaced(path: Path, name: str, value: np.ndarray) -> None:
    from uavsnn.network import _add_arrays

    _add_arrays(str(path), {name: value})


# -- 1. a version-3 identification without its trees -------------------------------------------


@pytest.mark.parametrize("dropped", [TREE_ARRAYS, *((name,) for name in TREE_ARRAYS)])
def test_a_version_3_file_without_its_trees_is_refused(
    tmp_path: Path, dropped: tuple[str, ...]
) -> None:
    # It loaded as a logistic model scored at the trees' threshold.
    path = saved(tmp_path, trees=True)
    loaded = Network.load(path).identification
    assert loaded is not None and loaded.trees is not None
    without(path, dropped)
    with pytest.raises(ModelFileError, match=rf"inconsistent: {re.escape(dropped[0])} is missing"):
        Network.load(path)


def test_the_class_part_is_optional_within_version_2_but_not_in_parts(tmp_path: Path) -> None:
    # docs/identification.md: a model without the class part is a training set with fewer
    # than two classes, written as version 2 too: it loads without one.
    path = saved(tmp_path)
    without(path, CLASS_ARRAYS)
    ident = Network.load(path).identification
    assert ident is not None and ident.classes == () and ident.class_coef is None
    # Its coefficients without the class names are a damaged file (they were ignored).
    path = saved(tmp_path)
    without(path, ("identify.classes",))
    with pytest.raises(ModelFileError, match=r"identify\.class_coef is stored without"):
        Network.load(path)


# -- 2. identification arrays without identify.version -----------------------------------------


def test_identification_arrays_without_their_version_are_refused(tmp_path: Path) -> None:
    # It loaded as a model without identification.
    path = saved(tmp_path, trees=True)
    without(path, ("identify.version",))
    with pytest.raises(ModelFileError, match=r"inconsistent: identify\.version is missing"):
        Network.load(path)
    with pytest.raises(ModelFileError, match=r"identify\.version is missing beside 1 of them"):
        Identifier.from_arrays({"identify.coef": np.zeros(3)})
    # No identify.* array at all: no identification, as before.
    assert Identifier.from_arrays({"conv1": np.zeros(3)}) is None


# -- 3. saving with an identification: typed errors, and long names ----------------------------


@pytest.fixture
def with_model() -> Network:
    net = Network(small_config(), seed=1)
    net.identification = identifier()
    return net


def test_a_save_under_a_file_is_a_model_file_error(tmp_path: Path, with_model: Network) -> None:
    # The cleanup's NotADirectoryError hid the engine's ModelFileError.
    (tmp_path / "keep.npz").write_bytes(b"x")
    with pytest.raises(ModelFileError, match=r"cannot write .*keep\.npz/x\.npz: Not a directory"):
        with_model.save(tmp_path / "keep.npz" / "x.npz")
    assert [p.name for p in tmp_path.iterdir()] == ["keep.npz"]


def test_a_name_too_long_is_a_model_file_error(tmp_path: Path, with_model: Network) -> None:
    # It was the raw OSError ENAMETOOLONG of the cleanup.
    with pytest.raises(ModelFileError, match="File name too long"):
        with_model.save(tmp_path / ("a" * 300 + ".npz"))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("path", ["", ".", "..", "x/"])
def test_a_path_without_a_file_name_is_a_model_file_error(
    path: str, tmp_path: Path, with_model: Network, monkeypatch: pytest.MonkeyPatch
) -> None:
    # "" was a ValueError; "x/" wrote a file "x". Without identification, the engine says so.
    monkeypatch.chdir(tmp_path)
    for net in (with_model, Network(small_config(), seed=1)):
        with pytest.raises(ModelFileError, match="cannot write"):
            net.save(path)
    assert list(tmp_path.iterdir()) == []


def test_a_long_name_saves_with_an_identification(tmp_path: Path, with_model: Network) -> None:
    # A 235-character name failed only with an identification: the temporary names nested.
    # Now the longest is 237 bytes (255 less the 18 of ".NAME.<12 hex>.tmp").
    for length in (235, 237):
        path = tmp_path / ("b" * (length - 4) + ".npz")
        with_model.save(path)
        back = Network.load(path)
        assert back == with_model and back.identification == with_model.identification
    with pytest.raises(ModelFileError, match="File name too long"):
        with_model.save(tmp_path / ("c" * 234 + ".npz"))
    assert sorted(len(p.name) for p in tmp_path.iterdir()) == [235, 237]


# -- 4. window states beyond the memory this process may have ----------------------------------


def test_the_state_bytes_are_the_engines_count(monkeypatch: pytest.MonkeyPatch) -> None:
    """The engine names one state's bytes when a Detector's live windows pass its 4 GiB cap,
    which it refuses before allocating any; Python's count is the same, for other layers and
    pools too."""
    monkeypatch.setattr(uavsnn.windows, "MEMORY_LIMIT", None)
    configs = [
        {"width": 4000, "height": 4000},
        {"width": 3001, "height": 2999, "padding": "valid"},
        {"width": 5000, "height": 3000, "conv1": {"maps": 2}, "pool1": {"kernel": 9, "stride": 4}},
    ]
    for config in configs:
        net = Network(config)
        with pytest.raises(ParameterError, match="MAX_ALLOC_BYTES") as caught:
            Detector(net, overlap=0.95, rotor=False)
        count = re.search(r"\((\d+) x (\d+)\)", str(caught.value))
        assert count is not None and int(count.group(2)) == net.state_bytes


def test_window_states_beyond_the_memory_limit_are_refused(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # A config within the engine's caps aborted the process ("memory allocation of ...
    # failed") under `ulimit -v`: refused now against uavsnn.windows.MEMORY_LIMIT.
    net = Network(small_config(), seed=1)
    one = net.state_bytes
    pixels = SMALL_SENSOR[0] * SMALL_SENSOR[1] * 40
    events = random_events(50, SMALL_SENSOR)
    t, x, y = events["t"], events["x"], events["y"]
    monkeypatch.setattr(uavsnn.windows, "MEMORY_LIMIT", one - 1)
    message = rf"one window's state .* would need {one:,} bytes, more than the {one - 1:,} bytes"
    with pytest.raises(
        ParameterError, match=message + r" allowed \(uavsnn\.windows\.MEMORY_LIMIT\)"
    ):
        net.run_window(t, x, y, int(t[0]))
    with pytest.raises(ParameterError, match="MEMORY_LIMIT"):
        net.stdp_step("conv2", t, x, y, int(t[0]))
    windows = uavsnn.windows.make_windows(Recording(events, SMALL_SENSOR), 10_000)
    for call in (net.infer, lambda w: net.train_layer("conv2", w)):
        with pytest.raises(ParameterError, match="MEMORY_LIMIT"):
            call(windows)
    with pytest.raises(ParameterError, match="MEMORY_LIMIT"):
        Detector(net, overlap=0.0)
    # A Detector holds a state per live window (2 at an overlap of 0.5) and 40 bytes a pixel.
    monkeypatch.setattr(uavsnn.windows, "MEMORY_LIMIT", 2 * one + pixels - 1)
    with pytest.raises(ParameterError, match=r"the states of 2 live windows .* smaller overlap"):
        Detector(net, overlap=0.5)
    assert Detector(net, overlap=0.0).push(events) is not None
    net.run_window(t, x, y, int(t[0]))
    monkeypatch.setattr(uavsnn.windows, "MEMORY_LIMIT", 2 * one + pixels)
    Detector(net, overlap=0.5)
    # More live windows than the engine allows is still its to refuse, in its words.
    with pytest.raises(ParameterError, match="at most 64 are allowed"):
        Detector(net, overlap=0.99)


# -- 5. uavsnn info on a damaged model ---------------------------------------------------------


@pytest.mark.parametrize("dropped", ["conv3", "format", "config"])
def test_info_sends_a_model_missing_an_array_to_the_model_loader(
    tmp_path: Path, dropped: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # It said "an .npz recording needs arrays 'events' and 'sensor_size'".
    path = tmp_path / "model.npz"
    Network(small_config(), seed=1).save(path)
    without(path, (dropped,))
    assert is_model_file(path)
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert "model file" in err and dropped in err and "recording" not in err


def test_info_sends_a_truncated_model_to_the_model_loader(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # It said "cannot read as .npz: File is not a zip file".
    path = saved(tmp_path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    assert is_model_file(path)
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert "model file" in err and "cannot read as .npz" not in err
    # A recording, whole or not, and another archive stay recordings.
    rec = tmp_path / "rec.npz"
    write_npz(Recording(random_events(20, SMALL_SENSOR), SMALL_SENSOR), rec)
    assert not is_model_file(rec)
    rec.write_bytes(rec.read_bytes()[:100])
    assert not is_model_file(rec)
    np.savez(tmp_path / "other.npz", foo=np.zeros(3))
    assert not is_model_file(tmp_path / "other.npz")


# -- 6. comparing identifications ---------------------------------------------------------------


def test_identifications_compare_by_their_arrays_and_are_not_hashable(tmp_path: Path) -> None:
    # == raised "The truth value of an array is ambiguous"; hash() a TypeError of ndarray.
    net = Network(small_config(), seed=1)
    net.identification = identifier(trees=True)
    twin = copy.deepcopy(net)
    assert twin.identification is not net.identification
    assert (twin.identification == net.identification) is True
    assert twin.identification != replace(identifier(trees=True), coef=np.zeros(len(FEATURES) + 1))
    assert identifier(trees=True) != identifier()
    assert identifier() != "a model" and identifier() == identifier()
    with pytest.raises(TypeError, match="unhashable"):
        hash(identifier())
    net.save(tmp_path / "m.npz")
    assert Network.load(tmp_path / "m.npz").identification == net.identification


# -- 7. a recording smaller than the model ------------------------------------------------------


def test_a_smaller_recording_is_not_told_to_downsample(tmp_path: Path) -> None:
    # Following the advice failed: "downsampling only reduces".
    model = (40, 30)
    for size, advice in (((30, 40), "smaller than"), ((40, 20), "smaller than"), ((80, 60), "add")):
        path = tmp_path / f"r{size[0]}x{size[1]}.npz"
        write_npz(Recording(random_events(20, (min(size[0], 30), min(size[1], 20))), size), path)
        with pytest.raises(ParameterError) as caught:
            check_fits(FileSource(path), model)
        text = str(caught.value)
        assert advice in text and f"{size[0]}x{size[1]}" in text and "40x30" in text
        assert ("add --downsample" in text) == (advice == "add")
    # The model's own size fits.
    path = tmp_path / "r40x30.npz"
    write_npz(Recording(random_events(20, model), model), path)
    check_fits(FileSource(path), model)


def test_a_file_of_no_event_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # A RAW header alone (a file cut short inside its header) detected nothing and exited 0.
    model = (40, 30)
    path = tmp_path / "empty.npz"
    write_npz(Recording(random_events(0, model), model), path)
    with pytest.raises(ParameterError, match=r"empty\.npz holds no event: nothing to detect"):
        check_fits(FileSource(path), model)
    net = tmp_path / "m.npz"
    Network(small_config(), seed=0).save(net)
    line = one_line_exit_2(capsys, ["detect", str(path), "-m", str(net)], "holds no event")
    assert line.startswith("uavsnn detect: error: ")


def test_a_npy_recording_within_the_model_is_asked_for_its_sensor_size(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A .npy file's size is its events' extent: events short of the edge were told to use a
    # model of that extent's size, and --sensor-size was the fix.
    model = (40, 30)
    path = tmp_path / "r.npy"
    np.save(path, random_events(200, (33, 25)))
    with pytest.raises(ParameterError, match=r"r\.npy records no sensor size.*--sensor-size 40x30"):
        check_fits(FileSource(path), model)
    check_fits(FileSource(path, sensor_size=model), model)  # the advice taken, it fits
    # An extent beyond the model's on either axis keeps the advice of its size.
    np.save(path, random_events(200, (50, 25)))
    with pytest.raises(ParameterError, match=r"sensor is 50x25, smaller than the model's input"):
        check_fits(FileSource(path), model)


# -- 8. operating points of a float32 rate; messages naming the array ---------------------------


def test_a_float32_share_or_rate_selects_its_operating_point() -> None:
    ident = identifier()
    assert ident.at_false_alarm(np.float32(0.01)).threshold == 0.9
    assert ident.at_false_alarm(0.05).threshold == 0.7
    assert ident.at_false_tracks(np.float32(0.1)).threshold == 0.8
    with pytest.raises(ParameterError, match=r"not tuned for a false-alarm share of 0\.0101"):
        ident.at_false_alarm(0.0101)
    with pytest.raises(ParameterError, match=r"not tuned for 0\.11 false tracks"):
        ident.at_false_tracks(0.11)


@pytest.mark.parametrize(
    ("name", "value", "message"),
    [
        ("identify.coef", None, "identify.coef is missing"),
        (
            "identify.threshold",
            np.zeros((2, 2)),
            r"identify\.threshold must be one number, got an "
            r"array of float64 \(2, 2\)",
        ),
        ("identify.l2", np.array("0.1"), r"identify\.l2 must be one number"),
        ("identify.alarm_thresholds", None, "identify.alarm_thresholds is missing"),
        ("identify.track_alarm_minutes", None, "identify.track_alarm_minutes is missing"),
    ],
)
def test_a_missing_or_misshapen_array_is_named_plainly(
    tmp_path: Path, name: str, value: np.ndarray | None, message: str
) -> None:
    # A missing one showed KeyError's repr ("'identify.coef is not a file in the archive'");
    # a 2-D threshold "only 0-dimensional arrays can be converted to Python scalars".
    path = saved(tmp_path)
    if value is None:
        without(path, (name,))
    else:
        replaced(path, name, value)
    with pytest.raises(ModelFileError, match="inconsistent: " + message) as caught:
        Network.load(path)
    assert "'" not in str(caught.value) and "archive" not in str(caught.value)


def test_changing_the_weights_drops_an_identification_fitted_on_the_old_ones() -> None:
    """An identification scores features of the network's own spikes: trained further, or
    given other weights, the network keeps none fitted on the old weights (it was kept, and
    saved with the new weights)."""
    events = random_events(400, SMALL_SENSOR, seed=3)
    windows = uavsnn.windows.make_windows(Recording(events, SMALL_SENSOR), 20_000)
    net = Network(small_config(), seed=1)

    def train(n: Network) -> None:
        n.train_layer("conv2", windows)

    def stdp(n: Network) -> None:
        n.stdp_step("conv2", events["t"], events["x"], events["y"], 0)

    def replace_weights(n: Network) -> None:
        n.set_weights("conv3", n.weights("conv3") * np.float32(0.5))

    for change in (train, stdp, replace_weights):
        net.identification = identifier()
        with pytest.warns(UserWarning, match="identification, fitted on the old weights, is"):
            change(net)
        assert net.identification is None
    # Without an identification, nothing to say.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        replace_weights(net)
    # A copy's pictures of its weights (the report's) leave the network's identification be.
    net.identification = identifier()
    net.copy().identification = None
    assert net.identification is not None
