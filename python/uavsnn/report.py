"""The Markdown report of a trained detector (SPEC §6): the any-spike rule's tables, accuracy
against noise (Table 3), identification's figures by size, range and class, and the operating
points, as Markdown.

:func:`evaluation_markdown` turns an evaluation into Markdown tables,
:func:`identification_markdown` identification's figures, :func:`noise_table` a noise sweep.
The pictures beside them are :mod:`uavsnn.report_pictures`' (:func:`figures`,
:func:`picture_links`, the captions), re-exported here, and the ROC chart is
:func:`uavsnn.pictures.roc_chart`. ``uavsnn demo``, ``uavsnn evaluate --report`` and
``uavsnn reproduce`` compose them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from uavsnn.dataset.labels import NONE_CLASS
from uavsnn.errors import ParameterError
from uavsnn.evaluation import (
    MIN_INTERVAL_RECORDINGS,
    ClassFigures,
    Evaluation,
    detection_by_target,
)
from uavsnn.experiments import PAPER_TABLE3, PAPER_TABLE3_BY_SHARE, NoisePoint
from uavsnn.pictures import roc_chart
from uavsnn.report_pictures import (
    CAPTIONS,
    TRAINED_CONV1_CAPTION,
    caption,
    conv1_trained,
    figures,
    picture_links,
)

__all__ = [
    "CAPTIONS",
    "NONE_TEXT",
    "TARGET_SIZE_PX",
    "TARGET_SIZE_TEXT",
    "TRAINED_CONV1_CAPTION",
    "at_point_text",
    "bin_name",
    "caption",
    "class_markdown",
    "confusion_table",
    "conv1_trained",
    "detection_from_size",
    "evaluation_markdown",
    "figures",
    "identification_markdown",
    "interval_text",
    "lead_text",
    "noise_table",
    "percent",
    "percent_with_interval",
    "picture_links",
    "roc_chart",
    "target_size_cell",
]


#: What the class ``none`` of the per-class tables is.
NONE_TEXT = (
    f"`{NONE_CLASS}`: a window in which no labelled object is in view, not an empty scene: the "
    "scene's background, its clutter and the sensor's noise still give events."
)


def confusion_table(matrix: np.ndarray) -> str:
    """The confusion matrix as a Markdown table."""
    (tp, fn), (fp, tn) = np.asarray(matrix).tolist()
    return (
        "| | called UAV | called not UAV |\n|---|---|---|\n"
        f"| **UAV** | {tp} (TP) | {fn} (FN) |\n| **not UAV** | {fp} (FP) | {tn} (TN) |\n"
    )


def percent(share: float | None) -> str:
    """``"34.3 %"`` for a share of 0.343; ``"–"`` for a figure that is undefined (``None``)."""
    return "–" if share is None else f"{100 * share:.1f} %"


def _share(figures: ClassFigures) -> str:
    """``"12 (34.3 %)"``: windows called UAV, and their share; ``"-"`` for no windows."""
    if not figures.windows:
        return "-"
    return f"{figures.called_uav} ({100 * figures.called_uav_rate:.1f} %)"


def evaluation_markdown(evaluation: Evaluation) -> str:
    """Accuracy, the confusion matrix, per-class figures, latency, sparsity and cost."""
    d = evaluation.to_dict()
    lines = [
        f"Accuracy {percent_with_interval(d['accuracy'], d['accuracy_interval'], bold=True)} on "
        f"{d['windows']} windows (a window is a UAV when at least {d['min_detections']} conv3 "
        "neuron fires; in brackets its 95 % interval when the recordings are drawn again"
        + _no_interval_note([d["accuracy_interval"]], d["recordings"], "; ")
        + ").",
        "",
        confusion_table(evaluation.confusion),
        "| class | windows | called UAV | right |",
        "|---|---|---|---|",
    ]
    for name, c in d["per_class"].items():
        lines.append(
            f"| {name} | {c['windows']} | {c['called_uav']} | "
            f"{100 * c['correct'] / c['windows']:.1f} % |"
        )
    if NONE_CLASS in d["per_class"]:
        lines += ["", NONE_TEXT]
    if evaluation.per_size:
        lines += [
            "",
            "By the labelled object's box: the longer side of the box it covers over the "
            "window, its size and its motion in the window together (the detection by size "
            "further on bins the UAV's drawn size, without the motion); windows without an "
            "object left out:",
            "",
            "| box side | UAV windows | called UAV | other objects | called UAV |",
            "|---|---|---|---|---|",
        ]
        for z in evaluation.per_size:
            lines.append(
                f"| {z.label} | {z.uav.windows} | {_share(z.uav)} | {z.other.windows} | "
                f"{_share(z.other)} |"
            )
    lat, start = d["latency_us"], d["latency_from_window_start_us"]
    lines += [""]
    if lat["n"]:
        lines.append(
            f"Latency in event time over {lat['n']} true positives: from the first input spike "
            "in the UAV's box to the first conv3 spike it can have caused (at or after that "
            "spike, its box overlapping the UAV's), median "
            f"{lat['median'] / 1000:.2f} ms (90th percentile {lat['p90'] / 1000:.2f} ms); from "
            f"the window's start to the first conv3 spike, median {start['median'] / 1000:.2f} "
            f"ms over {start['n']}." + _latency_left_out(d["latency_left_out"])
        )
    elif start["n"]:
        lines.append(
            f"No latency from the UAV's first input spike: of {start['n']} true positives, "
            + _latency_left_out(d["latency_left_out"], alone=True)
            + f" From the window's start to the first conv3 spike, median "
            f"{start['median'] / 1000:.2f} ms."
        )
    iou, off = d["box_iou"], d["box_centre_error_px"]
    if iou["n"]:
        lines.append(
            f"Where, over {iou['n']} true positives with a labelled box: the first detection's "
            f"box overlaps it with a median IoU of {iou['median']:.2f}, and their centres lie a "
            f"median {off['median']:.1f} px apart (90th percentile {off['p90']:.1f} px)."
        )
    lines.append(
        f"Pixels that spiked per window: {100 * d['pixel_fraction']:.2f} % of the sensor. "
        f"Cost: {d['input_spikes']} input spikes in {d['seconds']:.3f} s of wall time, "
        f"{d['events_per_second'] / 1e6:.2f} M spikes/s ({d['ns_per_event']:.0f} ns each, "
        "batch inference on all cores, Python overhead included)."
    )
    return "\n".join(lines) + "\n"


def noise_table(points: Sequence[NoisePoint]) -> str:
    """Accuracy per noise level and mode, with the paper's Table 3 beside it; for the modes whose
    network has identification, a column for detection + identification beside the any-spike
    rule's."""
    modes = list(dict.fromkeys(p.mode for p in points))
    with_ident = {p.mode for p in points if p.identified is not None}
    columns = [(m, False) for m in modes] + [(m, True) for m in modes if m in with_ident]
    names = [f"{m} + identification" if ident else m for m, ident in columns]
    # The first mode's accuracy lead over each other, by rule (NoisePoint.accuracy_leads).
    led = next((p for p in points if p.accuracy_leads), None)
    first = "" if led is None else led.mode
    by_other = {} if led is None or led.accuracy_leads is None else led.accuracy_leads
    leads = [(other, rule) for other, by_rule in by_other.items() for rule in by_rule]
    names += ["the paper (PENT), SPEC §5's point"] + [
        f"{first} − {o}" + (" (+ identification)" if rule == "identified" else "")
        for o, rule in leads
    ]
    header = "| noise (share of pixels) | median SNR (dB) | " + " | ".join(names) + " |"
    rows = [header, "|---|---|" + "---|" * len(names)]
    for fraction in dict.fromkeys(p.fraction for p in points):
        level = next(p.snr_db for p in points if p.fraction == fraction)
        here = {p.mode: p for p in points if p.fraction == fraction}
        cells = []
        for mode, ident in columns:
            point = here[mode]
            if ident:
                acc = point.identified["identified"]["accuracy"] if point.identified else None
            else:
                acc = point.evaluation.accuracy
            cells.append(percent(acc))
        snr = "no noise" if not np.isfinite(level) else f"{level:.1f}"
        theirs = PAPER_TABLE3_BY_SHARE.get(fraction)
        cells.append("" if theirs is None else f"{100 * theirs:.0f} %")
        mine = here[first].accuracy_leads if first in here else None
        for other, rule in leads:
            lead = (mine or {}).get(other, {}).get(rule)
            cells.append("–" if lead is None else lead_text(lead))
        rows.append(f"| {100 * fraction:g} % | {snr} | {' | '.join(cells)} |")
    paper = ", ".join(f"{snr:g} dB: {100 * acc:.0f} %" for snr, acc in PAPER_TABLE3.items())
    out = "\n".join(rows) + (
        f"\n\nThe paper's Table 3 (PENT): {paper}; its SNR labels cannot all come from one "
        "signal, so SPEC §5 sets its six figures, in order, beside the six shares from 0.5 % "
        "to 5 % (the paper's column)."
        + (
            f" {first} − {', '.join(by_other)}: the accuracy lead in points, by rule, on the "
            "same noisy windows, with its 95 % interval when the test recordings are drawn "
            "again, UAV and UAV-free apart, both on the same draws "
            "(`evaluation.recording_interval` with `against` and `strata`)."
            if leads
            else ""
        )
        + "\n"
    )
    if with_ident:
        out += "\n" + _noise_detection_table(points, [m for m in modes if m in with_ident])
    return out


def _noise_detection_table(points: Sequence[NoisePoint], modes: Sequence[str]) -> str:
    """Detection + identification at fixed false-alarm rates per noise level and mode: a
    comparison that a rule firing more on every window cannot win by accuracy alone."""
    first = next(p.identified for p in points if p.identified is not None)
    assert first is not None
    rates = [a["false_alarm_target"] for a in first["at_false_alarm"]]
    names = [f"{m}, at {100 * r:g} % false alarms" for m in modes for r in rates]
    # The first mode's lead over each other, where the sweep measured it (NoisePoint.leads).
    led = next((p for p in points if p.leads), None)
    others = list(led.leads) if led is not None and led.leads else []
    if led is not None:
        names += [f"{led.mode} − {o}, at {100 * r:g} %" for o in others for r in rates]
    rows = [
        "Detection + identification: UAV windows detected where the given share of the UAV-free "
        "windows alarm (thresholds read off each level's own ROC)"
        + (
            f"; and {led.mode}'s lead over {', '.join(others)} in points, with its 95 % "
            "interval when the test recordings are drawn again, both on the same draws "
            "(`evaluation.roc_point_interval` with `against`)"
            if led
            else ""
        )
        + ":\n",
        "| noise (share of pixels) | " + " | ".join(names) + " |",
        "|---|" + "---|" * len(names),
    ]
    for fraction in dict.fromkeys(p.fraction for p in points):
        here = {p.mode: p.identified for p in points if p.fraction == fraction}
        cells = []
        for mode in modes:
            ident = here.get(mode)
            at = {} if ident is None else detection_by_target(ident["at_false_alarm"])
            cells += [f"{100 * at[r]:.1f} %" if r in at else "–" for r in rates]
        leads = next((p.leads for p in points if p.fraction == fraction and p.leads), None)
        for other in others:
            for r in rates:
                lead = (leads or {}).get(other, {}).get(f"{r:g}")
                cells.append("–" if lead is None else lead_text(lead))
        rows.append(f"| {100 * fraction:g} % | {' | '.join(cells)} |")
    return "\n".join(rows) + "\n"


def _drawn(interval: Sequence[float] | None) -> Sequence[float] | None:
    """A figure's interval, or ``None`` where it has none: ``None``, or NaN (drawn from too few
    recordings, :data:`uavsnn.evaluation.MIN_INTERVAL_RECORDINGS`)."""
    if interval is None or any(math.isnan(v) for v in interval):
        return None
    return interval


def lead_text(lead: dict[str, Any]) -> str:
    """``"+1.9 (-3.1 to +6.0)"``: a lead in points, with its interval; ``"+1.9 (–)"`` where it
    has none (too few recordings: :data:`uavsnn.evaluation.MIN_INTERVAL_RECORDINGS`)."""
    interval = _drawn(lead.get("interval"))
    if interval is None:
        return f"{100 * lead['lead']:+.1f} (–)"
    lo, hi = interval
    return f"{100 * lead['lead']:+.1f} ({100 * lo:+.1f} to {100 * hi:+.1f})"


def interval_text(interval: Sequence[float] | None, head: str = "95 % interval") -> str:
    """``"95 % interval 28.3-40.4"`` (per cent), or, where the figure has none (``None`` or
    NaN: drawn from fewer than :data:`uavsnn.evaluation.MIN_INTERVAL_RECORDINGS` recordings of
    a kind), ``"no 95 % interval: fewer than 5 recordings of a kind"``, for a line of text."""
    drawn = _drawn(interval)
    if drawn is None:
        return f"no {head}: fewer than {MIN_INTERVAL_RECORDINGS} recordings of a kind"
    return f"{head} {100 * drawn[0]:.1f}-{100 * drawn[1]:.1f}"


def _latency_left_out(left: dict[str, int], *, alone: bool = False) -> str:
    """The true positives the latency leaves out, as a sentence (``alone``: the whole reason
    there is none), or nothing."""
    parts = []
    if left["no_spike_in_box"]:
        parts.append(f"{left['no_spike_in_box']} with no input spike in the UAV's box")
    if left["not_caused"]:
        parts.append(
            f"{left['not_caused']} whose every detection came before the first input spike in "
            "the UAV's box or had its box off the UAV's (caused by something else)"
        )
    if not parts:
        return ""
    head = "" if alone else " Left out: "
    return head + " and ".join(parts) + "."


def _no_interval_note(
    intervals: Sequence[Sequence[float] | None], recordings: Any, lead: str = ""
) -> str:
    """What a ``–`` in place of a 95 % interval means, after ``lead``, where one of
    ``intervals`` is none (NaN), with the set's ``recordings`` (``{"uav", "uav_free"}``: the
    recordings with UAV windows and those with UAV-free windows, the two strata an interval
    draws from; a recording with both kinds is in both, so ``uav_free`` is not the count of
    recordings without a UAV); else nothing."""
    missing = any(i is not None and _drawn(i) is None for i in intervals)
    if not missing:
        return ""
    counts = ""
    if isinstance(recordings, Mapping):
        counts = (
            f"this set has {recordings['uav']} UAV and {recordings['uav_free']} UAV-free, "
            "counted by their windows: a recording with windows of both kinds counts in both; "
        )
    return (
        f"{lead}– in place of an interval: fewer than {MIN_INTERVAL_RECORDINGS} recordings of "
        f"a kind to draw again ({counts}`evaluation.MIN_INTERVAL_RECORDINGS`)"
    )


def bin_name(low: float, high: float | None, unit: str) -> str:
    """A bin of sizes or ranges as the reports name it: ``"6–12 px"``, or ``"≥ 48 px"`` for
    one without an upper end (``high`` ``None``)."""
    return f"≥ {low:g} {unit}" if high is None else f"{low:g}–{high:g} {unit}"


#: The smallest drawn drone size the detection target names: drones of at least 6 px
#: detected at least 95 % of the time at a 1 % false-alarm rate.
TARGET_SIZE_PX = 6.0


#: :data:`TARGET_SIZE_PX` as the reports name it: ``"≥ 6 px"``.
TARGET_SIZE_TEXT = bin_name(TARGET_SIZE_PX, None, "px")


def detection_from_size(
    bins: Sequence[Mapping[str, Any]], low: float = TARGET_SIZE_PX
) -> dict[str, Any] | None:
    """The detection of the UAV windows whose drawn size is at least ``low``, summed over an
    operating point's ``by_size_px`` bins (:func:`uavsnn.evaluation.identification_figures`;
    ``low`` must be a bin edge, as 6 px is of :data:`uavsnn.evaluation.SIZE_BINS_PX`):
    ``{"detected", "windows", "rate"}``, or ``None`` where no such window is there (or the
    bins carry no counts).

    Raises:
        ParameterError: ``low`` inside a bin.
    """
    if any(b["low"] < low < (math.inf if b["high"] is None else b["high"]) for b in bins):
        raise ParameterError(f"{low:g} px is not an edge of the size bins")
    above = [b for b in bins if b["low"] >= low and "windows" in b and "detected" in b]
    windows = sum(int(b["windows"]) for b in above)
    if not windows:
        return None
    detected = sum(int(b["detected"]) for b in above)
    return {"detected": detected, "windows": windows, "rate": detected / windows}


def at_point_text(point: Mapping[str, Any]) -> str:
    """``"at 1 % false alarms (0.9 % reached)"``: an operating point read off the ROC by its
    target share of UAV-free windows alarming, with the share its threshold reached on these
    windows (a ROC moves in steps, so the two can differ); the target alone where the point
    gives no rate reached."""
    text = f"at {100 * point['false_alarm_target']:g} % false alarms"
    reached = point.get("false_alarm_rate")
    return text if reached is None else f"{text} ({100 * reached:.1f} % reached)"


def percent_with_interval(
    share: float | None, interval: Sequence[float] | None, *, bold: bool = False
) -> str:
    """``share`` in per cent (in bold with ``bold``), with its interval in brackets when there
    is one; ``(–)`` where it was drawn from too few recordings to have one (NaN,
    :data:`uavsnn.evaluation.MIN_INTERVAL_RECORDINGS`)."""
    text = f"**{percent(share)}**" if bold and share is not None else percent(share)
    if share is None or interval is None or math.isnan(share):
        return text
    if _drawn(interval) is None:
        return f"{text} (–)"
    return f"{text} ({100 * interval[0]:.1f}–{100 * interval[1]:.1f})"


def _operating_points(points: list[dict[str, Any]], recordings: Any = None) -> list[str]:
    """The lines of :func:`identification_markdown` at the points read off the ROC: detection
    by size and range, false alarms per class, overall detection."""
    lines: list[str] = []
    head = " | ".join(at_point_text(p) for p in points)
    for key, unit, what in (("by_size_px", "px", "size"), ("by_range_m", "m", "range")):
        if not points[0][key]:
            lines += [f"No UAV window has a labelled {what}.\n"]
            continue
        label = f"{what} (as drawn, `size_px`: not the box, which adds the motion)"
        # Older figures give no recordings per bin.
        counted = all("recordings" in b for b in points[0][key])
        lines += [
            f"Detection by the UAV's {label if key == 'by_size_px' else what}:\n",
            f"| {what} | UAV windows{' (their recordings)' if counted else ''} | {head} |",
        ]
        lines.append("|---|---|" + "---|" * len(points))
        for k, b in enumerate(points[0][key]):
            cells = " | ".join(
                f"{p[key][k]['detected']} ({100 * p[key][k]['rate']:.1f} %)" for p in points
            )
            windows = f"{b['windows']} ({b['recordings']})" if counted else f"{b['windows']}"
            lines.append(f"| {bin_name(b['low'], b['high'], unit)} | {windows} | {cells} |")
        if counted:
            lines.append(
                "\nA recording whose UAV changes size or range has windows in several bins; a "
                "bin of few recordings is known to few draws."
            )
        lines.append("")
    lines += _class_false_alarms(points, head)
    overall = "; ".join(
        f"{percent_with_interval(p['detection_rate'], p.get('detection_interval'))} of the UAV "
        f"windows at {100 * p['false_alarm_rate']:.1f} % false alarms" + _target_size_text(p)
        for p in points
    )
    lines += ["", f"Overall detection: {overall}."]
    if any(p.get("detection_interval") for p in points):
        lines.append(
            "In brackets, its 95 % interval when the set's recordings are drawn again and the "
            "threshold read again on each draw (`evaluation.roc_point_interval`; at 1 % it "
            'covers less than 95 %: docs/identification.md, "How well a point read off the '
            'ROC is known")'
            + _no_interval_note([p.get("detection_interval") for p in points], recordings, "; ")
            + "."
        )
    return lines


def _class_false_alarms(points: Sequence[Mapping[str, Any]], head: str) -> list[str]:
    """The false alarms per class of other object at each operating point, under ``head`` (the
    points' names, ``" | "`` between them)."""
    lines = ["False alarms per class of other object:\n", f"| class | {head} |"]
    lines.append("|---|" + "---|" * len(points))
    for cls in points[0]["false_alarms_per_class"]:
        cells = " | ".join(f"{100 * p['false_alarms_per_class'][cls]:.1f} %" for p in points)
        lines.append(f"| {cls} | {cells} |")
    return lines


def _target_size_text(point: Mapping[str, Any]) -> str:
    """``" (of the drones ≥ 6 px, the target's size: 134 of 761, 17.6 %)"``, or nothing where the
    point has no UAV window of that size (:func:`detection_from_size`)."""
    at = detection_from_size(point.get("by_size_px", []))
    if at is None:
        return ""
    return (
        f" (of the drones {TARGET_SIZE_TEXT}, the target's size: "
        f"{at['detected']} of {at['windows']}, {100 * at['rate']:.1f} %)"
    )


def target_size_cell(point: Mapping[str, Any]) -> str:
    """``"200 of 761 (26.3 %)"``: :func:`detection_from_size` of an operating point as the
    reports write it, ``–`` for none."""
    at = detection_from_size(point.get("by_size_px", []))
    return "–" if at is None else f"{at['detected']} of {at['windows']} ({percent(at['rate'])})"


def identification_markdown(figures: dict[str, Any]) -> str:
    """Both rules side by side (:func:`uavsnn.evaluation.identification_figures`' output): the
    confusion and accuracy of each, the calls per class, and at the thresholds where 1 % and
    5 % of the UAV-free windows alarm, the detection rate by size and by range and the false
    alarms per class of other object; and at the thresholds tuned beforehand for those shares
    (when the model has them), the shares and detection measured here."""
    lines = [
        f"Identification threshold {figures['threshold']:.3f} (chosen on recordings none of "
        "these figures is measured on). A window is called UAV by the any-spike rule when a "
        "conv3 neuron fires; with identification, when also its best object's UAV score "
        "reaches the threshold.\n",
        "| rule | TP | FN | FP | TN | accuracy (its 95 % interval over the recordings) |",
        "|---|---|---|---|---|---|",
    ]
    for key, name in (("any_spike", "any-spike"), ("identified", "any-spike + identification")):
        rule = figures[key]
        (tp, fn), (fp, tn) = rule["confusion"]
        acc = percent_with_interval(rule["accuracy"], rule.get("accuracy_interval"), bold=True)
        lines.append(f"| {name} | {tp} | {fn} | {fp} | {tn} | {acc} |")
    drawn = [figures[k].get("accuracy_interval") for k in ("any_spike", "identified")]
    if "accuracy_lead" in figures:
        drawn.append(figures["accuracy_lead"].get("interval"))
    note = _no_interval_note(drawn, figures.get("recordings"))
    if note:
        lines.append(f"\n{note}.")
    if "accuracy_lead" in figures:
        lead = lead_text(figures["accuracy_lead"])
        lines.append(
            f"\nIdentification's lead over the any-spike rule: {lead} points of accuracy (its "
            "95 % interval when the recordings are drawn again, both rules on the same draws)."
        )
    lines += ["", "Called UAV, per class:\n", "| class | any-spike | + identification |"]
    lines.append("|---|---|---|")
    for cls, rate in figures["any_spike"]["per_class"].items():
        other = figures["identified"]["per_class"][cls]
        lines.append(f"| {cls} | {100 * rate:.1f} % | {100 * other:.1f} % |")
    if NONE_CLASS in figures["any_spike"]["per_class"]:
        lines.append(f"\n{NONE_TEXT}")
    roc = figures["roc"]
    points = figures["at_false_alarm"]
    if roc is None:
        lines.append(
            "\nThe windows are of one class only (all UAV, or none): no ROC, and no point "
            "read off one.\n"
        )
    else:
        lines.append(
            f"\nROC of the combined score: it ends at the any-spike rule's own false-alarm rate "
            f"({100 * roc['false_alarm'][-1]:.1f} %, detection "
            f"{100 * roc['detection'][-1]:.1f} %); area up to there {roc['area_reachable']:.3f}, "
            f"of at most {roc['false_alarm'][-1]:.3f} (every UAV window detected from the "
            "first false alarm on).\n"
        )
        lines += _operating_points(points, figures.get("recordings"))
    tuned = figures.get("at_tuned_false_alarm", [])
    if tuned:
        lines += [
            "\nAt thresholds set beforehand, where a share of the tuning recordings' UAV-free "
            "windows alarmed (`Identifier.alarm_thresholds`; what a user who fixes the "
            "operating point gets here). In brackets, the 95 % interval when this set's "
            "recordings are drawn again (`evaluation.recording_interval`): windows of one "
            "recording alarm together, so the recordings set how well a share is known"
            + _no_interval_note(
                [p.get(k) for p in tuned for k in ("false_alarm_interval", "detection_interval")],
                figures.get("recordings"),
                "; ",
            )
            + ".\n",
            f"| set for | threshold | false alarms here | detection here | detection here, "
            f"drones {TARGET_SIZE_TEXT} |",
            "|---|---|---|---|---|",
        ]
        lines += [
            f"| {100 * p['false_alarm_target']:g} % false alarms | {p['threshold']:.3f} | "
            f"{percent_with_interval(p['false_alarm_rate'], p.get('false_alarm_interval'))} | "
            f"{percent_with_interval(p['detection_rate'], p.get('detection_interval'))} | "
            f"{target_size_cell(p)} |"
            for p in tuned
        ]
        if all("false_alarms_per_class" in p for p in tuned):
            head = " | ".join(f"set for {100 * p['false_alarm_target']:g} %" for p in tuned)
            lines += ["", *_class_false_alarms(tuned, head)]
    return "\n".join(lines) + "\n"


def class_markdown(figures: dict[str, Any], at_points: list[dict[str, Any]] | None = None) -> str:
    """The class guess on the test objects whose class is known
    (:func:`uavsnn.identify.class_figures`' output): per true class, its objects, the share
    guessed right and what the rest were taken for; with ``at_points`` (the same figures at
    operating points set beforehand, each with its ``false_alarm_target``), the share guessed
    right at each point too."""
    if not figures["classes"]:
        return "No class model: the guess is uav or other.\n"
    if not figures["objects"]:
        return "No test object of a known class.\n"
    points = at_points or []
    balanced = figures["balanced_accuracy"]
    lines = [
        f"Class guess on the {figures['objects']} test objects of a known class (uav where the "
        "UAV score reaches the threshold, else the likeliest other class of a multinomial "
        "logistic regression on the same features; `uavsnn.identify.class_figures`): "
        f"{100 * figures['accuracy']:.1f} % right, balanced over the model's classes "
        f"{percent(balanced)}{' (none of them among these objects)' if balanced is None else ''}"
        + "".join(
            f"; at the threshold set for {100 * p['false_alarm_target']:g} % false alarms "
            f"{100 * p['accuracy']:.1f} %, balanced {percent(p['balanced_accuracy'])}"
            for p in points
        )
        + ".\n",
        "| class | objects | guessed right | taken most often for |"
        + "".join(f" right, set for {100 * p['false_alarm_target']:g} % |" for p in points),
        "|---|---|---|---|" + "---|" * len(points),
    ]
    for cls, row in figures["per_class"].items():
        wrong = {g: n for g, n in figures["confusion"][cls].items() if g != cls}
        most = max(wrong.items(), key=lambda kv: (kv[1], kv[0])) if wrong else None
        taken = "-" if most is None else f"{most[0]} ({100 * most[1] / row['objects']:.1f} %)"
        known = "" if cls in figures["classes"] else " (not a class of the model)"
        at = "".join(f" {100 * p['per_class'][cls]['recall']:.1f} % |" for p in points)
        lines.append(
            f"| {cls}{known} | {row['objects']} | {100 * row['recall']:.1f} % | {taken} |{at}"
        )
    return "\n".join(lines) + "\n"
