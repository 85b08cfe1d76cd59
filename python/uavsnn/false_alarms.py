"""False alarms over long UAV-free recording, as the streaming detector raises them (SPEC §5:
"false tracks per minute of UAV-free recording").

A test split holds about half a minute of UAV-free recording, too little to show a rate of
false tracks below several per minute (docs/identification.md, "Tuned on other seeds"). Here
fresh UAV-free dvs recordings are rendered — the datasets' own scenes (:func:`uav_free_scenes`:
"object" 70 %, "empty" 30 %), under a key no dataset split uses, so none is a recording a model
was trained or tuned on — and each is streamed through :class:`uavsnn.detector.Detector`
(``push_windows``: the tracker and identification as ``uavsnn detect`` runs them; a new stream
per recording). Per rule (:func:`alarm_rules`: the any-spike rule, identification at the
model's threshold and at each operating point set beforehand) it counts:

- windows that alarm (any-spike: the window is detected; with identification at a threshold:
  also its best object's UAV score reaches it), over every window of the recordings;
- tracks that alarm (any-spike: confirmed; with identification: confirmed while the running
  mean of the track's object scores reaches the threshold, as :mod:`uavsnn.track_eval`'s
  identified rule), per minute, with the 95 % upper bound
  (:func:`uavsnn.track_eval.poisson_upper`) and by the kind of the scene's object.

::

    figures = false_alarm_figures(network, minutes=10, seed=0)   # or runner=RayRunner()
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterator, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any, TypedDict

import numpy as np

from uavsnn._validate import check_int
from uavsnn.dataset.splits import DOMAIN_KEY, keyed_rng, keyed_seed
from uavsnn.distributed import SERIAL, Runner
from uavsnn.errors import ParameterError
from uavsnn.track_eval import (
    DEFAULT_CONFIRM,
    Confirm,
    at_rule,
    poisson_upper,
    rule_name,
    tracks_at_rule,
)

if TYPE_CHECKING:
    from uavsnn.dataset.synthetic import LabelledRecording
    from uavsnn.events import SensorSizeLike
    from uavsnn.grouping import WindowReport
    from uavsnn.identifier import Identifier
    from uavsnn.network import Network
    from uavsnn.scenes import Lens

__all__ = [
    "DEFAULT_CONFIRM",
    "FREE_KEY",
    "TRACK_ALARM_RATES",
    "TUNE_KEY",
    "AlarmCounts",
    "alarm_rules",
    "count_alarms",
    "false_alarm_figures",
    "false_alarm_table",
    "scene_batches",
    "scene_reports",
    "stream_batch",
    "stream_reports",
    "summarise",
    "track_alarm_threshold",
    "tune_track_alarms",
    "uav_free_scenes",
]

#: The key under a seed that no dataset split uses (``uavsnn.dataset.splits.SPLIT_KEY``: 1, 2).
FREE_KEY = 9
#: The key of the recordings track alarm thresholds are set on (:func:`tune_track_alarms`):
#: never :data:`FREE_KEY`'s, so a threshold is never measured on the recordings it was set on.
TUNE_KEY = 10
#: False tracks per minute that :func:`tune_track_alarms` sets thresholds for by default: the
#: target of SPEC §5's issue (one per 10 minutes) and ten times it.
TRACK_ALARM_RATES = (0.1, 1.0)
#: Recordings per unit of work (a Ray task).
BATCH = 20
#: Events per chunk pushed into the detector, as a live stream arrives in pieces.
CHUNK = 20_000
#: The most minutes of recording one call renders.
MAX_MINUTES = 600.0


def uav_free_scenes(seed: int, recordings: int, key: int = FREE_KEY) -> list[tuple[str, int]]:
    """The kind and seed of each UAV-free recording: ``"object"`` 70 %, ``"empty"`` 30 %, as a
    dataset draws its UAV-free scenes, keyed by ``(seed, dvs, key, ...)`` (:data:`FREE_KEY`
    for measuring, :data:`TUNE_KEY` for setting track alarm thresholds).

    Raises:
        ParameterError: ``seed``, ``recordings`` or ``key`` not an integer >= 0.
    """
    seed = check_int("seed", seed, 0)
    recordings = check_int("recordings", recordings, 0)
    key = check_int("key", key, 0)
    dkey = DOMAIN_KEY["dvs"]
    kinds = keyed_rng(seed, dkey, key, 0)
    out = []
    for i in range(recordings):
        kind = "object" if kinds.random() < 0.7 else "empty"
        out.append((kind, keyed_seed(seed, dkey, key, 1, i)))
    return out


def alarm_rules(
    network: Network, confirm: tuple[int, int] = DEFAULT_CONFIRM
) -> dict[str, float | None]:
    """Rule name -> threshold (``None``: the any-spike rule), named as
    :func:`uavsnn.track_eval.identified_track_figures` names them. The track alarm thresholds
    are rules only where they were set with the confirmation rule ``confirm`` the stream
    follows."""
    rules: dict[str, float | None] = {"any_spike": None}
    ident = network.identification
    if ident is not None:
        rules["identified"] = ident.threshold
        for rate, threshold in ident.alarm_thresholds:
            rules[at_rule(rate)] = threshold
        if tuple(ident.track_alarm_confirm) == tuple(confirm):
            for rate, threshold in ident.track_alarm_thresholds:
                rules[tracks_at_rule(rate)] = threshold
    return rules


class AlarmCounts(TypedDict):
    """What :func:`count_alarms` gives."""

    #: Per rule, the detected windows that alarm.
    alarming: dict[str, int]
    #: Per rule, the confirmed tracks that alarm.
    tracks: dict[str, int]
    #: Each confirmed, scored track's highest track score, largest first.
    track_peaks: list[float]
    #: Each detected window's highest object score, largest first.
    window_peaks: list[float]


def count_alarms(reports: Sequence[WindowReport], rules: dict[str, float | None]) -> AlarmCounts:
    """Per rule, the windows (``"alarming"``) and the tracks (``"tracks"``) that alarm among
    ``reports``, the windows of one stream; ``"track_peaks"``: for each confirmed track with a
    score, the highest :attr:`~uavsnn.grouping.WindowObject.track_score` it reached while
    confirmed in a detected window, largest first; and ``"window_peaks"``: each detected
    window's highest object score (windows without a scored object left out), largest first.
    With identification at a threshold ``θ``, the tracks and the windows that alarm are those
    whose peak reaches ``θ`` (:func:`track_alarm_threshold` reads a threshold off them)."""
    windows = dict.fromkeys(rules, 0)
    tracks: dict[str, set[int]] = {rule: set() for rule in rules}
    peaks: dict[int, float] = {}
    window_peaks: list[float] = []
    for report in reports:
        if not report.detected:
            continue
        scores = [o.uav_score for o in report.objects if o.uav_score is not None]
        if scores:
            window_peaks.append(max(scores))
        for rule, threshold in rules.items():
            if threshold is None or (scores and max(scores) >= threshold):
                windows[rule] += 1
        for o in report.objects:
            if o.track_id is None or not o.track_confirmed:
                continue
            score = o.track_score
            if score is not None:
                peaks[o.track_id] = max(peaks.get(o.track_id, -math.inf), score)
            for rule, threshold in rules.items():
                if threshold is None or (score is not None and score >= threshold):
                    tracks[rule].add(o.track_id)
    return {
        "alarming": windows,
        "tracks": {rule: len(ids) for rule, ids in tracks.items()},
        "track_peaks": sorted(peaks.values(), reverse=True),
        "window_peaks": sorted(window_peaks, reverse=True),
    }


def track_alarm_threshold(
    peaks: Sequence[float], minutes: float, rate: float, *, floor: float = 0.0
) -> float:
    """The lowest threshold at which at most ``rate`` false tracks per minute alarm over
    ``minutes`` of UAV-free recording whose confirmed tracks peaked at ``peaks``
    (:func:`count_alarms`): with ``k = floor(rate × minutes)``, just above the ``k + 1``-th
    highest peak, so that ``k`` tracks reach it; ``floor`` (every confirmed track alarms)
    when there are ``k`` tracks or fewer, and never below ``floor``: 0.0, the lowest UAV
    score, by default (``-inf`` for a statistic of any sign). A rate below one track over
    ``minutes`` (``k = 0``) asks that no track of them alarm.

    Raises:
        ParameterError: ``minutes`` or ``rate`` not positive and finite, ``peaks`` not a
            sequence of finite numbers, or ``floor`` not a number below ``inf``.
    """
    for name, value in (("minutes", minutes), ("rate", rate)):
        if not _real(value) or not (0 < value < math.inf):
            raise ParameterError(f"{name} must be positive and finite, got {value!r}")
    minutes, rate = float(minutes), float(rate)
    if not _real(floor) or not floor < math.inf:  # NaN too
        raise ParameterError(f"floor must be a number below inf (-inf: none), got {floor!r}")
    floor = float(floor)
    try:
        listed = list(peaks)
    except TypeError as exc:
        raise ParameterError(
            f"peaks must be a sequence of numbers, got {type(peaks).__name__}"
        ) from exc
    odd = [p for p in listed if not _real(p)]
    if odd:
        raise ParameterError(f"peaks must be a sequence of numbers, got one of {odd[0]!r}")
    values = sorted((float(p) for p in listed), reverse=True)
    if not all(math.isfinite(p) for p in values):
        raise ParameterError("track peaks must be finite")
    # The tolerance keeps a product such as 0.1 × 10 from falling just below its integer.
    k = math.floor(rate * minutes + 1e-9)
    if len(values) <= k:
        return floor
    return max(math.nextafter(values[k], math.inf), floor)


def _real(value: Any) -> bool:
    """Whether ``value`` is a real number (a NumPy one too; a ``bool`` is not)."""
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def stream_reports(
    network: Network,
    events: np.ndarray,
    sensor_size: SensorSizeLike,
    confirm: tuple[int, int] | None = None,
    *,
    window_us: int = 50_000,
    overlap: float = 0.5,
) -> list[WindowReport]:
    """The windows of one recording's ``events``, pushed in chunks of :data:`CHUNK` (as a live
    stream arrives) through a fresh :class:`~uavsnn.detector.Detector` starting at 0, tracked
    with the confirmation rule ``confirm`` ``(hits, windows)`` (default: the
    :class:`~uavsnn.tracks.Tracker`'s, 3 of 5) at the network's gate
    (:func:`uavsnn.tracks.tracker_for`)."""
    from uavsnn.detector import Detector
    from uavsnn.tracks import tracker_for

    tracker = None
    if confirm is not None:
        tracker = tracker_for(network, confirm_hits=confirm[0], confirm_windows=confirm[1])
    detector = Detector(
        network,
        window_us=window_us,
        overlap=overlap,
        sensor_size=sensor_size,
        start_us=0,
        tracker=tracker,
    )
    reports = []
    for start in range(0, len(events), CHUNK):
        reports += detector.push_windows(events[start : start + CHUNK])
    return reports + detector.flush_windows()


def scene_reports(
    network: Network,
    scenes: Sequence[tuple[str, int]],
    confirm: tuple[int, int] | None = None,
    lens: Lens | None = None,
) -> Iterator[tuple[LabelledRecording, list[WindowReport]]]:
    """Each scene of ``scenes`` (``(kind, seed)``, :func:`uav_free_scenes`) rendered as a dvs
    recording at the network's sensor size (through ``lens``, default a pinhole), and its
    :func:`stream_reports`."""
    from uavsnn.dataset.synthetic import default_source, synthetic_recording

    size = (int(network.config["width"]), int(network.config["height"]))
    source = replace(default_source("dvs", size), lens=lens)
    for kind, seed in scenes:
        lr = synthetic_recording(source, kind, seed)
        yield lr, stream_reports(network, lr.recording.events, size, confirm)


def stream_batch(
    network: Network,
    scenes: Sequence[tuple[str, int]],
    confirm: tuple[int, int] | None = None,
    lens: Lens | None = None,
) -> list[dict[str, Any]]:
    """Each scene of ``scenes`` rendered at the network's sensor size and streamed through a
    fresh detector: its object's kind, length, windows and :func:`count_alarms` (the unit of
    work of :func:`false_alarm_figures`). ``confirm`` ``(hits, windows)``: the tracker's
    confirmation rule (default: the :class:`~uavsnn.tracks.Tracker`'s, 3 of 5). ``lens``: the
    camera's (:class:`uavsnn.scenes.Lens`; default a pinhole, as the datasets by default)."""
    rules = alarm_rules(network, DEFAULT_CONFIRM if confirm is None else confirm)
    rows = []
    for lr, reports in scene_reports(network, scenes, confirm, lens):
        objects = lr.info.get("objects") or [{"kind": "none"}]
        rows.append(
            {
                "kind": str(objects[0]["kind"]),
                "seconds": lr.end_us / 1e6,
                "windows": len(reports),
                **count_alarms(reports, rules),
            }
        )
    return rows


def summarise(rows: Sequence[dict[str, Any]], rules: dict[str, float | None]) -> dict[str, Any]:
    """The figures of :func:`false_alarm_figures` from :func:`stream_batch`'s rows."""
    minutes = sum(r["seconds"] for r in rows) / 60
    windows = sum(r["windows"] for r in rows)
    out: dict[str, Any] = {
        "recordings": len(rows), "minutes": minutes, "windows": windows, "rules": {},
        "track_peaks": sorted((p for r in rows for p in r["track_peaks"]), reverse=True),
        "window_peaks": sorted((p for r in rows for p in r["window_peaks"]), reverse=True),
    }  # fmt: skip
    for rule, threshold in rules.items():
        false = sum(r["tracks"][rule] for r in rows)
        per_kind: dict[str, int] = {}
        for r in rows:
            if r["tracks"][rule]:
                per_kind[r["kind"]] = per_kind.get(r["kind"], 0) + r["tracks"][rule]
        out["rules"][rule] = {
            "threshold": threshold,
            "window_alarm_share": sum(r["alarming"][rule] for r in rows) / max(1, windows),
            "false_tracks": false,
            "false_tracks_per_minute": false / minutes if minutes else None,
            "false_tracks_per_minute_upper95": poisson_upper(false) / minutes if minutes else None,
            "recordings_with_a_false_track": sum(1 for r in rows if r["tracks"][rule]),
            "false_tracks_per_kind": dict(sorted(per_kind.items())),
        }
    return out


def scene_batches(minutes: float, seed: int, key: int = FREE_KEY) -> list[list[tuple[str, int]]]:
    """The :func:`uav_free_scenes` of ``minutes`` of recording (dvs scenes of 1 s) under
    ``key``, in units of :data:`BATCH` (what :func:`stream_batch` takes).

    Raises:
        ParameterError: ``minutes`` outside (0, :data:`MAX_MINUTES`] or a negative ``seed``.
    """
    from uavsnn.dataset.synthetic import default_source

    if not _real(minutes) or not 0 < minutes <= MAX_MINUTES:
        raise ParameterError(f"minutes must be in (0, {MAX_MINUTES:g}], got {minutes!r}")
    minutes = float(minutes)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed must be a non-negative integer, got {seed!r}")
    seconds = default_source("dvs").duration_s
    scenes = uav_free_scenes(seed, max(1, round(minutes * 60 / seconds)), key)
    return [scenes[i : i + BATCH] for i in range(0, len(scenes), BATCH)]


def _streamed_rows(
    network: Network,
    batches: list[list[tuple[str, int]]],
    confirm: tuple[int, int] | None,
    runner: Runner,
) -> list[dict[str, Any]]:
    """:func:`stream_batch`'s rows of every batch, in order, each batch a unit of work on
    ``runner``."""
    shared = runner.put(network)
    units = runner.imap(stream_batch, [(shared, batch, confirm) for batch in batches])
    return [row for unit in units for row in unit]


def false_alarm_figures(
    network: Network, *, minutes: float, seed: int = 0, runner: Runner = SERIAL
) -> dict[str, Any]:
    """The false alarms of ``network`` over ``minutes`` of fresh UAV-free recording (dvs scenes
    of 1 s at its sensor size; the module's docs give the rules), in units of :data:`BATCH`
    recordings on ``runner``. The same network, minutes and seed give the same figures on any
    runner.

    Raises:
        ParameterError: as :func:`scene_batches`.
    """
    rows = _streamed_rows(network, scene_batches(minutes, seed), None, runner)
    return summarise(rows, alarm_rules(network)) | {"seed": int(seed)}


def tune_track_alarms(
    network: Network,
    *,
    minutes: float,
    seed: int,
    rates: Sequence[float] = TRACK_ALARM_RATES,
    confirm: tuple[int, int] = DEFAULT_CONFIRM,
    runner: Runner = SERIAL,
) -> tuple[Identifier, dict[str, Any]]:
    """``network``'s identification with track alarm thresholds
    (:attr:`uavsnn.identify.Identifier.track_alarm_thresholds`) set for ``rates`` false tracks
    per minute on ``minutes`` of fresh UAV-free recording streamed as
    :func:`false_alarm_figures` streams it, but under :data:`TUNE_KEY`: recordings that
    :func:`false_alarm_figures` never measures, whatever the seeds
    (:func:`track_alarm_threshold` on the confirmed tracks' peak scores), the tracker
    confirming tracks by ``confirm`` ``(hits, windows)``, which the model records
    (:attr:`~uavsnn.identify.Identifier.track_alarm_confirm`). Returns the model (not
    attached) and a summary: ``seed``, ``minutes``, ``recordings``, ``confirmed_tracks``
    (those with a score), ``confirm`` (as text) and ``track_alarm_thresholds``.

    Raises:
        ParameterError: a network without identification, bad ``minutes``, ``seed`` or
            ``rates``.
    """
    from dataclasses import replace

    ident = network.identification
    if ident is None:
        raise ParameterError("track alarm thresholds need a network with identification")
    rates = [float(r) for r in rates]
    if not rates or not all(0 < r < math.inf for r in rates) or len(set(rates)) != len(rates):
        raise ParameterError(f"rates must be distinct, positive and finite, got {rates!r}")
    rule = Confirm.of_pair(confirm)
    confirm = rule.pair
    rows = _streamed_rows(network, scene_batches(minutes, seed, TUNE_KEY), confirm, runner)
    streamed = sum(r["seconds"] for r in rows) / 60
    peaks = [p for r in rows for p in r["track_peaks"]]
    pairs = tuple((rate, track_alarm_threshold(peaks, streamed, rate)) for rate in rates)
    tuned = replace(
        ident,
        track_alarm_thresholds=pairs,
        track_alarm_minutes=streamed,
        track_alarm_confirm=confirm,
    )
    summary = {
        "seed": int(seed),
        "minutes": streamed,
        "recordings": len(rows),
        "confirmed_tracks": len(peaks),
        "confirm": str(rule),
        "track_alarm_thresholds": [list(pair) for pair in pairs],
    }
    return tuned, summary


def false_alarm_table(figures: dict[str, Any]) -> str:
    """A Markdown table of :func:`false_alarm_figures` (or of :func:`summarise`'s figures,
    without a seed), one row per rule; ``–`` for a rate per minute of no recording."""
    lines = [
        "| rule | windows alarming | false tracks | per minute (95 % upper bound) | "
        "recordings with one | object kinds behind them |",
        "|---|---|---|---|---|---|",
    ]
    for rule, f in figures["rules"].items():
        kinds = ", ".join(f"{k} {n}" for k, n in f["false_tracks_per_kind"].items()) or "–"
        lines.append(
            f"| {rule_name(rule)} | {100 * f['window_alarm_share']:.2f} % | {f['false_tracks']} "
            f"| {_per_minute(f['false_tracks_per_minute'])} "
            f"({_per_minute(f['false_tracks_per_minute_upper95'])}) "
            f"| {f['recordings_with_a_false_track']} | {kinds} |"
        )
    lines.append("")
    seed = f" (seed {figures['seed']})" if "seed" in figures else ""
    lines.append(
        f"{figures['recordings']} UAV-free recordings{seed}, "
        f"{figures['minutes']:.2f} minutes, {figures['windows']} windows."
    )
    return "\n".join(lines)


def _per_minute(rate: float | None) -> str:
    """A rate per minute as :func:`false_alarm_table` prints it (``–``: no minutes)."""
    return "–" if rate is None else f"{rate:.2f}"
