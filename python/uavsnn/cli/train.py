"""``uavsnn train DATASET -o MODEL.npz``: layer-wise STDP on a dataset's train split."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn import _jsonout, identify
from uavsnn._files import check_output_dir
from uavsnn._validate import fields_once
from uavsnn.cli import output_file
from uavsnn.dataset import load
from uavsnn.distributed import Runner, add_ray_option, runner_for
from uavsnn.errors import DatasetError, ParameterError, ShapeError
from uavsnn.false_alarms import MAX_MINUTES, TRACK_ALARM_RATES, tune_track_alarms
from uavsnn.network import CONV_LAYERS, Network, default_config
from uavsnn.provenance import TrainedOn, recordings_of, split_ids
from uavsnn.track_eval import Confirm
from uavsnn.training import STATE_FILE, apply_overrides, parse_override, train

__all__ = ["register"]


def register(subparsers: Any) -> None:
    """Add ``uavsnn train``."""
    p = subparsers.add_parser(
        "train",
        help="train a detector by STDP, one layer at a time",
        description="Train conv2 then conv3 (and conv1 with --layers conv1,conv2,conv3) by "
        "winner-take-all STDP on the train split of a dataset made by `uavsnn dataset build`; "
        "fit identification (a logistic regression or boosted trees on rotor, shape, activity and "
        "track features, docs/identification.md) on the split's labels, tuned on --tune (build "
        "it with `uavsnn dataset build --seed OTHER --stratify`: a dataset of other "
        "recordings than DATASET's) or on held-out recordings; write the model file. STDP uses "
        "no labels. The network's input is the dataset's sensor size unless --config or --set "
        "gives width and height.",
    )
    p.add_argument("dataset", type=Path, help="dataset folder (with manifest.json)")
    p.add_argument(
        "-o", "--output", type=Path, required=True, help="model file to write (ends in .npz)"
    )
    p.add_argument("--split", default="train", help="split to train on (train)")
    p.add_argument("--layers", default=None, help="layers in order (conv2,conv3)")
    p.add_argument(
        "--windows-per-layer",
        type=int,
        default=None,
        help="at least this many windows each layer sees, in shuffled passes (a layer stops at "
        "its first progress report at or past the count, so it may see a few more; default: "
        "one pass; the paper: 20000)",
    )
    p.add_argument(
        "--epochs",
        type=int,
        default=None,
        help="passes over the training windows (1); not with --windows-per-layer, which "
        "sets the count alone",
    )
    p.add_argument(
        "--config",
        type=Path,
        help="a JSON network config (default: Table 1 at the dataset's sensor size; width and "
        "height the file gives must be the dataset's)",
    )
    p.add_argument(
        "--set",
        dest="settings",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="change one config field, e.g. --set conv2.threshold=15 (repeatable)",
    )
    p.add_argument("--seed", type=int, default=None, help="initial weights and shuffling (0)")
    p.add_argument(
        "--checkpoint-dir",
        type=Path,
        help="write the model after each layer here (made if missing, in a folder that exists)",
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="continue from --checkpoint-dir (with no checkpoint there, train from the start "
        "and say so)",
    )
    p.add_argument(
        "--tune",
        type=Path,
        help="a dataset of other recordings to tune identification on (its train split; one "
        "that shares a recording with DATASET, as a dataset of the same --seed and domain does, "
        "is refused; default: a quarter of the training recordings held out)",
    )
    p.add_argument(
        "--identify-model",
        choices=identify.MODELS,
        default=None,
        help="the UAV score's model: a logistic regression, boosted trees, or whichever "
        "ranks the tuning objects better (auto, the default)",
    )
    p.add_argument(
        "--no-identify", action="store_true", help="skip fitting identification after STDP"
    )
    p.add_argument(
        "--from",
        dest="start_from",
        type=Path,
        metavar="MODEL",
        help="continue STDP from MODEL's network (its config and weights) on DATASET, e.g. a "
        "model trained on rendered scenes taken on to your own footage of the same sensor "
        "size; --set may change its learning and firing settings, not its shape. Its "
        "identification is fitted again (its features change with the weights); the model "
        "written is trained on both MODEL's recordings and DATASET's",
    )
    p.add_argument(
        "--identify-only",
        type=Path,
        metavar="MODEL",
        help="no STDP: take MODEL's network as it is and fit its identification again on "
        "DATASET (with --tune), e.g. on a new tuning set; the result is written to -o",
    )
    p.add_argument(
        "--track-minutes",
        type=float,
        default=0.0,
        help="also stream this many minutes of fresh UAV-free dvs recording through the "
        "detector and set track alarm thresholds on it, for "
        + " and ".join(f"{r:g}" for r in TRACK_ALARM_RATES)
        + " false tracks per minute (uavsnn.false_alarms.tune_track_alarms; 0: none, the "
        "default); a rate of r per minute needs at least 1/r minutes, and the output warns of "
        "a rate set on fewer",
    )
    p.add_argument(
        "--track-seed",
        type=int,
        default=None,
        help="seed of the --track-minutes recordings (default: the --tune set's, else the "
        "training set's; they are never the recordings false-alarm figures are measured on)",
    )
    p.add_argument(
        "--track-confirm",
        default=None,
        metavar="HITS/WINDOWS",
        help="the tracker's confirmation rule for the --track-minutes recordings, which the "
        "points then hold for (`uavsnn detect --false-tracks` follows it; default 3/5, the "
        "detector's)",
    )
    add_ray_option(p, "the --track-minutes recordings")
    p.add_argument("--json", action="store_true", help="print the training summary as JSON")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(handler=_train)


def _base_config(config_file: Path | None) -> dict[str, Any]:
    """The config of ``--config``, or Table 1.

    Raises:
        ParameterError: the file cannot be read, is not JSON, does not hold an object, or one
            of its objects gives a field twice (JSON would keep the last one silently).
    """
    base = default_config()
    if config_file is not None:
        once = fields_once(f"--config {config_file}")
        try:
            base = json.loads(config_file.read_text(encoding="utf-8"), object_pairs_hook=once)
        except OSError as exc:
            raise ParameterError(f"--config {config_file}: cannot read: {exc.strerror}") from exc
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ParameterError(f"--config {config_file}: not a JSON file: {exc}") from exc
        if not isinstance(base, dict):
            raise ParameterError(f"--config {config_file}: must hold a JSON object")
    return base


def _sized(
    config: dict[str, Any], from_file: dict[str, Any], settings: list[str], data: Any
) -> dict[str, Any]:
    """``config`` with the training dataset's sensor size for the width and the height that
    neither ``--config`` (whose fields are ``from_file``) nor ``--set`` gives.

    Raises:
        ParameterError: a width or height given is not the dataset's (with the flags that fix
            it).
    """
    if not len(data):  # an empty split sizes nothing: train() refuses it
        return config
    sensor = tuple(int(v) for v in data.windows.sensor_size)
    given: dict[str, str] = {}
    for key in ("width", "height"):
        if any(parse_override(text)[0] == [key] for text in settings):
            given[key] = "--set"
        elif key in from_file:
            given[key] = "--config"
    out = dict(config)
    for key, side in zip(("width", "height"), sensor, strict=True):
        if key not in given:
            out[key] = side
    size = (out.get("width"), out.get("height"))
    if not all(isinstance(v, int) and not isinstance(v, bool) for v in size):
        return out  # the network refuses it, saying why
    if size != sensor:
        by = ", ".join(f"{key} by {flag}" for key, flag in given.items())
        raise ParameterError(
            f"the network's input is {size[0]}x{size[1]} ({by}), the dataset's sensor "
            f"{sensor[0]}x{sensor[1]}: give --set width={sensor[0]} --set height={sensor[1]}, "
            "or leave width and height out of --config and --set to take the dataset's"
        )
    return out


#: The advice for a tuning set of rendered scenes that shares recordings with the training set.
_OTHER_SEED = (
    "build the tuning set with another --seed (`uavsnn dataset build TUNE --seed OTHER --stratify`)"
)


def check_tuning_set(
    dataset: Path,
    data: Any,
    tune_path: Path,
    tune: Any,
    *,
    split: str = "train",
    flag: str = "--tune",
) -> None:
    """Refuse a ``--tune`` set (``flag``: ``--ablation``'s too; ``tune``, the train split of
    ``tune_path``) that shares a
    recording with the training dataset (``data``, its split ``split``): any of its splits,
    so that identification is tuned neither on the recordings it is fitted on nor on the test
    recordings. Recordings are told apart by their manifest entries
    (:func:`uavsnn.provenance.recording_key`);
    datasets whose manifests list none are told apart by their domain and seed.

    Raises:
        ParameterError: the same dataset, or a shared recording.
    """
    if Path(dataset).resolve() == Path(tune_path).resolve():
        raise ParameterError(
            f"{flag} {tune_path} is the training dataset itself: identification must be tuned "
            f"on other recordings than it is fitted on; {_OTHER_SEED}"
        )
    trained_m, tune_m = data.manifest or {}, tune.manifest or {}
    used = split_ids(trained_m)
    for rid in np.unique(np.asarray(data.recording)).tolist():
        used.setdefault(int(rid), split)
    mine = recordings_of(trained_m, used)
    theirs = recordings_of(tune_m, {int(r): "train" for r in np.unique(np.asarray(tune.recording))})
    if not mine or not theirs:
        same = [trained_m.get(k) for k in ("domain", "seed")] == [
            tune_m.get(k) for k in ("domain", "seed")
        ]
        if same and isinstance(trained_m.get("seed"), int):
            raise ParameterError(
                f"{flag} {tune_path} is a dataset of the domain and seed of {dataset} "
                f"({trained_m['domain']}, seed {trained_m['seed']}): its recordings are the "
                f"same; {_OTHER_SEED}"
            )
        return
    shared = [mine[key] for key in theirs if key in mine]
    if not shared:
        return
    by_split: dict[str, list[str]] = {}
    for name, where in shared:
        by_split.setdefault(where, []).append(name)
    listed = "; ".join(
        f"{', '.join(names[:3])}{f' and {len(names) - 3} more' if len(names) > 3 else ''} of "
        f"its {where} split"
        for where, names in sorted(by_split.items())
    )
    kinds = {key[0] for key in theirs if key in mine}
    advice = []
    if "scene" in kinds:
        advice.append(_OTHER_SEED)
    if "clip" in kinds:
        advice.append(
            "build it from other videos (a dataset of another seed splits the same clips again)"
        )
    raise ParameterError(
        f"{flag} {tune_path}: its train split holds recordings of {dataset} ({listed}): "
        "identification must be tuned on other recordings than it is fitted on, and never on "
        f"the test recordings; {'; '.join(advice)}"
    )


# The defaults of --layers, --epochs, --seed and --identify-model, which are None unless
# given: --identify-only and --no-identify refuse them only when given.
_LAYERS = "conv2,conv3"
_EPOCHS = 1
_SEED = 0


def _identify_model(args: argparse.Namespace) -> str:
    """``--identify-model``, ``auto`` when not given."""
    return "auto" if args.identify_model is None else str(args.identify_model)


def _check_track_flags(args: argparse.Namespace) -> None:
    """Refuse bad --track-minutes / --track-seed before any work."""
    if not 0 <= args.track_minutes <= MAX_MINUTES:
        raise ParameterError(
            f"--track-minutes must be in [0, {MAX_MINUTES:g}], got {args.track_minutes}"
        )
    if args.tune is not None and args.no_identify:
        raise ParameterError("--tune chooses identification's model: not with --no-identify")
    if args.track_minutes and args.no_identify:
        raise ParameterError(
            "--track-minutes sets identification's thresholds: not with --no-identify"
        )
    if args.identify_model is not None and args.no_identify:
        raise ParameterError(
            "--identify-model chooses identification's model: not with --no-identify"
        )
    if args.track_seed is not None and not args.track_minutes:
        raise ParameterError("--track-seed applies to --track-minutes: give it too")
    if args.track_seed is not None and args.track_seed < 0:
        raise ParameterError(f"--track-seed must be non-negative, got {args.track_seed}")
    if args.ray is not None and not args.track_minutes:
        raise ParameterError("--ray runs the --track-minutes recordings: give --track-minutes")
    if args.track_confirm is not None:
        if not args.track_minutes:
            raise ParameterError("--track-confirm applies to --track-minutes: give it too")
        if Confirm.parse(args.track_confirm).fast is not None:
            raise ParameterError(
                f"--track-confirm {args.track_confirm}: HITS/WINDOWS (the detector has no "
                "score-aware rule)"
            )


def _tune_tracks(
    network: Network, args: argparse.Namespace, data: Any, tune: Any, runner: Runner
) -> dict[str, Any] | None:
    """Set the track alarm thresholds of ``network``'s identification on --track-minutes of
    streamed recording, run on ``runner`` (--ray's, resolved before any work); their summary
    (``None`` when not asked or without identification)."""
    if not args.track_minutes or network.identification is None:
        return None
    seed = args.track_seed
    if seed is None:
        seed = int((tune if tune is not None else data).manifest.get("seed", 0))
    rule = Confirm.parse(args.track_confirm) if args.track_confirm else Confirm()
    network.identification, summary = tune_track_alarms(
        network,
        minutes=args.track_minutes,
        seed=seed,
        confirm=rule.pair,
        runner=runner,
    )
    summary["note"] = track_note(
        summary["minutes"], [r for r, _ in summary["track_alarm_thresholds"]]
    )
    return summary


def track_note(minutes: float, rates: list[float]) -> str | None:
    """Why the track alarm thresholds set on ``minutes`` of streamed UAV-free recording for
    ``rates`` false tracks per minute do not measure some of them, in one sentence (``None``
    when they do). The rule: a rate of ``r`` per minute is set from at least ``1/r`` minutes,
    so that one false track of the span may alarm (``r × minutes ≥ 1``); over fewer, the
    threshold only keeps every confirmed track of the span from alarming, which says nothing
    of ``r`` (a steady threshold needs several times ``1/r``)."""
    thin = [r for r in rates if r * minutes < 1 - 1e-9]
    if not thin:
        return None
    one = len(thin) == 1
    return (
        f"{minutes:.2f} minutes of recording are too short for "
        f"{' and '.join(f'{r:g}' for r in thin)} false tracks per minute: a rate of r per "
        "minute needs at least 1/r minutes (here at least "
        f"{' and '.join(f'{1 / r:g}' for r in thin)} minutes) for one false track to alarm; "
        f"at {'that threshold' if one else 'those thresholds'} none of the span's tracks "
        "alarms, which does not measure the rate: give more --track-minutes (several times "
        "1/r for a steady threshold)"
    )


def _model_file(path: Path) -> None:
    """Refuse a model file not named ``.npz``, as ``uavsnn simulate`` refuses its output (a
    folder is refused as such, as :func:`uavsnn.cli.output_file` refuses it)."""
    if path.is_dir():
        raise ParameterError(f"-o {path}: is a folder, not a file")
    if path.suffix.lower() != ".npz":
        raise ParameterError(f"output must end in .npz, got {path}")


def _train(args: argparse.Namespace) -> int:
    _model_file(args.output)
    _check_track_flags(args)
    if args.identify_only is not None:
        return _identify_only(args)
    _check_from_flags(args)
    if args.resume and args.checkpoint_dir is None:
        raise ParameterError("--resume continues from --checkpoint-dir: give it too")
    if args.epochs is not None and args.windows_per_layer is not None:
        raise ParameterError(
            "--epochs and --windows-per-layer both say how long a layer trains, and "
            "--windows-per-layer would decide alone (that many windows, in as many passes as "
            "it takes): give one"
        )
    start = None if args.start_from is None else Network.load(args.start_from)
    base = _base_config(args.config) if start is None else start.config
    config = apply_overrides(base, args.settings)  # bad flags fail before any work
    output_file(args.output, "-o")
    if args.checkpoint_dir is not None:
        # Made by train() with the first checkpoint: a run refused leaves no empty folder. Its
        # parent must exist, as -o's folder must.
        check_output_dir(args.checkpoint_dir, "--checkpoint-dir")
        parent = args.checkpoint_dir.absolute().parent
        if not args.checkpoint_dir.exists() and not parent.is_dir():
            raise ParameterError(
                f"--checkpoint-dir {args.checkpoint_dir}: the folder "
                f"{args.checkpoint_dir.parent} does not exist"
            )
    data = load(args.dataset, args.split)
    if start is None:
        config = _sized(config, base if args.config is not None else {}, args.settings, data)
    else:
        _check_start_size(args.start_from, start, data)
    tune = None if args.tune is None or args.no_identify else load(args.tune, "train")
    if tune is not None:
        check_tuning_set(args.dataset, data, args.tune, tune, split=args.split)
    runner = runner_for(args.ray)  # an unreachable cluster fails now, not after the training
    seed = _SEED if args.seed is None else args.seed
    layers = _LAYERS if args.layers is None else args.layers
    network = Network(config, seed=seed) if start is None else _continued(start, config, args)
    if args.resume and not (args.checkpoint_dir / STATE_FILE).is_file():
        print(
            f"note: nothing to resume in {args.checkpoint_dir}: training from the start",
            file=sys.stderr,
        )
    result = train(
        network,
        data.windows,
        layers=[name.strip() for name in layers.split(",") if name.strip()],
        windows_per_layer=args.windows_per_layer,
        epochs=_EPOCHS if args.epochs is None else args.epochs,
        seed=seed,
        checkpoint_dir=args.checkpoint_dir,
        resume=args.resume,
        progress=not args.quiet,
    )
    summary: dict[str, Any] = {"model": str(args.output), "windows": len(data)}
    if not args.no_identify:
        try:
            network.identification, summary["identify"] = identify.fit_network(
                network, data, tune, model=_identify_model(args)
            )
        except DatasetError as exc:  # the STDP result is kept: only the any-spike rule
            summary["identify"] = {"skipped": str(exc)}
        tracks = _tune_tracks(network, args, data, tune, runner)
        if tracks is not None:
            summary["identify"]["tracks"] = tracks
    network.trained_on = _trained_on(data, tune)
    if start is not None:
        summary["from"] = str(args.start_from)
        if start.trained_on is not None:
            network.trained_on = start.trained_on.joined(network.trained_on)
        if args.no_identify and start.identification is not None:
            summary["note"] = (
                f"{args.start_from}'s identification was fitted on its old weights and is not "
                "kept: only the any-spike rule decides (`uavsnn train --identify-only` fits it "
                "again)"
            )
    network.save(args.output)
    summary |= result.to_dict()
    if args.json:
        print(_jsonout.document(summary))
    else:
        for layer, r in summary["layers"].items():
            print(
                f"{layer}: {r['windows_seen']} windows, {r['winners']} winners, C "
                f"{r['convergence_first']:.4f} -> {r['convergence_last']:.4f} "
                f"({r['seconds']:.1f} s)"
            )
        for layer in summary["resumed"]:
            print(f"{layer}: from the checkpoint")
        _print_identification(
            summary.get("identify", {}), data.manifest, None if tune is None else tune.manifest
        )
        if "note" in summary:
            print(f"note: {summary['note']}")
        print(f"wrote {args.output}" + ("" if start is None else f" (from {args.start_from})"))
    return 0


def _check_from_flags(args: argparse.Namespace) -> None:
    """Refuse the flags that ``--from MODEL`` leaves no room for, before any work."""
    if args.start_from is None:
        return
    if args.config is not None:
        raise ParameterError(
            "--from takes MODEL's config: not with --config (--set changes one of its settings)"
        )
    if args.resume:
        raise ParameterError(
            "--resume continues from --checkpoint-dir, --from from a model file: give one"
        )
    for text in args.settings:
        if parse_override(text)[0][0] in ("width", "height"):
            raise ParameterError(
                f"--set {text}: --from keeps MODEL's input size (its weights are of it); "
                "train a new model for another size"
            )


def _check_start_size(path: Path, start: Network, data: Any) -> None:
    """Refuse a dataset whose sensor is not the input size of the ``--from`` model."""
    if not len(data):  # an empty split: train() refuses it
        return
    sensor = tuple(int(v) for v in data.windows.sensor_size)
    size = (int(start.config["width"]), int(start.config["height"]))
    if size != sensor:
        raise ParameterError(
            f"--from {path}: its network's input is {size[0]}x{size[1]}, the dataset's sensor "
            f"{sensor[0]}x{sensor[1]}: continue it on data of its size (`uavsnn dataset build "
            f"--sensor {size[0]}x{size[1]}`), or train a new model"
        )


def _continued(start: Network, config: dict[str, Any], args: argparse.Namespace) -> Network:
    """The network ``--from`` continues: ``start``'s weights under ``config`` (its config
    with --set), without the identification fitted on them.

    Raises:
        ParameterError: a --set that changes the shape of a layer's weights.
    """
    network = Network(config)
    try:
        for layer in CONV_LAYERS:
            network.set_weights(layer, start.weights(layer))
    except ShapeError as exc:
        raise ParameterError(
            f"--set {' '.join(args.settings)}: changes the shape of {layer}'s weights, which "
            f"--from {args.start_from} continues ({exc}); train a new model for another shape"
        ) from exc
    return network


def _trained_on(data: Any, tune: Any) -> TrainedOn:
    """What the model is trained on: ``data``'s windows and recordings, and those of the
    tuning set ``tune`` (``None``: held out of ``data``)."""
    return TrainedOn.of_sets(data, *([] if tune is None else [tune]))


def _tuning_advice(manifest: dict[str, Any] | None) -> str:
    """How to build a tuning set of other recordings for a dataset with ``manifest``: real
    footage from other videos (``--stratify`` is for rendered scenes), scenes of another seed."""
    if (manifest or {}).get("domain") == "real":
        return (
            "`uavsnn dataset build TUNE --domain real --videos OTHER_VIDEOS`, from videos the "
            "training set does not hold"
        )
    return "`uavsnn dataset build TUNE --seed OTHER --stratify`"


def _print_identification(
    ident: dict[str, Any],
    manifest: dict[str, Any] | None = None,
    tune_manifest: dict[str, Any] | None = None,
) -> None:
    if "skipped" in ident:
        print(f"identification skipped: {ident['skipped']}")
    elif ident:
        print(
            f"identification ({ident['model']}): fitted on {ident['train_windows']} "
            f"windows, tuned on {ident['tune_windows']} ({ident['tune']}): L2 "
            f"{ident['l2']:g}, "
            f"threshold {ident['threshold']:.3f}"
            + "".join(
                f", {100 * rate:g} % false alarms at {t:.3f}"
                for rate, t in ident.get("alarm_thresholds", [])
            )
        )
        if ident.get("alarm_note"):
            print(f"note: {ident['alarm_note']}")
        tracks = ident.get("tracks")
        if tracks:
            print(
                f"track alarm thresholds on {tracks['minutes']:.2f} minutes of UAV-free "
                f"recording (seed {tracks['seed']}, {tracks['confirmed_tracks']} tracks "
                f"confirmed at {tracks['confirm']}): "
                + ", ".join(
                    f"{rate:g} false tracks per minute at {t:.3f}"
                    for rate, t in tracks["track_alarm_thresholds"]
                )
            )
            if tracks.get("note"):
                print(f"note: {tracks['note']}")
        if ident.get("tune") == identify.HELD_OUT_TUNING:
            print(
                "note: identification was tuned on a quarter of the training recordings held "
                f"out; with a tuning set of other recordings ({_tuning_advice(manifest)}, then "
                "--tune TUNE) the fit detected more at 1 % false alarms on unseen recordings "
                '(docs/identification.md, "Tuned on other seeds")'
            )
        left = ", ".join(ident.get("classes_left_out", []))
        if left:
            why = (
                f"fewer than {identify.MIN_CLASS_OBJECTS} of its objects in the training "
                "windows were detected on their labelled box"
            )
            print(
                f"note: the class guess never gives {left}: {why}"
                if ident.get("classes")
                else f"note: no class guess: {why}, in all but one class or all ({left})"
            )
        if ident.get("tune_lacks"):
            print(
                f"note: the tuning windows hold no {', '.join(ident['tune_lacks'])} object, "
                "which the training windows have: the thresholds were set without them (auto "
                "keeps the logistic score); "
                + (
                    "a tuning set built from videos of every class has them"
                    if (manifest or {}).get("domain") == "real"
                    # Stratified already: too few windows to hold every kind.
                    else "a tuning set of more windows (--n-train) has them"
                    if ((tune_manifest or {}).get("parameters") or {}).get("object_scenes")
                    == "stratified"
                    else "`uavsnn dataset build --stratify` makes a tuning set with every kind "
                    "of object"
                )
            )


def _identify_only(args: argparse.Namespace) -> int:
    """``--identify-only MODEL``: MODEL's network, its identification fitted again."""
    if args.no_identify:
        raise ParameterError("--identify-only fits identification; --no-identify skips it")
    stdp = {
        "--config": args.config is not None,
        "--set": bool(args.settings),
        "--layers": args.layers is not None,
        "--windows-per-layer": args.windows_per_layer is not None,
        "--epochs": args.epochs is not None,
        "--seed": args.seed is not None,
        "--checkpoint-dir": args.checkpoint_dir is not None,
        "--resume": args.resume,
        "--from": args.start_from is not None,
    }
    given = [flag for flag, on in stdp.items() if on]
    if given:
        raise ParameterError(
            f"--identify-only trains no layer: {', '.join(given)} "
            f"{'does' if len(given) == 1 else 'do'} not apply (options of STDP)"
        )
    network = Network.load(args.identify_only)
    data = load(args.dataset, args.split)
    tune = None if args.tune is None else load(args.tune, "train")
    if tune is not None:
        check_tuning_set(args.dataset, data, args.tune, tune, split=args.split)
    output_file(args.output, "-o")
    runner = runner_for(args.ray)  # an unreachable cluster fails now, not after the fit
    network.identification, ident = identify.fit_network(
        network, data, tune, model=_identify_model(args)
    )
    tracks = _tune_tracks(network, args, data, tune, runner)
    if tracks is not None:
        ident["tracks"] = tracks
    fitted = _trained_on(data, tune)
    network.trained_on = fitted if network.trained_on is None else network.trained_on.joined(fitted)
    network.save(args.output)
    summary = {"model": str(args.output), "network": str(args.identify_only), "identify": ident}
    if args.json:
        print(_jsonout.document(summary))
    else:
        _print_identification(ident, data.manifest, None if tune is None else tune.manifest)
        print(f"wrote {args.output} (the network of {args.identify_only})")
    return 0
