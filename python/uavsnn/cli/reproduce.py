"""``uavsnn reproduce``: the paper's experiments at full size, written up in RESULTS.md.

- Table 2: networks trained on dvs, on sim, and on both ("combined"), each tested on the dvs
  test set (and the combined one with Table 1 unchanged, beside the project's recipe);
- Table 3: the combined network's accuracy against added noise, in dB of SNR;
- PENT against static thresholds at each noise level;
- the real footage of a Svanström-style folder: drone windows against bird, airplane and
  helicopter windows, split by clip.

Each figure for both rules (SPEC §3): the paper's any-spike rule, and detection +
identification (:mod:`uavsnn.identify`, fitted on each network's own training windows, a
combined network's on the dvs ones among them, and tuned on recordings of another seed of the
same domain: SPEC §5's "tuned on other seeds only"; the real network, whose clips have no second
draw, on a quarter of its training clips held out; never on a test set).

Every figure comes from this one command and its seed.
"""

from __future__ import annotations

import argparse
import shlex
import sys
import time
from pathlib import Path
from typing import Any, NamedTuple

from uavsnn import __version__, _jsonout, identify, pictures, report, report_pictures
from uavsnn._validate import check_int
from uavsnn.cli import check_output_dir, output_dir
from uavsnn.cli._results_text import (
    TABLE2_HEAD,
    ablation_table,
    identification_leads,
    identification_text,
    per_network,
    real_sizes_table,
    table2_row,
    track_points_text,
    tracks_text,
)
from uavsnn.clips import clip_table, evaluate_clips
from uavsnn.dataset import LabelledWindows, build, load, parse_sensor
from uavsnn.dataset.build import MAX_SPLIT_WINDOWS, check_footage
from uavsnn.distributed import (
    SERIAL,
    Runner,
    add_ray_option,
    evaluate_task,
    runner_for,
    train_task,
)
from uavsnn.errors import DatasetError, ParameterError
from uavsnn.evaluation import Evaluation
from uavsnn.experiments import (
    NOISE_FRACTIONS,
    PAPER_TABLE2,
    RECIPE_SETTINGS,
    both_rules,
    environment,
    fit_identification,
    have_dataset,
    mix_windows,
    noise_sweep,
    recipe_config,
    static_twin,
)
from uavsnn.false_alarms import (
    MAX_MINUTES,
    false_alarm_figures,
    false_alarm_table,
    tune_track_alarms,
)
from uavsnn.network import Network, default_config
from uavsnn.provenance import TrainedOn
from uavsnn.track_eval import evaluate_tracks

__all__ = ["register"]

_DEFAULT_VIDEOS = Path("../shared/data/svanstrom-dev")
#: The networks whose false alarms are streamed (and track alarm thresholds set): the paper's
#: system (combined) and the dvs network.
STREAMED = ("combined", "dvs")
#: The most STDP windows per layer reproduce takes (500 times its default): the engine trains a
#: layer on at most 5·10^7 windows (its MAX_WINDOWS, counted over whole passes of the set), so
#: a larger count would be refused only when the first network starts, hours into the run.
MAX_WINDOWS_PER_LAYER = 10**7


def register(subparsers: Any) -> None:
    """Add ``uavsnn reproduce``."""
    p = subparsers.add_parser(
        "reproduce",
        help="the paper's experiments at full size, written to RESULTS.md",
        description="Build dvs, sim (and real) datasets, train the dvs, sim and combined "
        "networks, test them on dvs (Table 2), sweep added noise (Table 3) with PENT and "
        "static thresholds, score the real footage, and write RESULTS.md with pictures.",
    )
    p.add_argument("--out", type=Path, default=Path("runs/reproduce"), help="(runs/reproduce)")
    p.add_argument(
        "--seed",
        type=int,
        default=0,
        help="seed of the datasets, the networks' weights and training, the added noise and the "
        "UAV-free minutes; the tuning sets and --track-minutes take --tune-seed (0)",
    )
    p.add_argument("--n-train", type=int, default=4000, help="train windows per domain (4000)")
    p.add_argument(
        "--n-test", type=int, default=2000, help="test windows of dvs and of real footage (2000)"
    )
    p.add_argument(
        "--tune-seed",
        type=int,
        default=None,
        help="seed of the recordings identification is tuned on: dvs and sim sets built as the "
        "training sets are, never tested on (default: --seed + 1)",
    )
    p.add_argument(
        "--n-tune", type=int, default=None, help="tuning windows per domain (default: --n-train)"
    )
    p.add_argument(
        "--free-minutes",
        type=float,
        default=10.0,
        help="minutes of fresh UAV-free recording streamed through the combined and dvs "
        "networks for their false alarms per minute (uavsnn.false_alarms; 0: none; default 10)",
    )
    p.add_argument(
        "--track-minutes",
        type=float,
        default=10.0,
        help="minutes of fresh UAV-free recording of the tuning seed streamed through the "
        "combined and dvs networks to set their track alarm thresholds on "
        "(uavsnn.false_alarms.tune_track_alarms; never the --free-minutes recordings; 0: none; "
        "default 10)",
    )
    p.add_argument(
        "--windows-per-layer", type=int, default=20000, help="STDP windows per layer (20000)"
    )
    p.add_argument(
        "--videos",
        type=Path,
        default=None,
        help=f"labelled real videos (default {_DEFAULT_VIDEOS} when it exists; not beside "
        "--no-real)",
    )
    p.add_argument(
        "--no-real",
        action="store_true",
        help="skip the real-footage experiment (refused beside --videos or --real-sensors)",
    )
    p.add_argument(
        "--real-sensors",
        default=None,
        metavar="WxH[,WxH...]",
        help="sensor sizes of the real-footage experiment, one dataset and network each "
        "(default: --sensor, and 640x480 beside it; SPEC §5 asks for real footage at "
        "240x180 and at a larger sensor; not beside --no-real)",
    )
    p.add_argument(
        "--sensor",
        default="240x180",
        metavar="WxH",
        help="sensor size of every dataset and network (240x180, the paper's; also 346x260, "
        "640x480, 1280x720: the scenes keep their field of view, so objects cover more pixels)",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    add_ray_option(p, "the dataset builds, trainings and evaluations as tasks (the same figures)")
    p.set_defaults(handler=_reproduce)


def _dataset(root: Path, domain: str, seed: int, progress: bool, **kwargs: Any) -> Path:
    """Build ``domain``'s dataset in ``root``, unless the one there was built with the same seed,
    sensor and window counts (and stratified, when ``stratify`` is asked for)."""
    same = {"sensor_size": kwargs["sensor"]} if "sensor" in kwargs else {}
    same |= {k: kwargs[k] for k in ("n_train", "n_test") if k in kwargs}
    if kwargs.get("stratify"):
        same["object_scenes"] = "stratified"
    if not have_dataset(root, seed, **same):
        build(root, domain, seed=seed, overwrite=True, progress=progress, **kwargs)
    return root


def _train_all(
    runner: Runner,
    runs: dict[str, tuple[dict[str, Any], LabelledWindows, str]],
    seed: int,
    train_kwargs: dict[str, Any],
) -> dict[str, Any]:
    """Start every run's training (all at once on a cluster); each window set is shared."""
    shared: dict[int, Any] = {}
    jobs = {}
    for name, (config, data, _) in runs.items():
        if id(data) not in shared:
            shared[id(data)] = runner.put(data.windows)
        jobs[name] = runner.submit(train_task, config, seed, shared[id(data)], train_kwargs)
    return jobs


#: The raw material of some figures (every streamed track's and window's peak score), left
#: out of results.json: thousands of numbers that the figures beside them summarise, and that
#: ``benches/python/false_alarms.py --json`` and ``uavsnn evaluate --clips --json`` give.
RAW_KEYS = ("track_peaks", "window_peaks")


def _lean(obj: Any) -> Any:
    """``obj`` without the keys of :data:`RAW_KEYS`, at any depth."""
    if isinstance(obj, dict):
        return {k: _lean(v) for k, v in obj.items() if k not in RAW_KEYS}
    if isinstance(obj, list):
        return [_lean(v) for v in obj]
    return obj


def _ablation(
    network: Network,
    train: LabelledWindows,
    tune: LabelledWindows,
    test: LabelledWindows,
    result: Evaluation,
) -> dict[str, Any]:
    """:func:`uavsnn.identify.ablation` of ``network`` fitted on ``train``, tuned on ``tune``
    and measured on ``test`` (``result``: its evaluation there, with the inference), tracks
    included."""

    assert result.inference is not None
    tune_inference = network.infer(tune.windows)
    return identify.ablation(
        identify.window_features(network, train),
        identify.window_features(network, tune, tune_inference),
        identify.window_features(network, test, result.inference),
        tune_detected=tune_inference.detected,
        tune_label=tune.label,
        test_detected=result.inference.detected,
        test_label=test.label,
        test_data=test,
    )


#: The larger sensor the real footage is also measured at by default (Prophesee Gen3/Gen4
#: class, SPEC §4).
REAL_LARGER_SENSOR = (640, 480)


def _real_sensors(value: str | None, sensor: tuple[int, int]) -> list[tuple[int, int]]:
    """The sensor sizes of the real-footage experiment: ``value``'s (comma-separated WxH,
    each once, in its order), or ``sensor`` and :data:`REAL_LARGER_SENSOR`.

    Raises:
        ParameterError: a size :func:`uavsnn.dataset.parse_sensor` refuses, or an empty list.
    """
    if value is None:
        return list(dict.fromkeys([sensor, REAL_LARGER_SENSOR]))
    sizes = [parse_sensor(part.strip()) for part in value.split(",") if part.strip()]
    if not sizes:
        raise ParameterError(f"--real-sensors needs at least one WxH, got {value!r}")
    return list(dict.fromkeys(sizes))


def _sensor_name(sensor: tuple[int, int]) -> str:
    return f"{sensor[0]}x{sensor[1]}"


def _real_footage(
    videos: Path,
    sensor: tuple[int, int],
    *,
    main: bool,
    out: Path,
    seed: int,
    n_test: int,
    runner: Runner,
    progress: bool,
    train_kwargs: dict[str, Any],
) -> tuple[dict[str, Any], list[str]]:
    """The real-footage experiment at one sensor size.

    The real dataset built from ``videos`` at ``sensor`` (``n_test`` test windows), a network
    trained on its train clips with the recipe, identification fitted (tuned on a quarter of
    the training clips held out: the clips have no second draw), scored on the test windows,
    their recordings followed as tracks, and the test clips streamed whole. ``main``: the
    run's own sensor size (``data/real``, ``model-real.npz``; another size's files carry its
    name). Returns the log entry and RESULTS.md's section."""
    name = _sensor_name(sensor)
    suffix = "" if main else f"-{name}"
    real_dir = _dataset(
        out / f"data/real{suffix}", "real", seed, progress, videos=videos, n_train=None,
        n_test=n_test, runner=runner, sensor=sensor,
    )  # fmt: skip
    real_train, real_test = load(real_dir, "train"), load(real_dir, "test")
    config = recipe_config() | {"width": sensor[0], "height": sensor[1]}
    job = _train_all(runner, {"real": (config, real_train, "")}, seed, train_kwargs)["real"]
    net = runner.result(job).network
    real_fit = fit_identification(net, real_train)
    net.trained_on = TrainedOn.of_sets(real_train)
    net.save(out / f"model-real{suffix}.npz")
    real = runner.result(runner.submit(evaluate_task, net, real_test, {"keep_inference": True}))
    assert real.inference is not None
    real_ident = both_rules(net, real_test, real.inference)
    real_tracks = evaluate_tracks(net, real_test, real.inference)
    real_clips = evaluate_clips(net, real_dir, videos=videos, runner=runner)
    entry = real.to_dict() | {
        "videos": str(videos), "sensor": list(sensor), "train_windows": len(real_train),
        "identify_fit": real_fit, "identification": real_ident, "tracks": real_tracks,
        "clips": real_clips,
    }  # fmt: skip
    heading = f"Real footage at {name}"
    lines = [
        f"\n## {heading}\n",
        f"`{videos}` at {name}: {len(real_train)} train windows and {len(real_test)} test "
        "windows from different clips, all through the PIX2NVS path; drone windows against "
        "bird, airplane and helicopter windows (and drone clips' frames without a visible "
        "drone). Trained on the real train clips with the same recipe "
        f"(`model-real{suffix}.npz`).\n",
        report.evaluation_markdown(real),
        *identification_text(real_fit, real_ident, ""),
        f"\n### Tracks on the real test clips ({name})\n",
        tracks_text(real_tracks),
        f"\n### The real test clips streamed whole ({name})\n",
        "Each test clip made into events again as the dataset's build made them and "
        "streamed whole through the detector, as `uavsnn detect` runs (`uavsnn evaluate "
        "--clips`; every window, where the split above keeps "
        f"{100 * real_tracks['window_coverage']:.1f} % of them). A clip is decided UAV when "
        "a track alarms in it, and decided right when that is whether a UAV is labelled in "
        "it (SPEC §5's target: at least 90 % of clips).\n",
        clip_table(real_clips),
    ]
    return entry, lines


class _Checked(NamedTuple):
    """What :func:`_checked` found the arguments to mean."""

    sensor: tuple[int, int]
    real_sensors: list[tuple[int, int]]
    tune_seed: int
    n_tune: int
    videos: Path | None  # None: no real footage
    no_real: str  # why there is no real footage ("" when there is)


def _checked(args: argparse.Namespace) -> _Checked:
    """Every argument checked before any work, and nothing made: the sensors, the tuning seed
    and count, the window counts, the minutes streamed, the folder --out (made by the caller
    once every check has passed) and the real footage (the videos the real builds read, each
    clip planned at each real sensor size as the build plans it; --videos and --real-sensors
    refused where the real-footage experiment does not run). Returns the values the run uses.

    Raises:
        ParameterError: a bad argument, or an --out that could not be made or written.
        DatasetError: --videos (or the default folder) lacking what a real build reads.
    """
    sensor = parse_sensor(args.sensor)
    real_sensors = _real_sensors(args.real_sensors, sensor)
    check_int("--seed", args.seed, low=0)
    tune_seed = args.seed + 1 if args.tune_seed is None else args.tune_seed
    n_tune = args.n_train if args.n_tune is None else args.n_tune
    if tune_seed == args.seed or tune_seed < 0:
        raise ParameterError(
            f"--tune-seed must be a non-negative seed other than --seed ({args.seed}): "
            f"identification is tuned on other recordings than the test's, got {tune_seed}"
        )
    for flag, n in (("--n-train", args.n_train), ("--n-tune", n_tune)):
        if not (2 <= n <= MAX_SPLIT_WINDOWS and n % 2 == 0):
            raise ParameterError(
                f"{flag} must be an even number of windows from 2 to {MAX_SPLIT_WINDOWS:,} (half "
                f"with a UAV), got {n}"
            )
    if not (2 <= args.n_test <= MAX_SPLIT_WINDOWS and args.n_test % 2 == 0):
        raise ParameterError(
            f"--n-test must be an even number of windows from 2 to {MAX_SPLIT_WINDOWS:,} (half "
            f"with a UAV), got {args.n_test}"
        )
    check_int("--windows-per-layer", args.windows_per_layer, low=1, high=MAX_WINDOWS_PER_LAYER)
    spans = (("--free-minutes", args.free_minutes), ("--track-minutes", args.track_minutes))
    for flag, minutes in spans:
        if not 0 <= minutes <= MAX_MINUTES:
            raise ParameterError(f"{flag} must be in [0, {MAX_MINUTES:g}], got {minutes}")
    # Options of the real-footage experiment are refused where it does not run, as other
    # commands refuse options that would change nothing.
    real_options = [
        flag
        for flag, value in (("--videos", args.videos), ("--real-sensors", args.real_sensors))
        if value is not None
    ]
    if args.no_real and real_options:
        raise ParameterError(
            f"{' and '.join(real_options)} {'set' if len(real_options) > 1 else 'sets'} the "
            "real-footage experiment, which --no-real leaves out: give one or the other"
        )
    check_output_dir(args.out, "--out")
    videos = None
    no_real = "--no-real was given"
    if not args.no_real:
        videos = args.videos or (_DEFAULT_VIDEOS if _DEFAULT_VIDEOS.is_dir() else None)
        no_real = (
            ""
            if videos is not None
            else f"no --videos was given, and the default folder {_DEFAULT_VIDEOS} (from the "
            "working directory) does not exist"
        )
        if videos is None and args.real_sensors is not None:
            raise ParameterError(
                "--real-sensors sets the sizes of the real-footage experiment, which cannot "
                f"run: {no_real} (--videos DIR gives the labelled videos)"
            )
    if videos is not None:
        # What the real builds will read, refused now rather than after the synthetic runs.
        for real_sensor in real_sensors:
            try:
                check_footage(videos, real_sensor, n_test=args.n_test, seed=args.seed)
            except DatasetError as exc:
                where = f"--videos {videos} at {_sensor_name(real_sensor)}"
                skip = "" if args.videos is not None else " (the default; --no-real skips it)"
                raise DatasetError(f"{where}{skip}: {exc}") from exc
    return _Checked(sensor, real_sensors, tune_seed, n_tune, videos, no_real)


def _reproduce(args: argparse.Namespace) -> int:
    started = time.perf_counter()
    sensor, real_sensors, tune_seed, n_tune, videos, no_real = _checked(args)
    if no_real and not args.no_real:
        # Said now, not found hours later as a section missing from RESULTS.md.
        print(
            f"uavsnn reproduce: no real footage: {no_real}; RESULTS.md will say so (--videos "
            "DIR gives the labelled videos; --no-real leaves them out on purpose)",
            file=sys.stderr,
            flush=True,
        )
    runner = runner_for(args.ray)  # an unreachable cluster fails now, before --out is made
    out: Path = output_dir(args.out, "--out")
    progress = not args.quiet
    seed = args.seed
    command = "uavsnn reproduce " + " ".join(shlex.quote(a) for a in sys.argv[2:])
    env = environment()
    log: dict[str, Any] = {
        "uavsnn": __version__, "seed": seed, "tune_seed": tune_seed, "command": command,
        "environment": env, "sensor": list(sensor),
    }  # fmt: skip

    def step(msg: str) -> None:
        print(f"[{time.perf_counter() - started:7.1f} s] {msg}", flush=True)

    step("dvs dataset")
    dvs_dir = _dataset(
        out / "data/dvs", "dvs", seed, progress, n_train=args.n_train, n_test=args.n_test,
        runner=runner, sensor=sensor,
    )  # fmt: skip
    step("sim dataset")
    sim_dir = _dataset(
        out / "data/sim", "sim", seed, progress, n_train=args.n_train, n_test=200, runner=runner,
        sensor=sensor,
    )  # fmt: skip
    step(f"tuning sets (seed {tune_seed})")
    # Built as the training sets are, from recordings of another seed, with every kind of
    # object in its share (a drawn set of 4000 windows may lack one: seed 1 had no helicopter
    # scene); only their train split is used (the test split, two windows, is there because a
    # dataset has one).
    tune_kwargs = {
        "n_train": n_tune, "n_test": 2, "runner": runner, "sensor": sensor, "stratify": True,
    }  # fmt: skip
    tune_dirs = [
        _dataset(out / f"data/tune-{d}", d, tune_seed, progress, **tune_kwargs)
        for d in ("dvs", "sim")
    ]
    dvs_train, dvs_test = load(dvs_dir, "train"), load(dvs_dir, "test")
    sim_train = load(sim_dir, "train")
    combined = mix_windows([dvs_train, sim_train], args.n_train, seed=seed)
    dvs_tune, sim_tune = (load(d, "train") for d in tune_dirs)
    tuned_on = (
        f"dvs recordings of seed {tune_seed} (`data/tune-dvs`, each kind of object in its "
        "share); a combined network's identification is fitted on the dvs set's training "
        "windows, as the dvs network's is: the sim windows, made from video, carry no rotor"
    )
    size = {"width": sensor[0], "height": sensor[1]}
    recipe = recipe_config() | size
    # name -> (identification's training windows, its tuning windows). A combined network's
    # identification is fitted on the event-camera windows among its training data: the
    # rotor it reads cannot be in events made from 30/60 fps video, and on the dvs sets of
    # seeds 2 and 3 this fit beat the fit on the mixed windows (docs/identification.md, "The
    # combined network's identification on its dvs windows").
    ident_data = {
        "dvs": (dvs_train, dvs_tune), "sim": (sim_train, sim_tune),
        "combined": (dvs_train, dvs_tune), "combined, Table 1 as published": (dvs_train, dvs_tune),
    }  # fmt: skip
    # name -> the sets whose recordings the network learns from (uavsnn.provenance): its
    # training windows' (a combined network's are drawn from both) and identification's.
    learned = {
        "dvs": [dvs_train], "sim": [sim_train], "combined": [dvs_train, sim_train],
        "combined, Table 1 as published": [dvs_train, sim_train],
    }  # fmt: skip
    # name -> (config, training windows, model file)
    runs: dict[str, tuple[dict[str, Any], LabelledWindows, str]] = {
        "dvs": (recipe, dvs_train, "model-dvs.npz"),
        "sim": (recipe, sim_train, "model-sim.npz"),
        "combined": (recipe, combined, "model-combined.npz"),
        "combined, Table 1 as published": (
            default_config() | size,
            combined,
            "model-combined-table1.npz",
        ),
    }
    networks: dict[str, Network] = {}
    results: dict[str, Evaluation] = {}
    trainings = {}
    train_kwargs = {
        "windows_per_layer": args.windows_per_layer, "seed": seed,
        "progress": progress and runner is SERIAL,
    }  # fmt: skip
    jobs = _train_all(runner, runs, seed, train_kwargs)
    test_ref = runner.put(dvs_test)
    evaluations = {}
    fits: dict[str, dict[str, Any]] = {}
    for name, (_, _, model_file) in runs.items():
        step(f"train {name}")
        trainings[name] = runner.result(jobs[name])
        net = trainings[name].network
        fits[name] = fit_identification(net, *ident_data[name])
        if name in STREAMED and args.track_minutes and net.identification is not None:
            step(f"track alarm thresholds of {name} ({args.track_minutes:g} minutes streamed)")
            net.identification, fits[name]["tracks"] = tune_track_alarms(
                net, minutes=args.track_minutes, seed=tune_seed, runner=runner
            )
        fitted_on = [d for d in ident_data[name] if d is not None]
        net.trained_on = TrainedOn.of_sets(*learned[name], *fitted_on)
        net.save(out / model_file)
        networks[name] = net
        evaluations[name] = runner.submit(evaluate_task, net, test_ref, {"keep_inference": True})
    idents: dict[str, dict[str, Any] | None] = {}
    for name, job in evaluations.items():
        results[name] = runner.result(job)
        inference = results[name].inference
        assert inference is not None
        idents[name] = both_rules(networks[name], dvs_test, inference)
    log["table2"] = {
        name: e.to_dict() | {"identify_fit": fits[name], "identification": idents[name]}
        for name, e in results.items()
    }
    step("tracks")
    tracks = evaluate_tracks(networks["combined"], dvs_test, results["combined"].inference)
    log["tracks"] = tracks
    step("ablation")
    log["ablation"] = {
        name: _ablation(networks[name], *ident_data[name], dvs_test, results[name])
        for name in STREAMED
        if networks[name].identification is not None
    }
    ablation_text = []
    if log["ablation"]:
        ablation_text = [
            "\n### Ablation: rotor, shape and track features alone and together\n",
            "Identification fitted again on each group of features alone (the same training "
            f"windows, tuned on the same recordings of seed {tune_seed}, the same choice of "
            "score) and measured on the dvs test set (`uavsnn evaluate --ablation TUNE "
            "--tracks`; `no_track`: every feature but the track's; `no_activity_history`: "
            "every feature but the track's activity history). Detection is read off the test "
            "set's ROC.\n",
        ]
        ablation_text += per_network(log["ablation"], ablation_table)
    step("the test recordings streamed whole")
    log["clips"] = {
        name: evaluate_clips(networks[name], dvs_dir, runner=runner) for name in STREAMED
    }
    streamed_text = [
        "\n### Tracks: the test recordings streamed whole\n",
        "The split keeps "
        f"{100 * tracks['window_coverage']:.1f} % of the steps its recordings span. Each test "
        "recording rendered again from its seed as the build made it and streamed whole "
        "through the `Detector`, as `uavsnn detect` runs (`uavsnn evaluate --clips`): every "
        "window counts. A recording is decided UAV when a track alarms in it.\n",
    ]
    streamed_text += per_network(log["clips"], clip_table)
    free_text: list[str] = []
    if args.free_minutes:
        step(f"false alarms over {args.free_minutes:g} minutes of UAV-free recording")
        # The combined network (the paper's system) and the dvs network, the same recordings.
        log["false_alarms"] = {
            name: false_alarm_figures(
                networks[name], minutes=args.free_minutes, seed=seed, runner=runner
            )
            for name in STREAMED
        }
        free_text = [
            f"\n### False alarms over {args.free_minutes:g} minutes of UAV-free recording\n",
            "The test recordings hold half a minute of UAV-free recording, too little for a "
            "false-track rate. Fresh UAV-free dvs recordings (the datasets' scenes, under a key "
            "no dataset split uses) streamed through the `Detector` as `uavsnn detect` runs it "
            "(`uavsnn.false_alarms`); every window of them counts. The same recordings for "
            "both networks.\n",
        ]
        free_text += per_network(log["false_alarms"], false_alarm_table)

    step("noise sweep")
    best = networks["combined"]
    static, theta = static_twin(best, combined.windows)
    points = noise_sweep(
        {"pent": best, "static": static}, dvs_test, NOISE_FRACTIONS, seed=seed, runner=runner
    )
    log["noise"] = [p.to_dict() for p in points]
    log["static_threshold"] = theta
    written = report_pictures.figures(
        out / "figures", best, dvs_test, results["combined"], training=trainings["combined"],
        noise=points, static=static, seed=seed,
    )  # fmt: skip
    rocs = {name: f["roc"] for name, f in idents.items() if f is not None}
    if rocs:
        title = f"detection + identification, {len(dvs_test)} dvs test windows"
        at = {name: f["at_false_alarm"] for name, f in idents.items() if f is not None}
        written["roc"] = pictures.write_png(
            out / "figures/roc.png", pictures.roc_chart(rocs, title, points=at)
        )

    real_text: list[str] = []
    if no_real:
        real_text = ["\n## Real footage\n", f"Not run: {no_real}.\n"]
    if videos is not None:
        size_rows = []
        for real_sensor in real_sensors:
            name = _sensor_name(real_sensor)
            step(f"real footage at {name} from {videos}")
            entry, lines = _real_footage(
                videos, real_sensor, main=real_sensor == sensor, out=out, seed=seed,
                n_test=args.n_test, runner=runner, progress=progress, train_kwargs=train_kwargs,
            )  # fmt: skip
            if real_sensor == sensor:
                log["real"] = entry
            else:
                log.setdefault("real_sensors", {})[name] = entry
            size_rows.append((name, entry))
            real_text += lines
        if len(size_rows) > 1:
            real_text = [
                "\n## Real footage at each sensor size\n",
                f"`{videos}`, the same clips, split and recipe at each size (the network's input "
                "as large as the sensor; each size's section below): the test split's windows "
                "under both rules, and the test clips streamed whole, decided right under each "
                "rule.\n",
                real_sizes_table(size_rows),
                *real_text,
            ]
    log["seconds"] = round(time.perf_counter() - started, 1)
    (out / "results.json").write_text(_jsonout.dumps(_lean(log), indent=2) + "\n", encoding="utf-8")

    real_ran = "real" in log or "real_sensors" in log
    real_sizes = [_sensor_name(s) for s in real_sensors] if real_ran else []
    also_real = ""
    if real_sizes and real_sizes != [_sensor_name(sensor)]:
        also_real = f"; the real footage at {' and '.join(real_sizes)}"
    text = [
        "# Results\n",
        f"Every figure below was produced by `{command}` (uavsnn {__version__}, seed {seed}) in "
        f"{log['seconds'] / 60:.1f} minutes; `results.json` beside this file holds them all. "
        f"Sensor: {_sensor_name(sensor)} (every dataset and network{also_real}). "
        f"Training windows per domain: {args.n_train}; STDP windows per layer: "
        f"{args.windows_per_layer}; test: the dvs test set of {len(dvs_test)} windows "
        "(half UAV), from recordings no network was trained on. The project's recipe is "
        f"Table 1 with `{' '.join(RECIPE_SETTINGS)}` (see `uavsnn.experiments.RECIPE_SETTINGS`).\n",
        f"Environment: Python {env['python']}, NumPy {env['numpy']}, OpenCV {env['opencv']}, "
        f"faery {env['faery']}; {env['platform']}, {env['cpu'] or 'CPU unknown'}. The rendered "
        "scenes of the dvs and sim domains go through NumPy's and OpenCV's floating-point "
        "functions, whose last bits can differ between versions and CPUs, so their figures "
        "may differ slightly in another environment (see `uavsnn.experiments.environment`).\n",
        "## Table 2: networks tested on dvs\n",
        "Both rules: the paper's (a window is a UAV when a conv3 neuron fires) and detection + "
        "identification (also the best object's UAV score at least the threshold tuned on "
        f"recordings of seed {tune_seed}), each accuracy with its 95 % interval when the test "
        "recordings are drawn again, the UAV and the UAV-free ones apart "
        "(`evaluation.recording_interval`); and the detection rate of the second where 1 % and "
        "5 % of the UAV-free test windows alarm: the test ROC's own points, each threshold read "
        "off the test windows themselves, an operating point no user can set beforehand "
        "(nothing of the model is fitted on it; in brackets the detection's 95 % interval when "
        "the test recordings are drawn again and the threshold read again on each draw, "
        "`evaluation.roc_point_interval`, which at 1 % covers less than 95 %: "
        'docs/identification.md, "How well a point read off the ROC is known"), and the '
        "detection and false-alarm rates on the test set at the thresholds where 1 % and 5 % "
        f"of the UAV-free windows of seed {tune_seed} alarmed: an operating point fixed "
        "beforehand, as a user fixes it, and what a user gets (the interval: the false "
        "alarms' 95 % interval when the test recordings are drawn again, "
        "`evaluation.recording_interval`).\n",
        *TABLE2_HEAD,
        *[table2_row(name, e, PAPER_TABLE2.get(name), idents[name]) for name, e in results.items()],
        identification_leads(idents),
        "\n### The combined network in detail\n",
        report.evaluation_markdown(results["combined"]),
        "\n### The combined network with identification\n",
        *identification_text(fits["combined"], idents["combined"], tuned_on),
        "\n### Tracks: the test recordings followed as streams (combined network)\n",
        tracks_text(tracks),
        *[track_points_text(fits[name], name) for name in STREAMED],
        *streamed_text,
        *ablation_text,
        *free_text,
        "\n## Table 3 and PENT: accuracy against added noise (combined network)\n",
        f"Static threshold {theta:.2f}: the one PENT sets for the median clean training window. "
        "With identification, the same model scores both; the noise is added to the windows "
        "the network sees and, at the same density, to the raw events identification measures "
        "(`uavsnn.identify.raw_noise_events`).\n",
        report.noise_table(points),
        *real_text,
        "\n## Pictures\n",
        *report_pictures.picture_links(written, out, network=best),
    ]
    (out / "RESULTS.md").write_text("\n".join(text), encoding="utf-8")
    step(f"wrote {out / 'RESULTS.md'}")
    return 0
