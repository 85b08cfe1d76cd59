"""The text of ``uavsnn reproduce``'s RESULTS.md: Table 2's rows, each network's
identification, the ablation, the tracks and the real footage at each sensor size, as Markdown
from the figures :mod:`uavsnn.cli.reproduce` measured. No figure is computed here."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from uavsnn import identify, report
from uavsnn.cli import counted
from uavsnn.evaluation import Evaluation
from uavsnn.track_eval import rule_name, track_table

__all__ = [
    "TABLE2_HEAD",
    "ablation_table",
    "identification_leads",
    "identification_text",
    "per_network",
    "real_sizes_table",
    "table2_row",
    "track_points_text",
    "tracks_text",
]


def _target_size(point: dict[str, Any]) -> str:
    """``"; ≥ 6 px: 17.6 %"``: the detection of the drones of the target's size at ``point``
    (:func:`uavsnn.report.detection_from_size`), or nothing where there are none."""
    at = report.detection_from_size(point.get("by_size_px", []))
    if at is None:
        return ""
    return f"; {report.TARGET_SIZE_TEXT}: {report.percent(at['rate'])}"


def _read_off(point: dict[str, Any]) -> str:
    """Detection (its 95 % interval) at a point read off the test ROC, the false alarms its
    threshold reached there, and the drones of the target size detected."""
    detection = report.percent_with_interval(point["detection_rate"], point["detection_interval"])
    return f"{detection} at {report.percent(point['false_alarm_rate'])}{_target_size(point)}"


def _set_beforehand(point: dict[str, Any]) -> str:
    """Detection (false alarms; their 95 % interval over the test recordings, ``–`` where too
    few recordings give none: ``evaluation.MIN_INTERVAL_RECORDINGS``) at a threshold set
    beforehand, and the drones of the target size detected."""
    lo, hi = point["false_alarm_interval"]
    interval = "–" if math.isnan(lo) or math.isnan(hi) else f"{100 * lo:.1f}–{100 * hi:.1f}"
    return (
        f"{100 * point['detection_rate']:.1f} % ({100 * point['false_alarm_rate']:.1f} %; "
        f"{interval}){_target_size(point)}"
    )


def table2_row(name: str, e: Evaluation, paper: float | None, ident: dict[str, Any] | None) -> str:
    (tp, fn), (fp, tn) = e.confusion.tolist()
    ref = "" if paper is None else f"{100 * paper:.0f} %"
    # The any-spike accuracy with its interval over the test recordings, where both rules were
    # scored (identification_figures gives it).
    interval = None if ident is None else ident["any_spike"].get("accuracy_interval")
    any_spike = report.percent_with_interval(e.accuracy, interval, bold=True)
    if ident is None:
        cells = "– | – | – | – | –"
    else:
        # Detection at the points read off the test ROC, each with its interval over the test
        # recordings (the threshold read again on each draw).
        points = {p["false_alarm_target"]: p for p in ident["at_false_alarm"]}
        read = [_read_off(points[r]) if r in points else "–" for r in (0.01, 0.05)]
        tuned = {p["false_alarm_target"]: p for p in ident.get("at_tuned_false_alarm", [])}
        set_for = [_set_beforehand(tuned[r]) if r in tuned else "–" for r in (0.01, 0.05)]
        identified = ident["identified"]
        with_ident = report.percent_with_interval(
            identified["accuracy"], identified.get("accuracy_interval"), bold=True
        )
        cells = f"{with_ident} | {' | '.join(read)} | {' | '.join(set_for)}"
    return f"| {name} | {tp} | {fn} | {fp} | {tn} | {any_spike} | {ref} | {cells} |"


def identification_leads(idents: dict[str, dict[str, Any] | None]) -> str:
    """The line under Table 2: each network's accuracy with identification minus its any-spike
    accuracy, with the paired interval."""
    leads = [
        f"{name} {report.lead_text(f['accuracy_lead'])}"
        for name, f in idents.items()
        if f is not None and "accuracy_lead" in f
    ]
    if not leads:
        return ""
    return (
        "\nWhat identification adds to the any-spike rule's accuracy, in points, with its 95 % "
        "interval when the test recordings are drawn again, both rules on the same draws: "
        + "; ".join(leads)
        + ".\n"
    )


TABLE2_HEAD = [
    "| trained on | TP | FN | FP | TN | any-spike accuracy (its 95 % interval) | paper | "
    "with identification | detection at 1 % false alarms (its 95 % interval) at the false "
    f"alarms reached; drones {report.TARGET_SIZE_TEXT} | at 5 % | set beforehand for 1 %: "
    f"detection (false alarms; their 95 % interval); drones {report.TARGET_SIZE_TEXT} | for 5 % |",
    "|---|---|---|---|---|---|---|---|---|---|---|---|",
]


def identification_text(
    fit: dict[str, Any], figures: dict[str, Any] | None, tuned_on: str
) -> list[str]:
    """``tuned_on``: what the separate tuning windows are, when the fit had some."""
    if figures is None:
        return [f"\nNo identification: {fit.get('skipped', 'not fitted')}.\n"]
    if fit["tune"] == identify.HELD_OUT_TUNING:
        tuned_on = "a quarter of the training recordings held out (not fitted on)"
    return [
        f"\nIdentification fitted on {fit['train_windows']} training windows and tuned on "
        f"{fit['tune_windows']} windows of {tuned_on} (UAV score: "
        f"{fit['model']}; L2 {fit['l2']:g}, threshold "
        f"{fit['threshold']:.3f}).\n",
        report.identification_markdown(figures),
        *(
            [report.class_markdown(figures["classes"], figures.get("classes_at_tuned"))]
            if "classes" in figures
            else []
        ),
    ]


def per_network(figures: dict[str, Any], table: Callable[[Any], str]) -> list[str]:
    """Each network's ``table`` of its ``figures``, under its name."""
    return [
        part for name, f in figures.items() for part in (f"\n**The {name} network.**\n", table(f))
    ]


def ablation_table(rows: dict[str, Any]) -> str:
    lines = [
        "| features | columns | accuracy with identification | detection at 1 % / 5 % false "
        "alarms | UAV recordings found | false tracks |",
        "|---|---|---|---|---|---|",
    ]
    for name, row in rows.items():
        tracks = row["tracks"]
        lines.append(
            f"| {name} | {row['features']} | {100 * row['accuracy']:.1f} % "
            f"| {100 * row['detection_at_0.01']:.1f} / {100 * row['detection_at_0.05']:.1f} % "
            f"| {tracks['found']} | {tracks['false_tracks']} |"
        )
    return "\n".join(lines)


def tracks_text(figures: dict[str, Any]) -> str:
    return (
        f"{counted(figures['recordings'], 'test recording')} "
        f"({figures['uav_recordings']} with a UAV), "
        "each one's windows in time order through a tracker (`uavsnn evaluate --tracks`; "
        'docs/identification.md, "Track-level figures"); a window the dataset left out '
        "counts as a window without a detection.\n\n" + track_table(figures)
    )


def track_points_text(fit: dict[str, Any], name: str) -> str:
    """What the track alarm thresholds of ``name``'s fit were set on, or nothing."""
    tracks = fit.get("tracks")
    if not tracks:
        return ""
    points = ", ".join(
        f"{threshold:.3f} for {rate:g}" for rate, threshold in tracks["track_alarm_thresholds"]
    )
    return (
        f"\nThe {name} network's track alarm thresholds (the rules 'set for … false tracks per "
        f"minute'), set on {tracks['minutes']:.2f} minutes of other UAV-free recordings of seed "
        f"{tracks['seed']} ({tracks['confirmed_tracks']} confirmed tracks; "
        "`uavsnn.false_alarms.tune_track_alarms`): " + points + " false tracks per minute."
    )


def real_sizes_table(rows: list[tuple[str, dict[str, Any]]]) -> str:
    """One row per sensor size: the test windows under both rules, detection where 5 % of
    their UAV-free windows alarm, and the test clips decided right under each rule."""
    first = rows[0][1]["clips"]["rules"]
    rules = [r for r in first if all(r in e["clips"]["rules"] for _, e in rows)]
    lines = [
        "| sensor | windows, any-spike | windows, with identification | detection at 5 % false "
        "alarms (at the false alarms reached) | "
        + " | ".join(f"clips decided right: {rule_name(r)}" for r in rules)
        + " |",
        "|---|---|---|---|" + "---|" * len(rules),
    ]
    for name, entry in rows:
        ident = entry["identification"]
        clips = entry["clips"]
        if ident is None:
            with_ident = detection = "–"
        else:
            at = {p["false_alarm_target"]: p for p in ident["at_false_alarm"]}
            with_ident = f"{100 * ident['identified']['accuracy']:.1f} %"
            detection = (
                f"{report.percent(at[0.05]['detection_rate'])} at "
                f"{report.percent(at[0.05]['false_alarm_rate'])}"
                if 0.05 in at
                else "–"
            )
        cells = [
            f"{clips['rules'][r]['right']} of {clips['clips']} "
            f"({100 * clips['rules'][r]['right'] / max(1, clips['clips']):.1f} %)"
            for r in rules
        ]
        lines.append(
            f"| {name} | {100 * entry['accuracy']:.1f} % | {with_ident} | {detection} | "
            + " | ".join(cells)
            + " |"
        )
    return "\n".join(lines)
