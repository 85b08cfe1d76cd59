"""Layer-wise STDP training of a :class:`~uavsnn.Network` on a dataset (SPEC §3, docs/model.md §6).

Layers are trained in order — conv2, then conv3 (conv1 too, if asked) — each on the same
training windows with the layers below frozen::

    from uavsnn import Network, dataset, training

    train = dataset.load("data/dvs", "train")
    result = training.train(Network(seed=0), train.windows, windows_per_layer=20_000,
                            checkpoint_dir="runs/ckpt", progress=True)
    result.network.save("model.npz")

With ``checkpoint_dir``, the model is written after each layer (atomically) with a small
``state.json`` (the folder is checked before any training, and made with the first of them);
``resume=True`` picks up after the last finished layer, so an interrupted run loses at most the
layer it was in and never leaves a half-written file. The state records a
fingerprint of what the run was given — the network's config (before training), a hash of the
training windows, the seed and the schedule (with the reporting interval, where training stops)
— and a resume with any of them changed is refused: its weights would be written under settings
that did not make them. A run without ``resume`` starts a fresh state (the old one is not read).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn._files import check_output_dir, output_dir, write_atomic
from uavsnn._validate import check_int, fields_once
from uavsnn.errors import DatasetError, ModelFileError, ParameterError
from uavsnn.network import CONV_LAYERS, Network, TrainReport, WindowsLike

__all__ = [
    "MAX_SNAPSHOTS",
    "STATE_FILE",
    "LayerResult",
    "TrainingResult",
    "apply_overrides",
    "parse_override",
    "train",
]

STATE_FILE = "state.json"
"""The checkpoint folder's record of finished layers."""

#: The most weight copies :func:`train` keeps per layer (``snapshots``; each is a copy of the
#: layer's weights, and the pictures use six).
MAX_SNAPSHOTS = 1000

#: Called with (layer, windows done, windows planned, convergence C).
ProgressFn = Callable[[str, int, int, float], None]


@dataclass(frozen=True)
class LayerResult:
    """One trained layer: the engine's report, weight snapshots taken as training went
    (``(windows seen, weights)``, the first before any update, the last at the end) and the
    wall time it took."""

    report: TrainReport
    snapshots: list[tuple[int, np.ndarray]]
    seconds: float

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (no weights)."""
        c = self.report.convergence
        return {
            "windows_seen": self.report.windows_seen,
            "winners": self.report.winners,
            "convergence_first": c[0] if c else None,
            "convergence_last": c[-1] if c else None,
            "a_plus_last": self.report.a_plus[-1] if self.report.a_plus else None,
            "seconds": round(self.seconds, 3),
        }


@dataclass
class TrainingResult:
    """The trained network and what each layer's training did (layers resumed from a
    checkpoint have no entry)."""

    network: Network
    layers: dict[str, LayerResult] = field(default_factory=dict)
    resumed: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary."""
        return {
            "layers": {name: r.to_dict() for name, r in self.layers.items()},
            "resumed": list(self.resumed),
        }


def train(
    network: Network,
    windows: WindowsLike,
    *,
    layers: Sequence[str] = ("conv2", "conv3"),
    windows_per_layer: int | None = None,
    epochs: int = 1,
    seed: int = 0,
    snapshots: int = 6,
    checkpoint_dir: str | os.PathLike[str] | None = None,
    resume: bool = False,
    progress: bool | ProgressFn = False,
) -> TrainingResult:
    """Train ``layers`` of ``network`` in place, one after the other, on ``windows``.

    Each layer sees ``windows_per_layer`` windows (the set is visited in shuffled epochs until
    that many are seen; the paper used about 20,000) or, if that is ``None``, ``epochs`` passes
    over the set (``epochs`` other than 1 beside a count is refused: the count alone would
    decide). Training stops at the first progress report at or past the count (every
    ``max(1, min(64, windows_per_layer // snapshots))`` windows, and after the last epoch), so a
    layer may see fewer than one such interval more. The learning-rate schedule restarts from
    the config's rates for each layer. ``snapshots`` (at most :data:`MAX_SNAPSHOTS`) weight
    copies per layer are kept for the pictures of how features evolve.
    Layer ``i`` shuffles with seed ``seed + i``. With ``checkpoint_dir`` the model is written
    there after each layer; ``resume`` continues after the last layer written, and trains
    every layer where none was (a run stopped in its first layer, or a folder not made yet).

    Raises:
        ParameterError: an unknown layer, layers out of order, a bad count,
            ``windows_per_layer`` with ``epochs`` other than 1, ``resume`` without
            ``checkpoint_dir``, a ``checkpoint_dir`` that is a file, cannot be created
            or written, or holds a folder where a checkpoint file goes.
        DatasetError: no training windows.
        ModelFileError: ``resume`` with a damaged state file or a checkpoint of another network
            shape.
        ParameterError: ``resume`` with a checkpoint made with another config, training data,
            seed or schedule (``snapshots`` sets where each layer stops), or without a complete
            fingerprint of them; the message names what was changed, not the settings that
            follow from it (the passes a count of windows takes over other data).
    """
    names = _check_layers(layers)
    if resume and checkpoint_dir is None:
        raise ParameterError("resume=True continues from checkpoint_dir: give it too")
    n = len(windows.t0)
    if n == 0:
        raise DatasetError("no training windows: the train split is empty")
    if windows_per_layer is not None:
        windows_per_layer = check_int("windows_per_layer", windows_per_layer, 1)
        if epochs != 1:
            raise ParameterError(
                f"windows_per_layer ({windows_per_layer}) and epochs ({epochs}) both say how "
                "long a layer trains, and windows_per_layer would decide alone (that many "
                "windows, in as many passes as it takes): give one"
            )
        epochs = math.ceil(windows_per_layer / n)
    planned = windows_per_layer or n * check_int("epochs", epochs, 1)
    snapshots = check_int("snapshots", snapshots, 0, MAX_SNAPSHOTS)
    report_progress = _progress_fn(progress)

    ckpt = None if checkpoint_dir is None else _checkpoint_folder(Path(checkpoint_dir), names)
    done: list[str] = []
    fingerprint: dict[str, Any] = {}
    state = _new_state()
    if ckpt is not None:
        every = _report_every(planned, snapshots)
        fingerprint = _fingerprint(network, windows, seed, planned, epochs, every)
        if resume:
            state, loaded = _read_checkpoint(
                ckpt, names, fingerprint, per_layer=windows_per_layer is not None
            )
            done = list(state["done"])
            if loaded is not None:
                _copy_weights(loaded, network)
    result = TrainingResult(network=network, resumed=tuple(done))

    for index, layer in enumerate(names):
        if layer in done:
            continue
        result.layers[layer] = _train_layer(
            network, windows, layer, epochs, seed + index, planned, snapshots, report_progress
        )
        if ckpt is not None:
            done.append(layer)
            _write_checkpoint(ckpt, network, state, done, result.layers[layer], layer, fingerprint)
    return result


def _checkpoint_folder(root: Path, names: list[str]) -> Path:
    """Check, before any training, that the checkpoint folder ``root`` can be made (it is made
    with the first checkpoint, so that a run refused before then leaves no empty folder) and
    that its files can be written there."""
    check_output_dir(root, "checkpoint_dir")
    for name in (STATE_FILE, *(f"after-{layer}.npz" for layer in names)):
        if (root / name).is_dir():
            raise ParameterError(
                f"checkpoint_dir {root}: {name}: is a folder, where the checkpoint writes a "
                "file; remove it or use another checkpoint folder"
            )
    return root


def _report_every(planned: int, snapshots: int) -> int:
    """Windows between progress reports: training stops at the first one at or past
    ``planned``."""
    return max(1, min(64, planned // max(snapshots, 1)))


def _fingerprint(
    network: Network,
    windows: WindowsLike,
    seed: int,
    planned: int,
    epochs: int,
    every: int,
) -> dict[str, Any]:
    """What a run was given, for a resume to check: hashes of the config and of the windows,
    the seed and the schedule, with the reporting interval (where a layer stops) (the layers
    may grow: a resume trains those not yet done)."""
    config = hashlib.sha256(json.dumps(network.config, sort_keys=True).encode()).hexdigest()
    data = hashlib.sha256()
    data.update(json.dumps([list(windows.sensor_size), int(windows.length_us)]).encode())
    for name in ("t0", "offsets", "t", "x", "y", "n_preceding"):
        data.update(np.ascontiguousarray(getattr(windows, name)).tobytes())
    return {
        "config_sha256": config,
        "data_sha256": data.hexdigest(),
        "seed": int(seed),
        "windows_per_layer": int(planned),
        "epochs": int(epochs),
        "report_every": int(every),
    }


def _train_layer(
    network: Network,
    windows: WindowsLike,
    layer: str,
    epochs: int,
    seed: int,
    planned: int,
    snapshots: int,
    report_progress: ProgressFn,
) -> LayerResult:
    """Train one layer for ``planned`` windows, taking ``snapshots`` weight copies on the way."""
    every = _report_every(planned, snapshots)
    marks = _snapshot_marks(planned, snapshots)
    taken: list[tuple[int, np.ndarray]] = [(0, network.weights(layer))] if snapshots else []

    def callback(seen: int, _total: int, convergence: float) -> bool:
        if marks and seen >= marks[0]:
            while marks and seen >= marks[0]:
                marks.pop(0)
            taken.append((seen, network.weights(layer)))
        report_progress(layer, min(seen, planned), planned, convergence)
        return seen < planned

    start = time.perf_counter()
    report = network.train_layer(
        layer, windows, epochs=epochs, seed=seed, callback=callback, every=every
    )
    if snapshots and taken[-1][0] != report.windows_seen:
        taken.append((report.windows_seen, network.weights(layer)))
    return LayerResult(report, taken, time.perf_counter() - start)


def _check_layers(layers: Sequence[str]) -> list[str]:
    names = [layers] if isinstance(layers, str) else list(layers)
    if not names:
        raise ParameterError("no layers to train")
    for name in names:
        if name not in CONV_LAYERS:
            raise ParameterError(f"cannot train {name!r}: layers are {', '.join(CONV_LAYERS)}")
    order = [CONV_LAYERS.index(name) for name in names]
    if order != sorted(set(order)):
        raise ParameterError(
            f"layers must be distinct and in the network's order (conv1, conv2, conv3), "
            f"got {', '.join(names)}"
        )
    return names


def _snapshot_marks(planned: int, snapshots: int) -> list[int]:
    if snapshots <= 1:
        return []
    return sorted({max(1, round(planned * k / (snapshots - 1))) for k in range(1, snapshots - 1)})


def _progress_fn(progress: bool | ProgressFn) -> ProgressFn:
    if callable(progress):
        return progress
    if not progress:
        return lambda *_args: None
    from uavsnn.progress import bar as new_bar

    bars: dict[str, Any] = {}

    def step(layer: str, done: int, total: int, convergence: float) -> None:
        bar = bars.get(layer)
        if bar is None:
            bar = bars[layer] = new_bar(total=total, unit=" window", desc=f"train {layer}")
        bar.set_postfix_str(f"C={convergence:.4f}", refresh=False)
        bar.update(done - bar.n)
        if done >= total:
            bar.close()

    return step


def _new_state() -> dict[str, Any]:
    """The state of a run that has written no checkpoint: no layer done."""
    return {"format": "uavsnn-training-state", "version": 1, "done": [], "layers": {}}


def _write_checkpoint(
    root: Path,
    network: Network,
    state: dict[str, Any],
    done: list[str],
    layer_result: LayerResult,
    layer: str,
    fingerprint: dict[str, Any],
) -> None:
    """The model after ``layer`` (atomic, by the engine), then the state that names it:
    ``state`` (a fresh one, or the one a resume read and checked) updated in place."""
    output_dir(root, "checkpoint_dir")  # made with the first checkpoint
    model = root / f"after-{layer}.npz"
    network.save(model)
    state_path = root / STATE_FILE
    state["done"] = list(done)
    state["model"] = model.name
    state["fingerprint"] = fingerprint
    state["layers"][layer] = layer_result.to_dict()
    text = json.dumps(state, indent=2) + "\n"
    write_atomic(state_path, lambda f: f.write(text.encode("utf-8")))


_WHAT = {
    "config_sha256": "the network config (--config, --set)",
    "data_sha256": "the training windows (dataset or split)",
    "seed": "the seed",
    "windows_per_layer": "the windows per layer",
    "epochs": "the epochs",
    "report_every": "the reporting interval (snapshots)",
}


def _changed(stored: dict[str, Any], fingerprint: dict[str, Any], per_layer: bool) -> list[str]:
    """What the user changed, in words, of the settings ``fingerprint`` records that differ
    from ``stored``: a setting that follows from another one that changed is not named (the
    reporting interval follows from the windows per layer; with ``per_layer`` (a count of
    windows per layer given) the passes follow from it and from the training windows, without
    it the windows per layer follow from the passes and the training windows)."""
    diff = {k for k in fingerprint if stored[k] != fingerprint[k]}
    follows: dict[str, set[str]] = {"report_every": {"windows_per_layer"}}
    if per_layer:
        follows["epochs"] = {"data_sha256", "windows_per_layer"}
    else:
        follows["windows_per_layer"] = {"data_sha256", "epochs"}
    named = [k for k in fingerprint if k in diff and not follows.get(k, set()) & diff]
    return [_WHAT.get(k, k) for k in named]


def _read_checkpoint(
    root: Path, names: list[str], fingerprint: dict[str, Any], *, per_layer: bool = True
) -> tuple[dict[str, Any], Network | None]:
    """The state of the checkpoint in ``root``, checked against the layers asked for and the
    run's fingerprint (``per_layer``: the run was given a count of windows per layer, not
    passes), and the model it names (a fresh state and ``None`` without one)."""
    state_path = root / STATE_FILE
    if not state_path.exists():
        return _new_state(), None
    try:
        state = json.loads(state_path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ModelFileError(f"{state_path}: cannot read: {exc.strerror or exc}") from exc
    except ValueError as exc:
        raise ModelFileError(
            f"{state_path}: not a training state file ({exc}); start without resume to train afresh"
        ) from exc
    problem = _state_problem(state)
    if problem:
        raise ModelFileError(
            f"{state_path}: not a training state file: {problem}; start without resume to "
            "train afresh"
        )
    done: list[str] = state["done"]
    if done != names[: len(done)]:
        raise ParameterError(
            f"checkpoint in {root} finished {', '.join(done)}, which is not a start of the "
            f"layers asked for ({', '.join(names)})"
        )
    stored = state.get("fingerprint")
    if not isinstance(stored, dict) or any(k not in stored for k in fingerprint):
        raise ParameterError(
            f"checkpoint in {root} records no complete fingerprint of its settings and data "
            "(made by an older uavsnn, or damaged): it cannot be checked, so it is not resumed; "
            "start without resume to train afresh"
        )
    changed = _changed(stored, fingerprint, per_layer)
    if changed:
        raise ParameterError(
            f"checkpoint in {root} was made with other settings: {', '.join(changed)} "
            "changed since; resume with the same ones, or start in another checkpoint folder"
        )
    if not isinstance(state.get("layers"), dict):
        state["layers"] = {}  # summaries only: rebuilt from the layers trained from now on
    return state, Network.load(root / state["model"])


def _state_problem(state: Any) -> str | None:
    """What makes ``state`` something :func:`_write_checkpoint` did not write, or ``None``."""
    if not isinstance(state, dict):
        return "not a JSON object"
    done = state.get("done")
    if not isinstance(done, list) or not done or not all(isinstance(n, str) for n in done):
        return f"'done' must be a non-empty list of layer names, got {done!r}"
    unknown = [name for name in done if name not in CONV_LAYERS]
    if unknown:
        return f"'done': {unknown[0]!r} is not a layer ({', '.join(CONV_LAYERS)})"
    order = [CONV_LAYERS.index(name) for name in done]
    if order != sorted(set(order)):
        return f"'done' ({', '.join(done)}) is not in training order"
    model = f"after-{done[-1]}.npz"
    if state.get("model") != model:
        return f"'model' must be {model!r} (in the checkpoint folder), got {state.get('model')!r}"
    return None


def _copy_weights(source: Network, target: Network) -> None:
    if source.shapes != target.shapes:
        raise ParameterError(
            f"the checkpoint's network has shapes {source.shapes}, this one {target.shapes}"
        )
    for layer in CONV_LAYERS:
        target.set_weights(layer, source.weights(layer))


def parse_override(text: str) -> tuple[list[str], Any]:
    """``"conv2.threshold=15"`` → ``(["conv2", "threshold"], 15)``; the value is read as JSON
    (numbers, ``true``/``false``, quoted strings, objects), or taken as a plain string.

    Raises:
        ParameterError: not ``KEY=VALUE``, or a JSON object value giving a field twice.
    """
    key, sep, value = text.partition("=")
    path = [part for part in key.strip().split(".") if part]
    if not sep or not path:
        raise ParameterError(
            f"a setting must read KEY=VALUE (e.g. conv2.threshold=15), got {text!r}"
        )
    try:
        parsed: Any = json.loads(value, object_pairs_hook=fields_once(f"the setting {text!r}"))
    except ParameterError:
        raise
    except ValueError:
        parsed = value.strip()
    return path, parsed


def apply_overrides(config: Mapping[str, Any], overrides: Sequence[str]) -> dict[str, Any]:
    """A copy of ``config`` with each ``KEY=VALUE`` of ``overrides`` set (nested keys with
    dots). Unknown keys are left for :class:`~uavsnn.Network` to refuse."""
    out: dict[str, Any] = json.loads(json.dumps(dict(config)))
    for text in overrides:
        path, value = parse_override(text)
        node = out
        for part in path[:-1]:
            child = node.setdefault(part, {})
            if not isinstance(child, dict):
                raise ParameterError(f"{'.'.join(path)}: {part!r} is not a section of the config")
            node = child
        node[path[-1]] = value
    return out
