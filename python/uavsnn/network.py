"""The spiking network of the paper (Table 1), exactly as ``docs/model.md`` specifies it.

The work is done by the Rust engine, event by event; this module converts and checks inputs and
wraps results in NumPy structured arrays::

    import uavsnn.network as nw

    net = nw.Network(seed=1)                      # Table 1 on a 240x180 sensor
    trace = net.run_window(t, x, y, t0)           # one window, every layer's spikes
    report = net.train_layer("conv2", windows)    # WTA + STDP, one layer at a time
    result = net.infer(windows)                   # many windows in parallel
    net.save("model.npz"); net = nw.Network.load("model.npz")

Times are absolute microseconds. Inputs ``t, x, y`` are one window's input spikes (the first
event of each active pixel, polarities merged), sorted by ``t``; a repeated pixel is ignored.
"""

from __future__ import annotations

import contextlib
import copy
import functools
import itertools
import json
import os
import secrets
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from uavsnn import _core, _network_use
from uavsnn._files import write_atomic
from uavsnn._network_use import Use as _Use
from uavsnn._validate import (
    U64_MAX,
    check_int,
    check_path,
    check_real,
    check_sensor_size,
)
from uavsnn.errors import EventError, ModelFileError, ParameterError, ShapeError

# The network's results and the dtypes of its spikes live in uavsnn.outputs; their names stay
# here too.
from uavsnn.outputs import (
    CONV_LAYERS,
    DETECTION_DTYPE,
    LAYERS,
    SPIKE_DTYPE,
    WINDOW_DETECTION_DTYPE,
    WINDOW_SPIKE_DTYPE,
    Inference,
    TrainReport,
    WindowsLike,
    WindowTrace,
)

if TYPE_CHECKING:
    import threading

    from uavsnn.identifier import Identifier
    from uavsnn.provenance import TrainedOn

__all__ = [
    "CONV_LAYERS",
    "DETECTION_DTYPE",
    "LAYERS",
    "MAX_THREADS",
    "SPIKE_DTYPE",
    "WINDOW_DETECTION_DTYPE",
    "WINDOW_SPIKE_DTYPE",
    "Inference",
    "Network",
    "TrainReport",
    "WindowTrace",
    "WindowsLike",
    "default_config",
]

MAX_THREADS = 256
"""The most worker threads :meth:`Network.infer` accepts (the engine's own limit): more than any
machine has cores, few enough to start quickly. The engine keeps the worker pools of the two
counts used last, so calls with varying counts do not leave pools behind."""


def default_config() -> dict[str, Any]:
    """The default configuration: the paper's Table 1 on a 240x180 sensor, ``same`` padding,
    PENT on (a new dict each call; see docs/api.md for every field)."""
    config: dict[str, Any] = json.loads(_core.network_default_config())
    return config


def _integers(name: str, values: Any, dtype: type[np.integer[Any]]) -> np.ndarray:
    """A contiguous 1-D array of ``dtype`` from integer ``values``, range-checked."""
    if (
        type(values) is np.ndarray
        and values.dtype == dtype
        and values.ndim == 1
        and values.flags.c_contiguous
    ):
        return values  # the dtype's range is the range checked below: nothing to check
    array = np.asarray(values)
    if array.ndim != 1:
        raise ShapeError(f"{name} must be a 1-D array, got shape {array.shape}")
    if array.size == 0:
        return np.zeros(0, dtype=dtype)
    if array.dtype.kind not in "ui":
        raise EventError(f"{name} must hold integers, got dtype {array.dtype}")
    info = np.iinfo(dtype)
    low, high = int(array.min()), int(array.max())
    if low < 0 or high > info.max:
        raise EventError(f"{name} must lie in [0, {info.max}], got values in [{low}, {high}]")
    return np.ascontiguousarray(array, dtype=dtype)


def _count(name: str, value: Any, *, minimum: int = 0) -> int:
    """A non-negative integer parameter that fits the engine's ``u64`` (``bool`` refused)."""
    return check_int(name, value, minimum, U64_MAX)


def _spikes(columns: tuple[np.ndarray, ...], dtype: np.dtype) -> np.ndarray:
    out = np.empty(len(columns[0]), dtype=dtype)
    for name, column in zip(dtype.names or (), columns, strict=True):
        out[name] = column
    return out


def _window_columns(windows: WindowsLike) -> dict[str, Any]:
    """The columns of a ``Windows``-like object, converted to the engine's dtypes."""
    try:
        sensor_size = windows.sensor_size
        length_us = windows.length_us
        t0, offsets, t = windows.t0, windows.offsets, windows.t
        x, y, n_preceding = windows.x, windows.y, windows.n_preceding
    except AttributeError as exc:
        raise ParameterError(
            f"windows must be a uavsnn.windows.Windows (or have its columns): {exc}"
        ) from exc
    width, height = check_sensor_size(sensor_size)
    offsets_array = np.asarray(offsets)
    if offsets_array.ndim != 1 or (offsets_array.size and offsets_array.dtype.kind not in "ui"):
        raise ShapeError(
            f"offsets must be a 1-D integer array, got {offsets_array.dtype} "
            f"shape {offsets_array.shape}"
        )
    preceding = np.asarray(n_preceding)
    if preceding.ndim != 1 or (preceding.size and preceding.dtype.kind not in "ui"):
        raise ShapeError(
            f"n_preceding must be a 1-D integer array, got {preceding.dtype} "
            f"shape {preceding.shape}"
        )
    return {
        "sensor_size": (width, height),
        "length_us": _count("length_us", length_us, minimum=1),
        "t0": _integers("t0", t0, np.uint64),
        "offsets": np.ascontiguousarray(offsets_array, dtype=np.int64),
        "t": _integers("t", t, np.uint64),
        "x": _integers("x", x, np.uint16),
        "y": _integers("y", y, np.uint16),
        "n_preceding": np.ascontiguousarray(preceding, dtype=np.int64),
    }


class Network:
    """The network: conv1 (Gabor, or trained), conv2 and conv3 (STDP) with their config.

    ``config`` is a (possibly partial) dict like :func:`default_config`'s; missing fields take
    the defaults, unknown fields or bad values raise :class:`~uavsnn.ParameterError` (or
    :class:`~uavsnn.ShapeError` for layers that do not fit their input). conv2 and conv3 start
    from ``N(mean, std)`` clipped to ``[0, 1]`` drawn from ``seed``.
    """

    def __init__(self, config: Mapping[str, Any] | None = None, seed: int = 0) -> None:
        if config is not None and not isinstance(config, Mapping):
            raise ParameterError(f"config must be a dict, got {type(config).__name__}")
        plain = _plain(config or {})
        _check_finite(plain, "config")
        try:
            text = json.dumps(plain, allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"config must be JSON-serialisable: {exc}") from exc
        self._core = _core.NetworkCore(text, _count("seed", seed))
        self._init_guard()
        self._identification: Identifier | None = None
        #: What :meth:`load` noticed about the file (e.g. that it has no identification, or that
        #: its identification does not record its tracker gate).
        self.load_note: str | None = None
        #: What the model was trained on (:class:`uavsnn.provenance.TrainedOn`: its windows
        #: and recordings), or ``None``; ``uavsnn train`` records it, and it is saved and loaded
        #: with the model file.
        self.trained_on: TrainedOn | None = None

    # The guard of a call while train_layer may run (uavsnn._network_use.Use).
    _guard: threading.Lock
    _trainer: int | None
    _users: int

    def _init_guard(self) -> None:
        _network_use.init_guard(self)

    @classmethod
    def _wrap(cls, core: _core.NetworkCore) -> Network:
        net = cls.__new__(cls)
        net._core = core
        net._init_guard()
        net._identification = None
        net.load_note = None
        net.trained_on = None
        return net

    @property
    def identification(self) -> Identifier | None:
        """The identification model (:class:`uavsnn.identify.Identifier`) or ``None``: then
        only the any-spike rule decides. Saved and loaded with the model file.

        Raises:
            ParameterError: set to anything else (on setting).
        """
        return self._identification

    @identification.setter
    def identification(self, value: Identifier | None) -> None:
        if value is not None:
            from uavsnn.identifier import Identifier

            if not isinstance(value, Identifier):
                raise ParameterError(
                    f"identification must be a uavsnn.identify.Identifier or None, got "
                    f"{type(value).__name__}"
                )
        self._identification = value

    @property
    def config(self) -> dict[str, Any]:
        """The full configuration (a copy; JSON-serialisable)."""
        config: dict[str, Any] = json.loads(self._core.config_json())
        return config

    @property
    def shapes(self) -> dict[str, tuple[int, int, int]]:
        """Each layer's output shape ``(maps, rows, cols)``."""
        return dict(self._core.shapes())

    def weights(self, layer: str) -> np.ndarray:
        """A copy of a conv layer's weights, ``(maps, in_channels, k, k)`` float32."""
        with _Use(self, "weights"):
            return self._core.weights(_layer(layer))

    def set_weights(self, layer: str, w: npt.ArrayLike) -> None:
        """Replace a conv layer's weights: float32 of shape ``(maps, in_channels, k, k)``, every
        value finite and in ``[0, 1]``."""
        array = np.asarray(w)
        if array.dtype != np.float32:
            raise ParameterError(f"weights must be float32, got {array.dtype}")
        if array.ndim != 4:
            raise ShapeError(f"weights must be 4-D (maps, in_channels, k, k), got {array.shape}")
        with _Use(self, "set_weights", write=True):
            self._core.set_weights(_layer(layer), np.ascontiguousarray(array))
        self._drop_identification("set_weights")

    def _drop_identification(self, call: str) -> None:
        """Drop an identification fitted on the weights just changed by ``call``, with a
        warning: it scores features of the old network's spikes (docs/identification.md)."""
        if self._identification is None:
            return
        import warnings

        self._identification = None
        warnings.warn(
            f"{call}() changed the network's weights: its identification, fitted on the old "
            "weights, is dropped (only the any-spike rule decides); fit it again on the new "
            "network (`uavsnn train --identify-only`, or uavsnn.identify.fit_network)",
            UserWarning,
            stacklevel=3,
        )

    @functools.cached_property
    def state_bytes(self) -> int:
        """Bytes of one window's state, the engine's count (``Geometry::state_bytes``): what
        each window :meth:`infer` runs at once, and each live window of a
        :class:`~uavsnn.detector.Detector`, holds (``uavsnn info`` prints it for a model). A
        network's config does not change: asked once."""
        return self._core.state_bytes()

    def _check_memory(self, states: int = 1, *, more: int = 0, hint: str = "") -> None:
        """Refuse ``states`` window states (and ``more`` bytes beside them) that would not fit
        in ``uavsnn.windows.MEMORY_LIMIT``: :func:`uavsnn._network_use.check_memory`.

        Raises:
            ParameterError: they would not fit (the bytes and the limit named; ``hint`` added).
        """
        _network_use.check_memory(self, states, more=more, hint=hint)

    def conv1_thresholds(self, n_in: int) -> np.ndarray:
        """conv1's per-map thresholds (float32) for a window whose PENT estimate is ``n_in``."""
        with _Use(self, "conv1_thresholds"):
            thresholds = self._core.conv1_thresholds(_count("n_in", n_in))
        return np.asarray(thresholds, dtype=np.float32)

    def _inputs(self, t: Any, x: Any, y: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t_, x_, y_ = (
            _integers("t", t, np.uint64),
            _integers("x", x, np.uint16),
            _integers("y", y, np.uint16),
        )
        if not len(t_) == len(x_) == len(y_):
            raise ShapeError(
                f"t, x and y must have equal lengths, got {len(t_)}, {len(x_)}, {len(y_)}"
            )
        return t_, x_, y_

    def run_window(
        self, t: npt.ArrayLike, x: npt.ArrayLike, y: npt.ArrayLike, t0: int, n_in: int | None = None
    ) -> WindowTrace:
        """Run one window's input spikes through the network in inference mode.

        ``t`` (sorted, ``>= t0``), ``x``, ``y`` are integer arrays of equal length. ``n_in``
        overrides PENT's ``N_in`` (default: the number of spikes). Out-of-sensor or unsorted
        spikes raise :class:`~uavsnn.EventError`; a network whose window state would not fit in
        ``uavsnn.windows.MEMORY_LIMIT`` raises :class:`~uavsnn.ParameterError` (it, and the
        bytes it needs, named) instead of aborting the process.
        """
        t_, x_, y_ = self._inputs(t, x, y)
        n = None if n_in is None else _count("n_in", n_in)
        self._check_memory()
        with _Use(self, "run_window"):
            packed, counts, thresholds, found = self._core.run_window(
                t_, x_, y_, _count("t0", t0), n
            )
        # One buffer of every layer's spike records; each layer is a slice of one view.
        spikes = packed.view(SPIKE_DTYPE)
        ends = list(itertools.accumulate(counts))
        conv1, pool1, conv2, pool2, conv3 = (
            spikes[a:b] for a, b in zip([0, *ends[:-1]], ends, strict=True)
        )
        return WindowTrace(
            conv1=conv1,
            pool1=pool1,
            conv2=conv2,
            pool2=pool2,
            conv3=conv3,
            thresholds=thresholds,
            detections=found.view(DETECTION_DTYPE),
        )

    def stdp_step(
        self,
        layer: str,
        t: npt.ArrayLike,
        x: npt.ArrayLike,
        y: npt.ArrayLike,
        t0: int,
        n_in: int | None = None,
        *,
        a_plus: float | None = None,
        a_minus: float | None = None,
    ) -> np.ndarray:
        """One STDP training step of ``layer`` on one window (docs/model.md §6).

        Layers below run in inference mode; ``layer`` runs without lateral inhibition and its
        crossings compete (winner-take-all); the winners' kernels are updated in place with
        ``a_plus``/``a_minus`` (default: the config's initial rates; an override must keep the
        config's signs, ``a_plus > 0`` and ``a_minus <= 0``, as a finite float32). Returns the
        winners in acceptance order (:data:`SPIKE_DTYPE`). A window state that would not fit in
        ``uavsnn.windows.MEMORY_LIMIT`` is refused (:class:`~uavsnn.ParameterError`), as in
        :meth:`run_window`.
        """
        layer = _layer(layer)
        plus = None if a_plus is None else _rate("a_plus", a_plus)
        minus = None if a_minus is None else _rate("a_minus", a_minus)
        t_, x_, y_ = self._inputs(t, x, y)
        n = None if n_in is None else _count("n_in", n_in)
        self._check_memory()
        with _Use(self, "stdp_step", write=True):
            columns = self._core.stdp_step(layer, t_, x_, y_, _count("t0", t0), n, plus, minus)
        self._drop_identification("stdp_step")
        return _spikes(columns, SPIKE_DTYPE)

    def infer(
        self, windows: WindowsLike, *, threads: int | None = None, spikes: bool = False
    ) -> Inference:
        """Run every window in inference mode, in parallel (``threads`` workers; default: all
        cores, or ``RAYON_NUM_THREADS``; at most :data:`MAX_THREADS`), without holding the GIL.
        PENT's ``N_in`` is each window's spike count or its ``n_preceding``, as
        ``config["pent"]["estimate"]`` says. With ``spikes=True`` every layer's spikes are
        returned too. The results do not depend on the number of workers; fewer run than asked
        where their network states would not fit in the engine's 4 GiB cap together; a network
        whose one window state would not fit in ``uavsnn.windows.MEMORY_LIMIT`` is refused
        (:class:`~uavsnn.ParameterError`), as in :meth:`run_window`.

        A ``threads`` count other than the default starts a pool of that many threads, kept
        for later calls (starting threads costs more than a small batch): at most two such
        pools are kept, the two counts used last, and their threads live as long as the
        process or until a third count replaces one."""
        columns = _window_columns(windows)
        workers = None if threads is None else check_int("threads", threads, 1)
        if workers is not None and workers > MAX_THREADS:
            raise ParameterError(f"threads must be at most {MAX_THREADS}, got {workers}")
        if len(columns["t0"]):
            self._check_memory()  # one worker's (the engine runs fewer where more do not fit)
        with _Use(self, "infer"):
            counts, thresholds, detections, layer_spikes = self._core.infer(
                **columns, threads=workers, record=bool(spikes)
            )
        found = _spikes(tuple(detections), WINDOW_DETECTION_DTYPE)
        n = len(counts)
        first = np.zeros(n, dtype=np.uint64)
        if len(found):
            windows_with, index = np.unique(found["window"], return_index=True)
            first[windows_with] = found["t"][index]
        min_detections = int(self.config["detection"]["min_detections"])
        return Inference(
            detected=counts[:, 4] >= min_detections,
            counts=counts,
            first_detection_t=first,
            detections=found,
            thresholds=thresholds,
            spikes=None
            if layer_spikes is None
            else {
                name: _spikes(tuple(cols), WINDOW_SPIKE_DTYPE)
                for name, cols in zip(LAYERS, layer_spikes, strict=True)
            },
        )

    def train_layer(
        self,
        layer: str,
        windows: WindowsLike,
        *,
        epochs: int = 1,
        seed: int = 0,
        callback: Callable[[int, int, float], bool | None] | None = None,
        shuffle: bool = True,
        every: int = 64,
    ) -> TrainReport:
        """Train ``layer`` on ``windows`` (winner-take-all + STDP, docs/model.md §6), with the
        learning-rate schedule starting from the config's rates.

        Each epoch visits every window once, shuffled with ``seed`` unless ``shuffle=False``.
        ``callback(done, total, convergence)`` is called every ``every`` windows and at the end;
        returning ``False`` stops training early. The GIL is released between calls. Ctrl-C
        (checked as often, callback or not) stops it too, with a ``KeyboardInterrupt``: the
        layer's weights then hold the windows taken so far. A window state that would not fit
        in ``uavsnn.windows.MEMORY_LIMIT`` is refused (:class:`~uavsnn.ParameterError`), as in
        :meth:`run_window`.
        """
        layer = _layer(layer)
        columns = _window_columns(windows)
        if len(columns["t0"]):
            self._check_memory()
        epochs, seed = _count("epochs", epochs, minimum=1), _count("seed", seed)
        every = _count("every", every, minimum=1)
        # The network is this thread's until training ends, between its chunks too (_Use).
        with _network_use.training(self):
            try:
                convergence, a_plus, seen, winners = self._core.train_layer(
                    layer,
                    **columns,
                    epochs=epochs,
                    seed=seed,
                    shuffle=bool(shuffle),
                    callback=callback,
                    every=every,
                )
            finally:  # stopped part way too: the weights hold the windows taken
                if len(columns["t0"]):
                    self._drop_identification("train_layer")
        return TrainReport(
            layer=layer,
            convergence=list(convergence),
            a_plus=list(a_plus),
            windows_seen=int(seen),
            winners=int(winners),
        )

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write a model file (``.npz``: weights + versioned config, no pickle), atomically;
        with :attr:`identification`, its arrays too (``identify.*``, uncompressed entries the
        engine's reader skips). The whole file, identification included, is written to a
        temporary file beside ``path`` and renamed over it: readers, and a save that fails or
        is interrupted, see the old file or the whole new one, never the new network without
        its identification.

        The temporary file's name is longer than the file's: with an identification, the
        file's name may be at most 237 bytes long (the usual limit of 255, less the 18 that
        ``.NAME.<12 hex digits>.tmp`` adds); without, about 240 (the engine's
        ``.NAME.tmp-<process id>-<count>``).

        Raises:
            ParameterError: ``path`` is not a ``str`` or ``os.PathLike[str]`` (bytes refused).
            ModelFileError: the file cannot be written (the old one is left as it was), or
                ``path`` names no file (empty, or ending in a folder separator).
        """
        from uavsnn.provenance import ARRAY, TrainedOn

        file = check_path(path)
        if self.trained_on is not None and not isinstance(self.trained_on, TrainedOn):
            raise ParameterError(
                f"trained_on must be a uavsnn.provenance.TrainedOn or None, got "
                f"{type(self.trained_on).__name__}"
            )
        if self.identification is None and self.trained_on is None:
            with _Use(self, "save"):
                self._core.save(file)
            return
        arrays: dict[str, np.ndarray] = {}
        if self.identification is not None:
            # The setter refuses anything else; checked again for one set past it.
            to_arrays = getattr(self.identification, "to_arrays", None)
            if not callable(to_arrays):
                raise ParameterError(
                    f"identification must be a uavsnn.identify.Identifier or None, got "
                    f"{type(self.identification).__name__}"
                )
            arrays |= to_arrays()
        if self.trained_on is not None:
            arrays[ARRAY] = self.trained_on.to_array()
        target = Path(file)
        # Path("x/") is "x": a file named so is not the folder asked for, as the engine says.
        if target.name in ("", ".", "..") or file.endswith((os.sep, os.altsep or os.sep)):
            raise ModelFileError(f"model file: cannot write {file}: the path has no file name")
        # The engine's part first, beside the file, under a short name (the engine adds its own
        # temporary name to it); then the whole file from it, atomically.
        tmp = target.with_name(f".uavsnn-{secrets.token_hex(6)}.tmp")
        try:
            try:
                with _Use(self, "save"):
                    self._core.save(str(tmp))
            except ModelFileError as exc:
                # The engine names the file it wrote, the temporary one: name the user's.
                raise ModelFileError(str(exc).replace(str(tmp), file)) from exc
            _add_arrays(file, arrays, source=tmp)
        except OSError as exc:
            raise ModelFileError(f"cannot write {file}: {exc.strerror or exc}") from exc
        finally:
            # Never in place of the error above (the folder may be a file, the name too long).
            with contextlib.suppress(OSError):
                tmp.unlink(missing_ok=True)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Network:
        """Read a model file written by :meth:`save`; a corrupt, foreign or other-version file
        raises :class:`~uavsnn.ModelFileError`. A file without identification loads with
        ``identification = None`` and a :attr:`load_note` saying only the any-spike rule
        decides. An identification that does not record the tracker gate it was fitted with
        (:attr:`uavsnn.identifier.Identifier.gate_px`) runs at its sensor's gate
        (:func:`uavsnn.tracks.tracker_for`); where that gate is wider than the 24 px
        (:data:`uavsnn.tracks.DEFAULT_GATE_PX`) every size was fitted at before the gate scaled
        with the sensor (sensors wider than 240 px), a :attr:`load_note` says so."""
        from uavsnn.identifier import Identifier
        from uavsnn.provenance import TrainedOn
        from uavsnn.tracks import DEFAULT_GATE_PX, GATE_SHARE

        path = check_path(path)
        net = cls._wrap(_core.NetworkCore.load(path))
        try:
            with np.load(path, allow_pickle=False) as arrays:
                net.identification = Identifier.from_arrays(arrays)
                net.trained_on = TrainedOn.from_arrays(arrays)
        except (OSError, ValueError) as exc:
            if isinstance(exc, ModelFileError):
                raise ModelFileError(f"{path}: {exc}") from exc
            raise ModelFileError(f"{path}: cannot read its arrays: {exc}") from exc
        width = int(net.config["width"])
        if net.identification is None:
            net.load_note = (
                f"{path} has no identification model: only the any-spike rule "
                "decides (`uavsnn train` fits one)"
            )
        elif net.identification.gate_px is None and GATE_SHARE * width > DEFAULT_GATE_PX:
            net.load_note = (
                f"{path} does not record the tracker gate its identification was "
                f"fitted with: it runs at {GATE_SHARE:g} of the sensor's width "
                f"({GATE_SHARE * width:g} px), but models fitted before the gate scaled with "
                f"the sensor were fitted at {DEFAULT_GATE_PX:g} px: fit it again with "
                "`uavsnn train --identify-only`"
            )
        return net

    def copy(self) -> Network:
        """An independent copy (same config and weights, and identification)."""
        with _Use(self, "copy"):
            core = self._core.copy()
        net = self._wrap(core)
        net._identification = self.identification
        net.trained_on = self.trained_on
        return net

    def __copy__(self) -> Network:
        """``copy.copy(net)``: an independent copy, as :meth:`copy` (the weights live in the
        engine: a copy sharing them would change the original through the copy)."""
        net = self.copy()
        net.load_note = self.load_note
        return net

    def __deepcopy__(self, memo: dict[int, Any]) -> Network:
        """``copy.deepcopy(net)``: an independent copy, its identification copied too."""
        net = self.copy()
        memo[id(self)] = net
        net._identification = copy.deepcopy(self.identification, memo)
        net.load_note = self.load_note
        return net

    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        """Pickled (for a process pool, Ray) as its config, weights, identification and load
        note, whatever else is imported."""
        weights = {layer: self.weights(layer) for layer in CONV_LAYERS}
        state = (self.config, weights, self.identification, self.load_note, self.trained_on)
        return Network._restore, state

    @staticmethod
    def _restore(
        config: dict[str, Any],
        weights: dict[str, np.ndarray],
        identification: Any,
        load_note: str | None,
        trained_on: TrainedOn | None = None,  # absent from a network pickled before
    ) -> Network:
        net = Network(config)
        for layer, w in weights.items():
            net.set_weights(layer, w)
        net._identification = identification
        net.load_note = load_note
        net.trained_on = trained_on
        return net

    def __eq__(self, other: object) -> bool:
        """Same config and bit-identical weights."""
        if not isinstance(other, Network):
            return NotImplemented
        return self._core.same_as(other._core)

    __hash__ = None  # type: ignore[assignment]  # mutable

    def __repr__(self) -> str:
        """A short description: sensor and maps per conv layer."""
        c = self.config
        maps = "/".join(str(c[name]["maps"]) for name in CONV_LAYERS)
        return f"Network({c['width']}x{c['height']}, maps {maps}, {c['pent']['mode']})"


def _add_arrays(path: str, arrays: Mapping[str, np.ndarray], *, source: Path | None = None) -> None:
    """Write the model file ``path`` atomically (:func:`uavsnn._files.write_atomic`): the
    entries of ``source`` (:meth:`Network.save`'s engine part; default: ``path`` itself) with
    ``arrays`` added (``.npy`` entries, stored)."""
    import io
    import zipfile

    with zipfile.ZipFile(source if source is not None else path) as old:
        entries = [(info.filename, old.read(info)) for info in old.infolist()]
    names = {f"{name}.npy" for name in arrays}

    def entry(name: str) -> zipfile.ZipInfo:
        # A fixed time, as the engine's part has: the same network gives the same bytes.
        info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
        info.external_attr = 0o644 << 16
        return info

    def write(out: Any) -> None:
        with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as z:
            for name, data in entries:
                if name not in names:
                    z.writestr(entry(name), data)
            for name, value in arrays.items():
                buf = io.BytesIO()
                np.save(buf, np.asarray(value), allow_pickle=False)
                z.writestr(entry(f"{name}.npy"), buf.getvalue())

    write_atomic(path, write)


def _check_finite(value: Any, path: str) -> None:
    """Name the first NaN or infinite number of a config (JSON cannot carry them)."""
    if isinstance(value, Mapping):
        for key, item in value.items():
            _check_finite(item, f"{path}.{key}")
    elif isinstance(value, float) and not np.isfinite(value):
        raise ParameterError(f"{path} must be a finite number, got {value}")


_F32_MAX = float(np.finfo(np.float32).max)


def _rate(name: str, value: Any) -> float:
    """A learning-rate override with the sign the config requires of it (``a_plus > 0``,
    ``a_minus <= 0``), finite and nonzero (``a_plus``) as the engine's float32."""
    if name == "a_plus":
        rate = check_real(name, value, low=0.0, low_open=True, high=_F32_MAX)
        if np.float32(rate) == 0:
            raise ParameterError(f"a_plus must be > 0 as a float32, got {rate!r}")
        return rate
    return check_real(name, value, low=-_F32_MAX, high=0.0)


def _layer(layer: Any) -> str:
    """A layer name as a ``str`` (the engine checks which names are conv layers)."""
    if not isinstance(layer, str):
        raise ParameterError(f"layer must be one of {', '.join(CONV_LAYERS)}, got {layer!r}")
    return layer


def _plain(value: Any) -> Any:
    """A config with its NumPy scalars (``np.int64(4)``, ``np.bool_``) as Python numbers, so
    that they serialise as the numbers they are."""
    if isinstance(value, Mapping):
        return {key: _plain(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(item) for item in value]
    if isinstance(value, np.generic):
        return value.item()
    return value
