"""``uavsnn evaluate MODEL DATASET``: the paper's figures for a model on a test set."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from uavsnn import _jsonout, report, report_pictures
from uavsnn._files import check_output_dir
from uavsnn.cli import counted, output_dir, output_file
from uavsnn.dataset import load
from uavsnn.distributed import add_ray_option, runner_for
from uavsnn.errors import ParameterError
from uavsnn.evaluation import evaluate
from uavsnn.experiments import (
    NOISE_FRACTIONS,
    PAPER_TABLE3_BY_SHARE,
    both_rules,
    noise_sweep,
    static_twin,
)
from uavsnn.network import MAX_THREADS, Network
from uavsnn.track_eval import Confirm, clock_text, ms_text, rule_name

__all__ = ["register"]


def register(subparsers: Any) -> None:
    """Add ``uavsnn evaluate``."""
    p = subparsers.add_parser(
        "evaluate",
        help="score a model on a labelled test set",
        description="Run a model on a dataset's test split: confusion matrix [[TP, FN], "
        "[FP, TN]], accuracy, per class, event-time latency, pixels used, cost; optionally "
        "accuracy against added noise with PENT and static thresholds, and a Markdown report "
        "with pictures.",
    )
    p.add_argument("model", type=Path, help="model file written by `uavsnn train`")
    p.add_argument("dataset", type=Path, help="dataset folder")
    p.add_argument("--split", default="test", help="split to score (test)")
    p.add_argument("--noise", action="store_true", help="also sweep added noise (Table 3)")
    p.add_argument(
        "--noise-shares",
        metavar="LIST",
        help="the shares of the sensor's pixels --noise sweeps, comma-separated (0.005,0.01), "
        "or 'table3': SPEC §5's six from 0.5 %% to 5 %%; no noise is always swept beside them "
        "(default: "
        + ",".join(f"{f:g}" for f in NOISE_FRACTIONS if f > 0)
        + "). Static thresholds under 10 %% or more of noise make every layer fire: on "
        "1280x720 windows that is seconds a window",
    )
    p.add_argument(
        "--report",
        type=Path,
        help="write report.md and its pictures to this folder (made when written; --roc may "
        "name a picture in it)",
    )
    p.add_argument("--unbalanced", action="store_true", help="score a set that is not half UAV")
    p.add_argument(
        "--threads",
        type=int,
        default=None,
        help=f"worker threads, at most {MAX_THREADS} (default: all cores)",
    )
    p.add_argument(
        "--seed",
        type=int,
        default=None,
        help="with --noise or --report: seed of the added noise (0)",
    )
    p.add_argument(
        "--ablation",
        type=Path,
        metavar="TUNE_DATASET",
        help="also refit identification on the dataset's train split with rotor, shape, track, "
        "all but track, and all features, tuned on TUNE_DATASET's train split, and score each "
        "on the test split (with --tracks: its track-level figures too)",
    )
    p.add_argument(
        "--roc",
        type=Path,
        metavar="PNG",
        help="write the ROC of detection + identification to this PNG (a model with "
        "identification)",
    )
    p.add_argument(
        "--tracks",
        action="store_true",
        help="also follow each recording's windows in time order with the tracker and report "
        "the track-level figures: UAV recordings found, time to first alarm, false tracks per "
        "minute of UAV-free recording (a dataset with raw events)",
    )
    p.add_argument(
        "--clips",
        action="store_true",
        help="also stream every clip (recording) of the split whole through the detector, made "
        "into events again as the dataset's build made them, and decide each clip (UAV when a "
        "track alarms in it): clips decided right, per class, UAV clips found, time to first "
        "alarm",
    )
    p.add_argument(
        "--videos",
        type=Path,
        metavar="DIR",
        help="with --clips on real footage: the folder of the clips' videos (default: the "
        "folder the dataset's build read, as its manifest names it)",
    )
    add_ray_option(p, "the --clips streams (a clip a task)")
    p.add_argument(
        "--track-score",
        choices=("mean", "max"),
        default=None,
        help="with --tracks and identification (or --ablation): a track alarms when confirmed "
        "and the running mean (default) or max of its objects' UAV scores reaches the model's "
        "threshold; recorded in --json",
    )
    p.add_argument(
        "--confirm",
        metavar="RULE",
        help="with --tracks or --clips: the track confirmation rule, HITS/WINDOWS (default "
        "3/5: hits in 3 of the last 5 windows), or with --tracks FAST+HITS/WINDOWS (e.g. "
        "2/3+3/5: a track whose running mean UAV score reaches the model's threshold confirms "
        "at 2 of 3); recorded in --json",
    )
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    p.set_defaults(handler=_evaluate)


def _trained_here(
    args: argparse.Namespace, network: Network, manifest: dict[str, Any]
) -> list[str]:
    """The recordings of the split scored that the model was trained, fitted or tuned on
    (:meth:`uavsnn.provenance.TrainedOn.shared_with`), each said on stderr, as is a dataset
    windowed otherwise than the model was trained."""
    trained = network.trained_on
    if trained is None:
        return []
    shared = trained.shared_with(manifest, args.split)
    if shared:
        names = ", ".join(shared[:3]) + (f" and {len(shared) - 3} more" if len(shared) > 3 else "")
        print(
            f"uavsnn evaluate: warning: {len(shared)} of the {args.split} split's recordings "
            f"trained {args.model} ({names}): its figures on them are no test; evaluate on a "
            "dataset of other recordings",
            file=sys.stderr,
            flush=True,
        )
    parameters = manifest.get("parameters")
    parameters = parameters if isinstance(parameters, dict) else {}
    window, overlap = parameters.get("window_us"), parameters.get("overlap")
    if not (isinstance(window, (int, float)) and isinstance(overlap, (int, float))):
        return shared
    otherwise = trained.windowed_otherwise(window, overlap)
    if otherwise:
        print(
            f"uavsnn evaluate: note: {args.model} was {otherwise}; {args.dataset}'s "
            f"are {window / 1000:g} ms, overlap {overlap:g}: its identification's features "
            "are measured over the window",
            file=sys.stderr,
            flush=True,
        )
    return shared


def _noise_shares(text: str | None) -> tuple[float, ...]:
    """--noise-shares: ``None`` for :data:`NOISE_FRACTIONS`; ``table3`` for SPEC §5's six; else
    comma-separated shares in (0, 1], in the order given, with no noise first."""
    if text is None:
        return NOISE_FRACTIONS
    if text.strip().lower() == "table3":
        return (0.0, *PAPER_TABLE3_BY_SHARE)
    shares: list[float] = []
    for part in text.split(","):
        try:
            share = float(part)
        except ValueError:
            raise ParameterError(
                f"--noise-shares takes shares of the pixels such as 0.005,0.01 (or table3), "
                f"got {part.strip()!r}"
            ) from None
        if not 0 < share <= 1:  # NaN too
            raise ParameterError(
                "--noise-shares: a share of the pixels is above 0 and at most 1, got "
                + part.strip()
            )
        if share in shares:
            raise ParameterError(f"--noise-shares: {part.strip()} is given twice")
        shares.append(share)
    return (0.0, *shares)


def _evaluate(args: argparse.Namespace) -> int:
    if args.threads is not None and not 1 <= args.threads <= MAX_THREADS:
        raise ParameterError(f"--threads must be from 1 to {MAX_THREADS}, got {args.threads}")
    if args.confirm is not None and not (args.tracks or args.clips):
        raise ParameterError(
            "--confirm sets the track confirmation rule: it needs --tracks or --clips"
        )
    if args.track_score is not None and not args.tracks:
        raise ParameterError(
            "--track-score sets how a track alarms in the --tracks figures: give --tracks"
        )
    track_score_given = args.track_score is not None
    args.track_score = args.track_score or "mean"
    if args.videos is not None and not args.clips:
        raise ParameterError("--videos names the folder of the clips --clips streams: give --clips")
    if args.ray is not None and not args.clips:
        raise ParameterError("--ray runs the --clips streams: give --clips")
    confirm = Confirm.parse("3/5" if args.confirm is None else args.confirm)
    if args.clips and confirm.fast is not None:
        raise ParameterError(
            f"--clips streams through the detector, which confirms by HITS/WINDOWS alone: "
            f"--confirm {confirm} is for --tracks"
        )
    if args.seed is not None and not (args.noise or args.report):
        raise ParameterError(
            "--seed seeds the noise added by --noise and in --report's pictures: give --noise or "
            "--report"
        )
    args.seed = 0 if args.seed is None else args.seed
    if args.seed < 0:
        raise ParameterError(f"--seed must be >= 0, got {args.seed}")
    shares = _noise_shares(args.noise_shares)
    if args.noise_shares is not None and not args.noise:
        raise ParameterError("--noise-shares sets the shares --noise sweeps: give --noise")
    if args.report is not None:
        check_output_dir(args.report, "--report")  # made when the report is written
    roc_in_report = args.roc is not None and _in_report(args.roc, args.report)
    if args.roc is not None:
        if args.roc.suffix.lower() != ".png":
            raise ParameterError(f"--roc {args.roc}: the picture is a PNG: name it .png")
        if roc_in_report:
            # The report folder is checked above and made before the ROC is written.
            if args.roc.is_dir():
                raise ParameterError(f"--roc {args.roc}: is a folder, not a file")
            if args.roc.name in _REPORT_PICTURES:
                raise ParameterError(
                    f"--roc {args.roc}: --report writes its own {args.roc.name} there: name the "
                    "ROC otherwise"
                )
        else:
            output_file(args.roc, "--roc")
    if args.ablation is not None:
        # The ablation fits on DATASET's train split and tunes on TUNE_DATASET's: tuned on the
        # recordings it is fitted on, or on the test recordings, its figures would be no test.
        from uavsnn.cli.train import check_tuning_set

        check_tuning_set(
            args.dataset,
            load(args.dataset, "train"),
            args.ablation,
            load(args.ablation, "train"),
            flag="--ablation",
        )
    network = Network.load(args.model)
    if args.roc is not None and network.identification is None:
        raise ParameterError("--roc needs a model with identification (`uavsnn train`)")
    if confirm.fast is not None and network.identification is None:
        raise ParameterError(
            f"--confirm {confirm}: the score-aware rule needs a model with identification "
            "(`uavsnn train`)"
        )
    if track_score_given and network.identification is None and args.ablation is None:
        raise ParameterError(
            f"--track-score {args.track_score} sets how the identified track rule alarms: it "
            "needs a model with identification (`uavsnn train`) or --ablation"
        )
    data = load(args.dataset, args.split)
    trained_here = _trained_here(args, network, data.manifest or {})
    result = evaluate(
        network, data, threads=args.threads, balanced=not args.unbalanced, keep_inference=True
    )
    figures: dict[str, Any] = {"model": str(args.model), "dataset": str(args.dataset)}
    if network.trained_on is not None:
        figures["trained_on_split"] = trained_here
    figures |= result.to_dict()
    features = None
    if args.tracks or network.identification is not None or args.ablation is not None:
        from uavsnn import identify
        from uavsnn.tracks import tracker_for

        tracker = tracker_for(network, confirm_hits=confirm.hits, confirm_windows=confirm.windows)
        features = identify.window_features(network, data, result.inference, tracker=tracker)
    ident = _identification(args, network, data, result, features, confirm)
    if ident:
        figures["identification"] = ident
    if args.tracks:
        from uavsnn.track_eval import evaluate_tracks

        figures["tracks"] = evaluate_tracks(
            network, data, features=features, track_score=args.track_score, confirm=confirm
        )
        # Recorded as --confirm is: the running score the identified track rules (and the
        # ablation's) alarm on, "mean" or "max"; None where only the any-spike rule is scored.
        identified = network.identification is not None or args.ablation is not None
        figures["tracks"]["track_score"] = args.track_score if identified else None
    if args.clips:
        from uavsnn.clips import evaluate_clips

        figures["clips"] = evaluate_clips(
            network,
            args.dataset,
            args.split,
            videos=args.videos,
            confirm=None if args.confirm is None else confirm,
            runner=runner_for(args.ray),
        )
    if args.roc is not None:
        if "roc" not in ident:
            raise ParameterError("--roc needs a model with identification (`uavsnn train`)")
        if ident["roc"] is None:
            raise ParameterError(
                f"--roc: the {args.split} split holds windows of one class only (all UAV, or "
                "none): no ROC"
            )
        from uavsnn import pictures

        if roc_in_report:
            output_dir(args.report, "--report")  # the ROC is written into it
        name = "any-spike + identification"
        chart = pictures.roc_chart(
            {name: ident["roc"]},
            f"ROC on {args.dataset.name}/{args.split}",
            points={name: ident["at_false_alarm"]},
        )
        figures["roc_png"] = str(pictures.write_png(args.roc, chart))
    points = []
    static = None
    if args.noise or args.report:
        # The static twin's threshold: the one PENT sets on a typical clean training window.
        if (args.dataset / "train.npz").exists():
            train = load(args.dataset, "train")
        else:
            train = data
            print(
                f"uavsnn evaluate: note: {args.dataset} has no train split: the static "
                f"threshold is the one PENT sets on the median window of the {args.split} "
                "split scored here (its spike counts, not its labels)",
                file=sys.stderr,
            )
        static, _ = static_twin(network, train.windows)
    if args.noise and static is not None:
        points = noise_sweep(
            {"pent": network, "static": static}, data, shares, seed=args.seed,
            threads=args.threads,
        )  # fmt: skip
        figures["noise"] = [p.to_dict() for p in points]
    if args.report:
        output_dir(args.report, "--report")  # made now, when the report is written
        written = report_pictures.figures(
            args.report, network, data, result, noise=points, static=static, seed=args.seed
        )
        text = [
            f"# Evaluation of {args.model.name} on {args.dataset}\n",
            report.evaluation_markdown(result),
        ]
        if points:
            text += ["\n## Noise\n", report.noise_table(points)]
        text += [
            "\n## Pictures\n",
            *report_pictures.picture_links(written, args.report, network=network),
        ]
        (args.report / "report.md").write_text("\n".join(text), encoding="utf-8")
        figures["report"] = str(args.report / "report.md")
    if args.json:
        print(_jsonout.document(figures))
        return 0
    if network.load_note:
        print(f"note: {network.load_note}")
    (tp, fn), (fp, tn) = result.confusion.tolist()
    print(
        f"accuracy {100 * result.accuracy:.1f} % ({report.interval_text(result.accuracy_interval)})"
        f" on {result.windows} windows"
    )
    print(f"confusion [[TP {tp}, FN {fn}], [FP {fp}, TN {tn}]]")
    for name, c in sorted(result.per_class.items()):
        print(f"  {name:12s} {c.windows:6d} windows, called UAV {100 * c.called_uav_rate:5.1f} %")
    for z in result.per_size:
        print(
            f"  box side {z.label:10s} UAV: {z.uav.called_uav}/{z.uav.windows} called UAV, "
            f"others: {z.other.called_uav}/{z.other.windows}"
        )
    left = result.latency_no_spike_in_box + result.latency_not_caused
    if len(result.latency_us) or left:
        # Over the true positives with a detection the UAV can have caused (evaluation.score).
        median = figures["latency_us"]["median"]
        said = "-" if median is None else f"median {median / 1000:.2f} ms"
        print(
            f"latency (first UAV spike -> first detection it can have caused): {said} over "
            f"{len(result.latency_us)} true positives"
            + (
                f" ({left} left out: {result.latency_no_spike_in_box} with no input spike in "
                f"the UAV's box, {result.latency_not_caused} with no detection at or after it "
                "boxed on the UAV)"
                if left
                else ""
            )
        )
    if len(result.box_iou):
        iou, off = figures["box_iou"]["median"], figures["box_centre_error_px"]["median"]
        print(f"first detection's box: median IoU {iou:.2f}, centre {off:.1f} px off the UAV's")
    print(
        f"pixels used {100 * result.pixel_fraction:.2f} %; {result.events_per_second / 1e6:.2f} M "
        f"spikes/s ({result.ns_per_event:.0f} ns each)"
    )
    for point in points:
        both = ""
        if point.identified is not None:
            both = f", with identification {100 * point.identified['identified']['accuracy']:.1f} %"
        print(
            f"  noise {100 * point.fraction:5g} % ({point.snr_db:6.1f} dB) {point.mode:7s} "
            f"{100 * point.evaluation.accuracy:.1f} %{both}"
        )
        for other, by_rule in (point.accuracy_leads or {}).items():
            leads = ", ".join(
                f"{'with identification' if rule == 'identified' else 'any-spike'} "
                f"{report.lead_text(lead)}"
                for rule, lead in by_rule.items()
            )
            print(f"    accuracy lead over {other} in points (95 % interval): {leads}")
    if ident:
        _print_identification(ident)
    if args.tracks:
        _print_tracks(figures["tracks"])
    if args.clips:
        from uavsnn.clips import clip_table

        print(f"whole clips of the {args.split} split, streamed:")
        print(clip_table(figures["clips"]))
    if args.report:
        print(f"wrote {figures['report']}")
    return 0


def _identification(
    args: argparse.Namespace,
    network: Network,
    data: Any,
    result: Any,
    test: Any,
    confirm: Confirm,
) -> dict[str, Any]:
    """Detection + identification beside the any-spike rule (when the model has it); ``test``:
    the data's features (``identify.window_features``); ``confirm``: the track confirmation
    rule of ``--confirm``, which the ablation's track figures use as the main ones do."""
    from uavsnn import identify

    if network.identification is None and args.ablation is None:
        return {}
    inference = result.inference
    out = both_rules(network, data, inference, feats=test) or {}
    out["rotor_coverage"] = identify.rotor_coverage(test, data)
    out["feature_auc"] = identify.feature_auc(test)
    if args.ablation is not None:
        train = load(args.dataset, "train")
        tune = load(args.ablation, "train")
        tune_inference = network.infer(tune.windows, threads=args.threads)
        out["ablation"] = identify.ablation(
            identify.window_features(network, train),
            identify.window_features(network, tune, tune_inference),
            test,
            tune_detected=tune_inference.detected,
            tune_label=tune.label,
            test_detected=inference.detected,
            test_label=data.label,
            test_data=data if args.tracks else None,
            track_score=args.track_score,
            confirm=confirm,
        )
    return out


#: How the lines of text name an interval over the recordings (report.interval_text).
OVER_RECORDINGS = "95 % interval over recordings"


def _print_identification(ident: dict[str, Any]) -> None:
    if "identified" in ident:
        for name, label in (("any_spike", "any-spike rule"), ("identified", "+ identification")):
            (tp, fn), (fp, tn) = ident[name]["confusion"]
            print(
                f"{label:18s} accuracy {100 * ident[name]['accuracy']:.1f} % "
                f"({report.interval_text(ident[name]['accuracy_interval'])}) "
                f"[[TP {tp}, FN {fn}], [FP {fp}, TN {tn}]]"
            )
        if "accuracy_lead" in ident:
            print(
                "identification's accuracy lead over the any-spike rule: "
                f"{report.lead_text(ident['accuracy_lead'])} points (95 % interval)"
            )
        for point in ident["at_false_alarm"]:
            sizes = ", ".join(
                f"{report.bin_name(z['low'], z['high'], 'px')} {100 * z['rate']:.1f} %"
                for z in point["by_size_px"]
            )
            drawn = report.interval_text(point["detection_interval"], OVER_RECORDINGS)
            print(
                f"  {report.at_point_text(point)}: detection "
                f"{100 * point['detection_rate']:.1f} % ({drawn}{_target_size(point)}; by "
                f"drawn size: {sizes}){_per_class(point)}"
            )
        if ident["roc"] is None:
            print("  one class only (all UAV, or none): no ROC, no point read off one")
        for point in ident.get("at_tuned_false_alarm", []):
            alarms = (
                "none to measure (no UAV-free window)"
                if point["false_alarm_rate"] is None
                else f"{100 * point['false_alarm_rate']:.1f} % "
                f"({report.interval_text(point['false_alarm_interval'], OVER_RECORDINGS)})"
            )
            print(
                f"  at the threshold set beforehand for {100 * point['false_alarm_target']:g} % "
                f"false alarms ({point['threshold']:.3f}): false alarms {alarms}, detection "
                f"{report.percent(point['detection_rate'])}{_target_size(point)}"
                f"{_per_class(point)}"
            )
    classes = ident.get("classes")
    if classes and classes["classes"] and classes["objects"]:
        recall = ", ".join(
            f"{c} {100 * row['recall']:.0f} % of {row['objects']}"
            for c, row in classes["per_class"].items()
        )
        print(
            f"class guess on {classes['objects']} test objects of a known class: "
            f"{100 * classes['accuracy']:.1f} % right, balanced "
            f"{report.percent(classes['balanced_accuracy'])} ({recall})"
        )
        for point in ident.get("classes_at_tuned", []):
            print(
                f"  at the threshold set beforehand for {100 * point['false_alarm_target']:g} % "
                f"false alarms: {100 * point['accuracy']:.1f} % right, balanced "
                f"{report.percent(point['balanced_accuracy'])}"
            )
    for z in ident["rotor_coverage"]:
        print(
            f"  UAV {report.bin_name(z['low_px'], z['high_px'], 'px')}: {z['uav_windows']} "
            "windows, object on the UAV "
            f"{z['object_on_uav']}, rotor votes {z['rotor_votes']}, rotor detected "
            f"{z['rotor_detected']}"
        )
    ablation = ident.get("ablation", {})
    width = max(map(len, ablation), default=0)
    for name, row in ablation.items():
        tracks = ""
        if "tracks" in row:
            t = row["tracks"]
            median = t["time_to_alarm_ms"]["median"]
            tracks = (
                f"; tracks: found {t['found']}, median alarm "
                f"{'-' if median is None else f'{ms_text(median)} ms'}, false {t['false_tracks']}"
            )
        print(
            f"  ablation {name:{width}s}: accuracy {100 * row['accuracy']:.1f} %, detection at "
            f"1 % / 5 % false alarms {100 * row['detection_at_0.01']:.1f} / "
            f"{100 * row['detection_at_0.05']:.1f} %{tracks}"
        )


def _per_class(point: dict[str, Any]) -> str:
    """``"; false alarms per class: ball 1.9 %, bird 2.5 %, ..."``: the share of each class of
    other object's windows that alarm at ``point``; nothing where the point gives none."""
    shares = point.get("false_alarms_per_class") or {}
    if not shares:
        return ""
    return "; false alarms per class: " + ", ".join(
        f"{cls} {report.percent(share)}" for cls, share in shares.items()
    )


def _target_size(point: dict[str, Any]) -> str:
    """``"; drones ≥ 6 px 134 of 761 (17.6 %)"``: the detection of the UAV windows whose drawn
    size reaches :data:`uavsnn.report.TARGET_SIZE_PX` at ``point`` (the size the target
    names); nothing where the point has no such window."""
    cell = report.target_size_cell(point)
    return "" if cell == "–" else f"; drones {report.TARGET_SIZE_TEXT} {cell}"


def _print_tracks(tracks: dict[str, Any]) -> None:
    score = tracks.get("track_score")
    score_text = f", identified on the running {score} UAV score" if score else ""
    print(
        f"tracks (confirmed at {tracks['confirm']}{score_text}): "
        f"{counted(tracks['recordings'], 'recording')} ({tracks['uav_recordings']} with a UAV), "
        f"{counted(tracks['windows'], 'window')} ({100 * tracks['window_coverage']:.1f} % of "
        f"their steps), {60 * tracks['uav_free_minutes']:.2f} s UAV-free; {clock_text(tracks)}"
    )
    for rule, f in tracks["rules"].items():
        t = f["time_to_alarm_ms"]
        delay = (
            "-"
            if t["median"] is None
            else f"median {ms_text(t['median'])} ms, 90th percentile {ms_text(t['p90'])} ms"
        )
        per_minute = f["false_tracks_per_minute"]
        rate = (
            "no UAV-free time to divide by"
            if per_minute is None
            else f"{per_minute:.2f} per minute, 95 % upper bound "
            f"{f['false_tracks_per_minute_upper95']:.2f}"
        )
        decided, recordings = f["decided"], tracks["recordings"]
        shares = [f"{100 * decided['right'] / recordings:.1f} %"] if recordings else []
        if decided.get("balanced_accuracy") is not None:
            shares.append(f"balanced accuracy {100 * decided['balanced_accuracy']:.1f} %")
        print(
            f"  {rule_name(rule):18s} UAV recordings found {f['found']}/"
            f"{tracks['uav_recordings']}, time to first alarm {delay}; "
            f"{counted(f['false_tracks'], 'false track')} ({rate}), stray {f['stray_tracks']}; "
            f"recordings decided right {decided['right']}/{recordings}"
            + (f" ({'; '.join(shares)})" if shares else "")
        )
    rows = {row["recording"]: row for row in tracks["per_recording"]}
    missed = tracks["rules"]["any_spike"]["missed"]
    if missed:
        print(
            "  UAV recordings the any-spike rule missed: "
            + ", ".join(
                f"{rows[r].get('name') or r} (UAV {_size(rows[r]['uav_size_px'])}, an object "
                f"on it in {rows[r]['uav_windows_met']} of {rows[r]['uav_windows']} windows)"
                for r in missed
            )
        )


def _in_report(path: Path, report_dir: Path | None) -> bool:
    """Whether the file ``path`` lies directly in the folder --report makes."""
    if report_dir is None:
        return False
    return path.parent.absolute().resolve() == report_dir.absolute().resolve()


#: The pictures ``uavsnn evaluate --report`` may write into its folder (beside report.md): all
#: of :func:`uavsnn.report_pictures.figures` but the training's and reproduce's ROC.
_REPORT_PICTURES = frozenset(
    f"{name}.png"
    for name in report_pictures.CAPTIONS
    if name not in ("roc", "convergence") and not name.startswith("evolution-")
)


def _size(px: float | None) -> str:
    return "size unknown" if px is None else f"{px:.1f} px"
