"""Layer-wise training: windows per layer, snapshots, checkpoints that survive an interruption
and resume to the same weights, config overrides, and that training learns something."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import uavsnn
from uavsnn.dataset import SceneSource, build, load
from uavsnn.errors import DatasetError, ParameterError
from uavsnn.training import STATE_FILE, apply_overrides, parse_override, train

CONFIG = {"conv2": {"threshold": 15.0}}


@pytest.fixture(scope="module")
def windows(tmp_path_factory: pytest.TempPathFactory) -> uavsnn.windows.Windows:
    root = tmp_path_factory.mktemp("train") / "set"
    build(
        root, "dvs", n_test=20, n_train=40, seed=7, dvs=SceneSource("dvs", (240, 180), 200.0, 0.3)
    )
    return load(root, "train").windows


def _weights(net: uavsnn.Network) -> dict[str, np.ndarray]:
    return {layer: net.weights(layer) for layer in ("conv1", "conv2", "conv3")}


def test_each_layer_sees_the_windows_asked_for(windows: uavsnn.windows.Windows) -> None:
    net = uavsnn.Network(CONFIG, seed=1)
    conv1 = net.weights("conv1")
    result = train(net, windows, windows_per_layer=100, snapshots=4)
    assert list(result.layers) == ["conv2", "conv3"]
    for layer, r in result.layers.items():
        # Progress reports every 100 // 4 = 25 windows: training stops at the one at 100.
        assert r.report.windows_seen == 100
        seen = [s for s, _ in r.snapshots]
        assert seen[0] == 0 and seen[-1] == r.report.windows_seen and seen == sorted(seen)
        np.testing.assert_array_equal(r.snapshots[-1][1], net.weights(layer))
    np.testing.assert_array_equal(net.weights("conv1"), conv1)  # Gabor stays fixed


def test_training_stops_at_the_first_report_at_or_past_the_count(
    windows: uavsnn.windows.Windows,
) -> None:
    # 40 windows: 77 asks for two passes (80 windows) with reports every 64 and at the end;
    # 130 with 6 snapshots, reports every 21 windows (126 < 130 <= 147).
    for asked, snapshots, seen in [(77, 0, 80), (130, 6, 147), (5, 2, 6)]:
        net = uavsnn.Network(CONFIG, seed=1)
        result = train(net, windows, layers=["conv2"], windows_per_layer=asked, snapshots=snapshots)
        assert result.layers["conv2"].report.windows_seen == seen, asked


def test_training_learns_weights_settle_towards_0_or_1(windows: uavsnn.windows.Windows) -> None:
    net = uavsnn.Network(CONFIG, seed=1)
    before = _weights(net)
    result = train(net, windows, windows_per_layer=8000, snapshots=0)
    for layer in ("conv2", "conv3"):
        c = result.layers[layer].report.convergence
        assert c[-1] < 0.5 * c[0], (layer, c[0], c[-1])
        assert not np.array_equal(before[layer], net.weights(layer))


def test_layers_must_be_known_and_in_order(windows: uavsnn.windows.Windows) -> None:
    net = uavsnn.Network(CONFIG, seed=1)
    with pytest.raises(ParameterError, match="cannot train 'pool1'"):
        train(net, windows, layers=["pool1"])
    with pytest.raises(ParameterError, match="in the network's order"):
        train(net, windows, layers=["conv3", "conv2"])
    with pytest.raises(ParameterError, match="distinct"):
        train(net, windows, layers=["conv2", "conv2"])
    with pytest.raises(ParameterError, match="windows_per_layer must be an integer >= 1"):
        train(net, windows, windows_per_layer=0)
    with pytest.raises(DatasetError, match="no training windows"):
        train(net, windows.select([]))


def test_checkpoint_survives_an_interruption_and_resume_gives_the_same_model(
    windows: uavsnn.windows.Windows, tmp_path: Path
) -> None:
    whole = uavsnn.Network(CONFIG, seed=3)
    train(whole, windows, windows_per_layer=200, seed=4, snapshots=0)

    class Stop(Exception):
        pass

    def interrupt(layer: str, done: int, total: int, convergence: float) -> None:
        if layer == "conv3" and done > 64:
            raise Stop

    ckpt = tmp_path / "ckpt"
    net = uavsnn.Network(CONFIG, seed=3)
    with pytest.raises(Stop):
        train(net, windows, windows_per_layer=200, seed=4, checkpoint_dir=ckpt, progress=interrupt)
    state = json.loads((ckpt / STATE_FILE).read_text())
    assert state["done"] == ["conv2"]
    assert sorted(p.name for p in ckpt.iterdir()) == ["after-conv2.npz", STATE_FILE]
    saved = uavsnn.Network.load(ckpt / "after-conv2.npz")
    np.testing.assert_array_equal(saved.weights("conv2"), whole.weights("conv2"))

    fresh = uavsnn.Network(CONFIG, seed=3)
    result = train(fresh, windows, windows_per_layer=200, seed=4, checkpoint_dir=ckpt, resume=True)
    assert result.resumed == ("conv2",) and list(result.layers) == ["conv3"]
    assert fresh == whole
    assert json.loads((ckpt / STATE_FILE).read_text())["done"] == ["conv2", "conv3"]


def test_resume_refuses_a_checkpoint_of_other_layers(
    windows: uavsnn.windows.Windows, tmp_path: Path
) -> None:
    net = uavsnn.Network(CONFIG, seed=3)
    train(net, windows, layers=["conv2"], windows_per_layer=10, checkpoint_dir=tmp_path)
    with pytest.raises(ParameterError, match="not a start of the layers"):
        train(net, windows, layers=["conv3"], checkpoint_dir=tmp_path, resume=True)


def test_overrides() -> None:
    assert parse_override("conv2.threshold=15") == (["conv2", "threshold"], 15)
    assert parse_override("pent.mode=static") == (["pent", "mode"], "static")
    # Spaces around a plain string are not part of it; a JSON string keeps what it quotes.
    assert parse_override(" pent.mode = static ") == (["pent", "mode"], "static")
    assert parse_override('name=" a b "') == (["name"], " a b ")
    config = apply_overrides(
        uavsnn.network.default_config(), ["conv2.threshold=15", "seedless.x=1"]
    )
    assert config["conv2"]["threshold"] == 15 and config["seedless"] == {"x": 1}
    assert uavsnn.network.default_config()["conv2"]["threshold"] == 45.0
    with pytest.raises(ParameterError, match="KEY=VALUE"):
        parse_override("conv2.threshold")
    with pytest.raises(ParameterError, match="not a section"):
        apply_overrides({"width": 240}, ["width.x=1"])
    with pytest.raises(ParameterError):
        uavsnn.Network(apply_overrides(uavsnn.network.default_config(), ["conv2.thresold=1"]))
