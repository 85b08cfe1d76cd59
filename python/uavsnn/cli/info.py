"""``uavsnn info FILE``: what a recording holds; for a model file (``uavsnn train`` writes
them), what the model takes and does."""

from __future__ import annotations

import argparse
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from uavsnn import _jsonout, io
from uavsnn._npy import npz_arrays
from uavsnn.cli import counted
from uavsnn.detector import MAX_LIVE_WINDOWS, live_windows
from uavsnn.errors import ParameterError
from uavsnn.events import Recording
from uavsnn.provenance import ARRAY, DEFAULT_OVERLAP, DEFAULT_WINDOW_US, model_windows

if TYPE_CHECKING:
    from uavsnn.network import Network

__all__ = ["PEAK_BIN_US", "is_model_file", "model_summary", "register", "summary"]

#: Width of the bins over which the peak event rate is measured.
PEAK_BIN_US = 1_000


def summary(recording: Recording) -> dict[str, Any]:
    """Sensor size, event count and the share of ON events, first/last time, duration, and
    mean and peak event rates.

    The mean rate is events per second from the intervals between the events: ``n − 1`` of
    them over ``last t − first t`` (``None`` for fewer than two distinct times; ``n`` over that
    span would count the last event's interval, which lies beyond it, and read above the peak
    for events spread evenly over about 1 ms). The peak rate is the most events in one 1 ms bin
    (bins aligned on the first event), times 1000, and ``None`` when the events span less than
    one bin, whose count would read as a rate lower than the mean.
    """
    t = recording.events["t"]
    n = len(t)
    duration = recording.duration_us
    peak = None
    if n and duration >= PEAK_BIN_US:
        bins = (t - t[0]) // PEAK_BIN_US
        edges = np.flatnonzero(np.diff(bins)) + 1
        counts = np.diff(np.concatenate(([0], edges, [n])))
        peak = int(counts.max()) * (1_000_000 // PEAK_BIN_US)
    return {
        "path": recording.metadata.get("path"),
        "format": recording.metadata.get("format"),
        "sensor_size": list(recording.sensor_size),
        "sensor_size_source": recording.metadata.get("sensor_size_source"),
        "camera": recording.metadata.get("camera"),
        "sensor_size_note": recording.metadata.get("sensor_size_note"),
        "events": n,
        "on_fraction": float(recording.events["p"].mean()) if n else None,
        "first_t_us": int(t[0]) if n else None,
        "last_t_us": int(t[-1]) if n else None,
        "duration_us": duration,
        "mean_rate_ev_per_s": (n - 1) * 1_000_000 / duration if duration > 0 else None,
        "peak_rate_ev_per_s": peak,
        "peak_bin_us": PEAK_BIN_US,
    }


#: The arrays of a model file (:meth:`uavsnn.network.Network.save` writes them, and its
#: identification's ``identify.*``; a recording has ``events`` and ``sensor_size`` instead).
MODEL_ARRAYS = ("format", "config", "conv1", "conv2", "conv3")


def is_model_file(path: str | Path) -> bool:
    """Whether ``path`` is meant as a model file, which :meth:`uavsnn.network.Network.load`
    reads (or says what is wrong with): an ``.npz`` archive holding any of a model's arrays
    (:data:`MODEL_ARRAYS`, ``identify.*``) and no events, a damaged model missing some of them
    too; or an archive cut short (no directory) whose first array is one of them."""
    try:
        if not zipfile.is_zipfile(path):
            first = _first_member(path)
            return first is not None and _is_model_array(first.removesuffix(".npy"))
        with zipfile.ZipFile(path) as archive:
            members = npz_arrays(archive)
    except (OSError, zipfile.BadZipFile):
        return False
    return "events" not in members and any(_is_model_array(name) for name in members)


def _is_model_array(name: str) -> bool:
    return name in MODEL_ARRAYS or name == ARRAY or name.startswith("identify.")


def _first_member(path: str | Path) -> str | None:
    """The name of a zip archive's first member, read from its local header (the start of a
    file cut short keeps it), or ``None`` when the file does not start with one."""
    with open(path, "rb") as file:
        head = file.read(30)
        if len(head) < 30 or head[:4] != b"PK\x03\x04":
            return None
        name = file.read(int.from_bytes(head[26:28], "little"))
    return name.decode("utf-8", errors="replace")


def model_summary(network: Network, path: str | None = None) -> dict[str, Any]:
    """A model's input size, layers, detection rule, identification and load note (and its
    whole ``config``), as ``uavsnn info`` prints them for a model file."""
    config = network.config
    layers = []
    for k, name in enumerate(("conv1", "conv2", "conv3"), start=1):
        conv = config[name]
        pool = config.get(f"pool{k}")
        layers.append(
            {
                "name": name,
                "maps": int(conv["maps"]),
                "kernel": int(conv["kernel"]),
                "threshold": float(conv["threshold"]),
                "pool": None if pool is None else [int(pool["kernel"]), int(pool["stride"])],
            }
        )
    ident = network.identification
    return {
        "path": path,
        "format": "model",
        "input_size": [int(config["width"]), int(config["height"])],
        "layers": layers,
        "min_detections": int(config["detection"]["min_detections"]),
        "pent_mode": config["pent"]["mode"],
        "pent_estimate": config["pent"].get("estimate"),
        "identification": None
        if ident is None
        else {
            "features": len(ident.features),
            "classes": list(ident.classes),
            "threshold": float(ident.threshold),
            "trees": ident.trees is not None,
            "false_alarm_rates": [float(rate) for rate, _ in ident.alarm_thresholds],
            "false_tracks_per_minute": [float(r) for r, _ in ident.track_alarm_thresholds],
        },
        "trained_on": None
        if network.trained_on is None
        else {
            "window_us": network.trained_on.window_us,
            "overlap": network.trained_on.overlap,
            "recordings": len(network.trained_on.recordings),
        },
        "state_bytes": network.state_bytes,
        "live_windows": live_windows(*model_windows(network.trained_on)),
        "load_note": network.load_note,
        "config": config,
    }


def _mib(n: float) -> str:
    return f"{n / 2**20:.3g} MiB" if n < 2**30 else f"{n / 2**30:.3g} GiB"


def _print_model(info: dict[str, Any]) -> None:
    width, height = info["input_size"]
    print(f"file:        {info['path']} (a uavsnn model: `uavsnn train` writes these)")
    print(f"input:       {width}x{height} (`uavsnn detect --downsample` fits a larger sensor)")
    parts = []
    for layer in info["layers"]:
        size = f"{layer['kernel']}x{layer['kernel']}"
        text = f"{layer['name']} {layer['maps']} maps {size} (threshold {layer['threshold']:g})"
        if layer["pool"] is not None:
            text += f", pool {layer['pool'][0]}/{layer['pool'][1]}"
        parts.append(text)
    print(f"layers:      {'; '.join(parts)}")
    n = info["min_detections"]
    rule = f"at least {n} conv3 spike{'s' if n != 1 else ''} in a window"
    if info["pent_mode"] == "pent":
        rule += f"; conv1 thresholds by PENT (input count: {info['pent_estimate']})"
    else:
        rule += f"; conv1 thresholds {info['pent_mode']}"
    print(f"detection:   {rule}")
    trained = info["trained_on"]
    if trained is None:
        print(
            f"trained on:  not recorded (`uavsnn detect` windows of {DEFAULT_WINDOW_US / 1000:g} "
            f"ms, overlap {DEFAULT_OVERLAP:g}, unless told otherwise)"
        )
    else:
        print(
            f"trained on:  windows of {trained['window_us'] / 1000:g} ms, overlap "
            f"{trained['overlap']:g} (`uavsnn detect` takes them), from "
            f"{counted(trained['recordings'], 'recording')}"
        )
    state, live = info["state_bytes"], info["live_windows"]
    print(
        f"memory:      {_mib(state)} a window's state; a detector keeps {live} live at "
        f"these windows ({_mib(live * state)}), {MAX_LIVE_WINDOWS} at most "
        f"({_mib(MAX_LIVE_WINDOWS * state)}: an overlap of 0.984)"
    )
    ident = info["identification"]
    if ident is None:
        print(
            "identify:    no identification model: only the any-spike rule decides "
            "(`uavsnn train` fits one)"
        )
        return
    classes = ", ".join(ident["classes"]) or "UAV or not"
    how = "trees" if ident["trees"] else "logistic regression"
    print(
        f"identify:    identification model ({how} over {ident['features']} features; "
        f"classes: {classes}; threshold {ident['threshold']:.3g})"
    )
    if info["load_note"]:
        print(f"note:        {info['load_note']}")


def _sensor_size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT, got {text!r}") from exc
    return width, height


_SOURCES = {
    "file": "from the file",
    "argument": "as given",
    "camera": "the {camera} camera named in the header, which has no geometry; "
    "give --sensor-size if wrong",
    "fallback": "faery's fallback: the file has no geometry, give --sensor-size",
    "inferred": "the events' bounding box: give --sensor-size",
}


def _format(value: float | None, unit: str) -> str:
    return "n/a" if value is None else f"{value:,.0f} {unit}"


def run(args: argparse.Namespace) -> int:
    """Print the summary of ``args.file``."""
    if args.sensor_size is not None and min(args.sensor_size) <= 0:
        raise ParameterError(f"--sensor-size must be positive, got {args.sensor_size}")
    if is_model_file(args.file):
        return _run_model(args)
    info = summary(io.read(args.file, sensor_size=args.sensor_size))
    if args.json:
        print(_jsonout.document(info))
        return 0
    width, height = info["sensor_size"]
    duration = info["duration_us"]
    print(f"file:        {info['path']} ({info['format']})")
    source = _SOURCES.get(info["sensor_size_source"], info["sensor_size_source"])
    source = source.replace("{camera}", str(info["camera"]))
    print(f"sensor:      {width}x{height} ({source})")
    if info.get("sensor_size_note"):
        print(f"note:        {info['sensor_size_note']}")
    on = "" if info["on_fraction"] is None else f" ({info['on_fraction']:.0%} ON)"
    print(f"events:      {info['events']:,}{on}")
    if info["events"]:
        print(f"time:        {info['first_t_us']} .. {info['last_t_us']} µs")
    print(f"duration:    {duration / 1e6:.6f} s")
    print(f"mean rate:   {_format(info['mean_rate_ev_per_s'], 'ev/s')}")
    peak = info["peak_rate_ev_per_s"]
    bin_text = "busiest 1 ms bin" if peak is not None else "the events span less than 1 ms"
    print(f"peak rate:   {_format(peak, 'ev/s')} ({bin_text})")
    return 0


def _run_model(args: argparse.Namespace) -> int:
    """Print the summary of the model file ``args.file``."""
    from uavsnn.network import Network

    network = Network.load(args.file)
    if args.sensor_size is not None:
        w, h = int(network.config["width"]), int(network.config["height"])
        raise ParameterError(
            f"--sensor-size gives a recording's sensor size: {args.file} is a model file "
            f"(its input is {w}x{h})"
        )
    info = model_summary(network, str(args.file))
    if args.json:
        print(_jsonout.document(info))
    else:
        _print_model(info)
    return 0


def register(subparsers: Any) -> None:
    """Add the ``info`` sub-command."""
    parser = subparsers.add_parser(
        "info",
        help="a recording's sensor size, event count, duration and event rates; a model "
        "file's input, layers and identification",
        description="Read a recording (AEDAT4, RAW, DAT, ES, CSV, NPZ, NPY) and summarise it; "
        "given a model file (the .npz `uavsnn train` writes), summarise the model: its input "
        "size, layers, detection rule and identification.",
    )
    parser.add_argument("file", help="the recording (or a model file)")
    parser.add_argument("--json", action="store_true", help="print JSON for programs")
    parser.add_argument(
        "--sensor-size",
        type=_sensor_size,
        metavar="WxH",
        help="sensor size for files without geometry (e.g. 640x480 for Prophesee Gen3 RAW)",
    )
    parser.set_defaults(handler=run)
