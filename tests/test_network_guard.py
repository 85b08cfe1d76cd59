"""A network's guards: the memory check counts a window's state with the engine's own count,
:mod:`uavsnn._network_use` holds that check and the training guard, ``identification`` takes
an identification model or ``None`` only, and ``uavsnn train --config`` refuses a field given
twice (JSON kept the last one silently)."""

from __future__ import annotations

import copy
import json
import pickle
from pathlib import Path

import numpy as np
import pytest
from conftest import SMALL_SENSOR, one_line_exit_2, random_events, small_config

import uavsnn.windows
from uavsnn import _network_use
from uavsnn.cli.train import _base_config
from uavsnn.errors import ParameterError
from uavsnn.identifier import Identifier
from uavsnn.network import Network, default_config


def _identifier() -> Identifier:
    names = ("log_width", "log_height")
    return Identifier(names, np.array([0.5, -0.25, 0.1]), np.zeros(2), np.ones(2), 0.4, 1.0)


# -- the state's bytes: the engine's count, the one the memory check uses ---------------------


def test_the_memory_check_uses_the_engines_count(monkeypatch: pytest.MonkeyPatch) -> None:
    # Python counted the state's bytes itself, a twin of the engine's Geometry::state_bytes.
    net = Network(small_config(), seed=1)
    one = net._core.state_bytes()
    assert isinstance(one, int) and one > 0 and net.state_bytes == one
    events = random_events(50, SMALL_SENSOR)
    t, x, y = events["t"], events["x"], events["y"]
    monkeypatch.setattr(uavsnn.windows, "MEMORY_LIMIT", one - 1)
    message = rf"would need {one:,} bytes, more than the {one - 1:,} bytes allowed"
    with pytest.raises(ParameterError, match=message):
        net.run_window(t, x, y, int(t[0]))
    monkeypatch.setattr(uavsnn.windows, "MEMORY_LIMIT", one)
    net.run_window(t, x, y, int(t[0]))  # just fits


def test_the_memory_check_of_live_windows(monkeypatch: pytest.MonkeyPatch) -> None:
    net = Network(small_config(), seed=1)
    one = net.state_bytes
    monkeypatch.setattr(uavsnn.windows, "MEMORY_LIMIT", 3 * one + 9)
    _network_use.check_memory(net, 3, more=9)
    with pytest.raises(
        ParameterError,
        match=rf"^the states of 3 live windows of a {SMALL_SENSOR[0]}x{SMALL_SENSOR[1]} network "
        rf"\(conv maps [0-9/]+\) would need {3 * one + 10:,} bytes \(10 of them beside the "
        rf"states\), more than .* or fewer maps, or a smaller overlap$",
    ):
        net._check_memory(3, more=10, hint=", or a smaller overlap")


# -- identification: an identification model or None ------------------------------------------


class _StandIn:
    def to_arrays(self) -> dict[str, np.ndarray]:
        return {"identify.coef": np.arange(3.0)}


@pytest.mark.parametrize("value", [5, ["a list"], {"a": 1}, _StandIn(), "model.npz"])
def test_an_identification_of_another_type_is_refused(value: object) -> None:
    # Any object was taken, and refused only by save() (or used as one by detect and evaluate).
    net = Network(small_config(), seed=1)
    ident = _identifier()
    net.identification = ident
    name = type(value).__name__
    with pytest.raises(
        ParameterError, match=rf"^identification must be .*Identifier or None, got {name}$"
    ):
        net.identification = value  # type: ignore[assignment]
    assert net.identification is ident  # left as it was


def test_an_identification_model_or_none_is_taken_and_copied(tmp_path: Path) -> None:
    net = Network(small_config(), seed=1)
    ident = _identifier()
    net.identification = ident
    assert net.identification is ident
    assert net.copy().identification is ident and copy.copy(net).identification is ident
    deep = copy.deepcopy(net).identification
    assert deep is not ident and deep == ident
    back = pickle.loads(pickle.dumps(net))
    assert back == net and back.identification == ident
    net.save(tmp_path / "m.npz")
    assert Network.load(tmp_path / "m.npz").identification == ident
    net.identification = None
    assert net.identification is None and net.copy().identification is None


def test_save_still_refuses_an_identification_set_past_the_setter(tmp_path: Path) -> None:
    net = Network(small_config(), seed=1)
    net._identification = 5  # type: ignore[assignment]
    with pytest.raises(
        ParameterError, match=r"identification must be .*Identifier or None, got int"
    ):
        net.save(tmp_path / "m.npz")
    assert list(tmp_path.iterdir()) == []


# -- uavsnn train --config: a field given twice ------------------------------------------------


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ('{"width": 240, "height": 180, "width": 346}', "width"),
        ('{"conv2": {"maps": 4, "threshold": 15, "maps": 8}}', "maps"),
    ],
)
def test_a_config_file_with_a_field_given_twice_is_refused(
    text: str, key: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # json kept the last value: the network was trained with a config the file did not mean.
    path = tmp_path / "config.json"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ParameterError, match=rf"^--config .*config\.json: the field '{key}' is"):
        _base_config(path)
    out = tmp_path / "m.npz"
    line = one_line_exit_2(
        capsys, ["train", str(tmp_path / "none"), "-o", str(out), "--config", str(path)], key
    )
    assert "given twice" in line and not out.exists()


def test_a_config_file_without_repeats_is_read_as_before(tmp_path: Path) -> None:
    path = tmp_path / "config.json"
    config = default_config() | {"conv2": default_config()["conv2"] | {"maps": 4}}
    path.write_text('{"a": {"maps": 1}, "b": {"maps": 2}}', encoding="utf-8")
    assert _base_config(path) == {"a": {"maps": 1}, "b": {"maps": 2}}  # same key, two objects
    path.write_text(json.dumps(config), encoding="utf-8")
    assert _base_config(path) == config
    assert _base_config(None) == default_config()


def test_a_setting_whose_object_gives_a_field_twice_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # --set conv2='{"maps": 4, "maps": 8}' kept the last value silently, as --config did.
    from uavsnn.training import apply_overrides

    setting = 'conv2={"maps": 4, "threshold": 15, "maps": 8}'
    with pytest.raises(ParameterError, match=r"the setting .*conv2=.*: the field 'maps' is given"):
        apply_overrides(default_config(), [setting])
    out = tmp_path / "m.npz"
    line = one_line_exit_2(
        capsys, ["train", str(tmp_path / "none"), "-o", str(out), "--set", setting], "maps"
    )
    assert "given twice" in line and not out.exists()
    # Objects without repeats, and plain values, are read as before.
    config = apply_overrides(default_config(), ['pent={"mode": "static"}', "conv2.threshold=9"])
    assert config["pent"] == {"mode": "static"} and config["conv2"]["threshold"] == 9
