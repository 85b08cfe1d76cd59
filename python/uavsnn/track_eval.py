"""Track-level evaluation (SPEC §5, "track level"): per recording, was the UAV found, when, and
how many tracks raised a false alarm.

The windows of each test recording are followed in time order, causally, as the streaming
:class:`uavsnn.detector.Detector` would follow them: :func:`uavsnn.features.window_features`
merges each window's conv3 spikes into objects and links them with a
:class:`uavsnn.tracks.Tracker` (a window the dataset left out counts as a window without a
detection). Each track then raises its alarm under two rules:

- **any-spike**: when the tracker confirms it (``confirm_hits`` of ``confirm_windows``);
- **identified**: at the first window where it is confirmed *and* the running mean of its
  objects' UAV scores so far (every object of the track up to and including that window)
  is at least the identifier's threshold. The mean, not the largest score: a track's
  objects are scored window by window, and the largest of many noisy scores grows with the
  track's length, so a long bird track would pass a threshold tuned on single windows; the
  running mean weighs every window the same and stays causal.

From the alarms (:func:`track_figures`):

- a UAV recording (one with a labelled UAV window) is **found** when an alarming track has,
  at or after its alarm, an object meeting the labelled UAV box of a UAV window; the **time
  to first alarm** is the end of the earliest such window minus the start of the
  recording's first labelled UAV window (the first window the UAV is labelled visible in for
  at least half of its time, not the UAV's first event), in event time: the first of every
  window the build cut from the recording (the manifest's ``first_uav_us``), not only of
  those the split kept (:func:`first_uav_starts`);
- a **false track** is an alarming track whose alarm window has no UAV; the rate divides
  them by the **UAV-free time**: the union of the recordings' UAV-free windows
  ``[t0, t0 + L)``. With few counts the one-sided 95 % Poisson upper bound is given beside;
- a **stray track** alarms in a UAV window but never meets the UAV from its alarm on;
- a recording is **decided** UAV when a track alarms in it, and decided right when that is
  whether it holds a UAV (:func:`decision_figures`).

    >>> figures = evaluate_tracks(network, test)          # test: a format-2 dataset split
    >>> print(track_table(figures))
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeGuard

import numpy as np

from uavsnn._validate import check_bools, check_real
from uavsnn.errors import ParameterError, ShapeError

if TYPE_CHECKING:
    from uavsnn.dataset import LabelledWindows
    from uavsnn.features import WindowFeatures
    from uavsnn.identifier import Identifier
    from uavsnn.network import Inference, Network
    from uavsnn.tracks import Tracker

__all__ = [
    "DEFAULT_CONFIRM",
    "RULES",
    "TRACK_SCORES",
    "UAV_WINDOW_TEXT",
    "Confirm",
    "at_rule",
    "box_meets",
    "clock_text",
    "confirm_flags",
    "decision_figures",
    "delay_stats_ms",
    "evaluate_tracks",
    "first_uav_starts",
    "identified_track_figures",
    "ms_text",
    "poisson_upper",
    "recording_class",
    "recording_names",
    "rule_name",
    "track_figures",
    "track_table",
    "tracks_at_rule",
]

#: The rules a track can alarm by, in the order they are reported.
RULES = ("any_spike", "identified")
#: What the identified rule can compare with the threshold: the running mean (the default) or
#: the running max of the track's object scores.
TRACK_SCORES = ("mean", "max")

_MINUTE_US = 60e6
#: The detector's confirmation rule, ``(hits, windows)``: :class:`Confirm`'s default (and the
#: :class:`uavsnn.tracks.Tracker`'s).
DEFAULT_CONFIRM = (3, 5)


@dataclass(frozen=True)
class Confirm:
    """A confirmation rule: a track is confirmed when it has hits in at least ``hits`` of its
    last ``windows`` windows (the :class:`uavsnn.tracks.Tracker`'s ``confirm_hits`` of
    ``confirm_windows``), or, with ``fast`` ``(hits, windows)`` and object scores, as soon as
    it has ``fast`` hits *and* the running mean UAV score of its objects so far reaches the
    identifier's threshold (the score-aware rule). Causal: it looks at the track's hits and
    scores up to the window at hand only.

    Text form (:meth:`parse`): ``"3/5"``, or ``"2/3+3/5"`` for the score-aware rule that
    confirms at 2 of 3 on a confident track and at 3 of 5 otherwise.
    """

    hits: int = DEFAULT_CONFIRM[0]
    windows: int = DEFAULT_CONFIRM[1]
    fast: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        pairs = [(self.hits, self.windows)] + ([self.fast] if self.fast is not None else [])
        for pair in pairs:
            if not (isinstance(pair, tuple) and len(pair) == 2):
                raise ParameterError(f"a confirmation rule is (hits, windows), got {pair!r}")
            h, w = pair
            for v in (h, w):
                if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
                    raise ParameterError(f"hits and windows must be integers, got {pair!r}")
            if not 1 <= h <= w <= 64:
                raise ParameterError(
                    f"a confirmation rule needs 1 <= hits <= windows <= 64, got {h}/{w}"
                )

    @classmethod
    def of_pair(cls, pair: Any) -> Confirm:
        """The plain rule of a ``(hits, windows)`` pair, checked as any rule is.

        Raises:
            ParameterError: not a pair of integers with 1 <= hits <= windows <= 64.
        """
        if not (isinstance(pair, tuple) and len(pair) == 2):
            raise ParameterError(f"a confirmation rule is (hits, windows), got {pair!r}")
        return cls(*pair)

    @property
    def pair(self) -> tuple[int, int]:
        """``(hits, windows)`` as plain integers."""
        return (int(self.hits), int(self.windows))

    @classmethod
    def parse(cls, text: str) -> Confirm:
        """``"M/N"`` or ``"F/G+M/N"`` (score-aware: ``F`` of ``G`` on a confident track)."""
        parts = str(text).strip().split("+")
        pairs = []
        for part in parts:
            bits = part.strip().split("/")
            if len(bits) != 2 or not all(b.strip().isdigit() for b in bits):
                raise ParameterError(
                    f"a confirmation rule is HITS/WINDOWS (e.g. 3/5) or FAST+HITS/WINDOWS "
                    f"(e.g. 2/3+3/5), got {text!r}"
                )
            pairs.append((int(bits[0]), int(bits[1])))
        if len(pairs) == 1:
            return cls(*pairs[0])
        if len(pairs) == 2:
            return cls(*pairs[1], fast=pairs[0])
        raise ParameterError(f"a confirmation rule has at most one '+', got {text!r}")

    def __str__(self) -> str:
        base = f"{self.hits}/{self.windows}"
        return base if self.fast is None else f"{self.fast[0]}/{self.fast[1]}+{base}"


def confirm_flags(
    steps: np.ndarray,
    rule: Confirm,
    mean_scores: np.ndarray | None = None,
    threshold: float | None = None,
) -> np.ndarray:
    """Whether a track is confirmed after each of its hits under ``rule``: ``steps`` the
    window indices of its objects in stream order (one object per window, increasing),
    ``mean_scores`` the running mean UAV score after each (for the score-aware part, with
    ``threshold``). The same as the :class:`uavsnn.tracks.Tracker`'s ``confirmed`` for a plain
    rule (confirmation is a function of the hit windows only; linking never looks at it)."""
    steps = np.asarray(steps, dtype=np.int64)
    if np.any(np.diff(steps) <= 0):
        raise ParameterError("a track's hit windows must increase (one object per window)")
    if (mean_scores is None) != (threshold is None):
        raise ParameterError("give both mean_scores and threshold, or neither")
    limit = math.inf if threshold is None else float(threshold)
    out = np.zeros(len(steps), dtype=bool)
    confirmed = False
    for n in range(len(steps)):
        if not confirmed:
            s = steps[n]
            # Hits in the last W windows: those of steps[: n + 1] (increasing) above s - W.
            inside = n + 1 - int(np.searchsorted(steps[: n + 1], s - rule.windows, "right"))
            confirmed = inside >= rule.hits
            if not confirmed and rule.fast is not None and mean_scores is not None:
                fast = n + 1 - int(np.searchsorted(steps[: n + 1], s - rule.fast[1], "right"))
                confirmed = fast >= rule.fast[0] and float(mean_scores[n]) >= limit
        out[n] = confirmed
    return out


def poisson_upper(count: int, confidence: float = 0.95) -> float:
    """The one-sided upper confidence bound on a Poisson mean after observing ``count``
    events: the mean at which ``count`` or fewer events have probability ``1 - confidence``
    (for 0 events at 95 %: 2.996, the "rule of three").

    Raises:
        ParameterError: ``count`` not an integer >= 0 or ``confidence`` not a number in
            (0, 1).
    """
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 0:
        raise ParameterError(f"count must be an integer >= 0, got {count!r}")
    confidence = check_real("confidence", confidence)
    if not 0.0 < confidence < 1.0:
        raise ParameterError(f"confidence must be in (0, 1), got {confidence}")
    alpha = 1.0 - confidence
    k = np.arange(int(count) + 1, dtype=np.float64)
    log_factorial = np.array([math.lgamma(v + 1.0) for v in k])

    def cdf(lam: float) -> float:
        # In logs: exp(-lam) alone underflows to 0 from lam ~ 745 (about 700 events).
        if lam <= 0.0:
            return 1.0
        terms = -lam + k * math.log(lam) - log_factorial
        top = float(terms.max())
        return math.exp(top) * float(np.exp(terms - top).sum())

    lo, hi = 0.0, 10.0 + 10.0 * count
    for _ in range(200):
        mid = (lo + hi) / 2
        if cdf(mid) > alpha:
            lo = mid
        else:
            hi = mid
    return (lo + hi) / 2


def box_meets(box: np.ndarray, truth: np.ndarray) -> bool:
    """A half-open object box meets a labelled box (NaN: no labelled object)."""
    return bool(
        np.isfinite(truth).all()
        and box[0] < truth[2]
        and truth[0] < box[2]
        and box[1] < truth[3]
        and truth[1] < box[3]
    )


def _union_us(starts: np.ndarray, length: int) -> int:
    """The total length of the union of the intervals ``[s, s + length)``."""
    total, end = 0, None
    for s in np.sort(starts).tolist():
        if end is None or s >= end:
            total += length
        else:
            total += s + length - end
        end = s + length
    return total


def delay_stats_ms(values_us: list[int]) -> dict[str, float | int | None]:
    """``n``, ``median``, ``p90`` and ``max`` of delays in µs, in ms (``None`` without any)."""
    if not values_us:
        return {"n": 0, "median": None, "p90": None, "max": None}
    v = np.asarray(values_us, dtype=np.float64) / 1000
    return {
        "n": len(v),
        "median": float(np.median(v)),
        "p90": float(np.percentile(v, 90)),
        "max": float(v.max()),
    }


def decision_figures(
    uav: Sequence[bool] | np.ndarray,
    alarmed: Sequence[bool] | np.ndarray,
    classes: Sequence[str] | np.ndarray,
) -> dict[str, Any]:
    """The decision on whole recordings (or clips), one entry each: decided UAV where a track
    alarmed in it (``alarmed``), right where that is whether it holds a UAV (``uav``).
    Returns ``right`` (how many), ``accuracy``, ``uav_alarmed`` (UAV recordings decided UAV),
    ``other_quiet`` (the others decided not), ``balanced_accuracy`` (the mean of the two
    shares, of the kinds present; ``None`` with no recording) and ``per_class`` (by
    ``classes``: ``recordings`` and ``decided_uav``).

    Raises:
        ShapeError: sequences of different lengths (or not 1-D).
        ParameterError: ``uav`` or ``alarmed`` not boolean.
    """
    truth = check_bools("uav", uav)
    said = check_bools("alarmed", alarmed)
    names = np.asarray(classes)
    if names.ndim != 1:
        raise ShapeError(f"classes must be 1-D, got shape {names.shape}")
    if not len(truth) == len(said) == len(names):
        raise ShapeError("uav, alarmed and classes must have one entry per recording")
    shares = []
    if truth.any():
        shares.append(float(said[truth].mean()))
    if (~truth).any():
        shares.append(float((~said[~truth]).mean()))
    per_class: dict[str, dict[str, int]] = {}
    for name, decided in zip(classes, said.tolist(), strict=True):
        row = per_class.setdefault(str(name), {"recordings": 0, "decided_uav": 0})
        row["recordings"] += 1
        row["decided_uav"] += int(decided)
    right = int((truth == said).sum())
    return {
        "right": right,
        "accuracy": right / len(truth) if len(truth) else None,
        "uav_alarmed": int((truth & said).sum()),
        "other_quiet": int((~truth & ~said).sum()),
        "balanced_accuracy": float(np.mean(shares)) if shares else None,
        "per_class": dict(sorted(per_class.items())),
    }


def recording_class(classes: np.ndarray) -> str:
    """A recording's class: the one most often among ``classes`` (the labels of its windows,
    or of its frames) other than ``"none"`` (``"none"`` when there is no other)."""
    names, counts = np.unique(classes[classes != "none"], return_counts=True)
    return str(names[np.argmax(counts)]) if len(names) else "none"


def first_uav_starts(data: LabelledWindows) -> tuple[dict[int, int], bool]:
    """Each UAV recording of ``data`` (one with a UAV window in it) and the start of its first
    UAV window, where the time to first alarm starts: the manifest's ``first_uav_us`` (the
    first usable UAV window among every window the build cut from the recording), else the
    first UAV window the split kept, which may be a step or more later (a split keeps only
    some of a recording's steps). Returns the starts and whether every one came from the
    manifest (datasets built before it carried ``first_uav_us`` do not)."""
    label = np.asarray(data.label, dtype=bool)
    rec = np.asarray(data.recording, dtype=np.int64)
    t0 = np.asarray(data.windows.t0, dtype=np.int64)
    entries = data.manifest.get("recordings")
    built = {
        r["id"]: r.get("first_uav_us")
        for r in (entries if isinstance(entries, list) else [])
        if isinstance(r, dict) and _is_int(r.get("id"))
    }
    starts: dict[int, int] = {}
    every = True
    for r in np.unique(rec[label]).tolist():
        kept = int(t0[(rec == r) & label].min())
        first = built.get(r)
        if _is_int(first):
            starts[r] = min(first, kept)
        else:
            starts[r], every = kept, False
    return starts, every


def recording_names(data: LabelledWindows) -> dict[int, str]:
    """Each recording's name in ``data``'s manifest (``recordings[]``: a real clip's file
    name, ``V_DRONE_026``; a rendered recording's ``dvs-test-00012``), by its id; a recording
    the manifest does not name is left out."""
    entries = data.manifest.get("recordings") if isinstance(data.manifest, dict) else None
    return {
        r["id"]: r["name"]
        for r in (entries if isinstance(entries, list) else [])
        if isinstance(r, dict) and _is_int(r.get("id")) and isinstance(r.get("name"), str)
    }


def _is_int(value: object) -> TypeGuard[int]:
    """A JSON integer (not a bool)."""
    return isinstance(value, int) and not isinstance(value, bool)


def track_figures(
    data: LabelledWindows,
    feats: WindowFeatures,
    scores: np.ndarray | None = None,
    threshold: float | None = None,
    *,
    track_score: str = "mean",
    confirm: Confirm | None = None,
) -> dict[str, Any]:
    """The track-level figures of the windows ``data`` whose tracked objects are ``feats``
    (:func:`uavsnn.features.window_features` of the same windows: ``window``, ``boxes``,
    ``track`` and ``confirmed`` are used). ``scores`` ``(m,)``: each object's UAV score, and
    ``threshold`` the identifier's; without them only the any-spike rule is reported.
    ``track_score``: what the identified rule compares with the threshold, the running
    ``"mean"`` of the track's object scores (the default) or their running ``"max"``.
    ``confirm``: the confirmation rule (:class:`Confirm`) to apply to the tracks' hits instead
    of the ``confirmed`` flags the tracker set (its score-aware part needs ``scores``); the
    figures carry ``confirm``, the rule as text: ``str(confirm)``, or with ``None`` the
    tracker's default :data:`DEFAULT_CONFIRM` (``"3/5"``), whose flags ``feats`` are taken to
    hold, as :func:`identified_track_figures` takes them (:func:`evaluate_tracks` records
    the rule of a ``tracker`` it is given).

    Returns a plain dict (JSON-ready): ``windows``, ``recordings``, ``uav_recordings``,
    ``step_us``, ``window_us``, ``window_coverage`` (the windows present over the steps
    their recordings span), ``alarm_clock`` (where the time to first alarm starts:
    ``"recording"``, each recording's first UAV window of all it was cut into, or ``"kept
    windows"``, the first the split kept, for a dataset whose manifest does not carry it;
    :func:`first_uav_starts`), ``uav_free_minutes``, ``rules`` (per rule of :data:`RULES`:
    ``found``, ``found_rate``, ``missed`` (recording ids), ``time_to_alarm_ms`` (``n``,
    ``median``, ``p90``, ``max``), ``alarming_tracks``, ``false_tracks``,
    ``false_tracks_per_class`` (by the class labelled in the alarm window),
    ``false_tracks_per_minute``, ``false_tracks_per_minute_upper95``, ``stray_tracks``, and
    ``decided``: the recordings decided right, :func:`decision_figures`, a recording decided
    UAV where a track alarmed in it, of the class labelled most often in it) and
    ``per_recording`` (one row per recording: ``recording``, its id, and ``name``, its name in
    the dataset's manifest or ``None`` (:func:`recording_names`), with ``uav_windows_met``: its
    UAV windows where an object meets the labelled box, and ``uav_size_px``: the median
    labelled UAV size).

    Raises:
        ShapeError: ``feats`` or ``scores`` that do not fit ``data``.
        ParameterError: ``scores`` without ``threshold`` or the other way round.
        DatasetError: windows that cannot form streams (:func:`uavsnn.features.window_steps`).
    """
    from uavsnn.features import window_steps

    if feats.windows != len(data):
        raise ShapeError(f"the features are of {feats.windows} windows, the data has {len(data)}")
    m = len(feats.window)
    if len(feats.track) != m or len(feats.confirmed) != m or len(feats.boxes) != m:
        raise ShapeError("the features carry no tracks: make them with identify.window_features")
    if (scores is None) != (threshold is None):
        raise ParameterError("give both scores and threshold, or neither")
    if scores is not None:
        scores = np.asarray(scores, dtype=np.float64)
        if scores.shape != (m,):
            raise ShapeError(f"scores must be ({m},), got {scores.shape}")
    if track_score not in TRACK_SCORES:
        raise ParameterError(f"track_score must be one of {TRACK_SCORES}, got {track_score!r}")
    if confirm is not None and not isinstance(confirm, Confirm):
        raise ParameterError(f"confirm must be a track_eval.Confirm, got {confirm!r}")
    rules = RULES if scores is not None else RULES[:1]
    limit = math.inf if threshold is None else float(threshold)
    order, step = window_steps(data)
    window_us = int(data.windows.length_us)
    t0 = np.asarray(data.windows.t0, dtype=np.int64)
    t1 = t0 + window_us
    label = np.asarray(data.label, dtype=bool)
    cls = np.asarray(data.cls)
    rec = np.asarray(data.recording, dtype=np.int64)
    truth = np.asarray(data.box, dtype=np.float64)
    position = np.empty(len(data), dtype=np.int64)
    position[order] = np.arange(len(data))

    # Each track's objects in stream order (objects of one window keep their order).
    obj_order = np.lexsort((np.arange(m), position[feats.window]))
    tracks: dict[tuple[int, int], list[int]] = {}
    for j in obj_order.tolist():
        tid = int(feats.track[j])
        if tid:
            tracks.setdefault((int(rec[feats.window[j]]), tid), []).append(j)

    recordings = np.unique(rec).tolist()
    first_uav, from_manifest = first_uav_starts(data)
    found: dict[str, dict[int, int]] = {rule: {} for rule in rules}
    false: dict[str, dict[int, list[str]]] = {rule: {r: [] for r in recordings} for rule in rules}
    stray = dict.fromkeys(rules, 0)
    alarming = dict.fromkeys(rules, 0)
    alarmed: dict[str, set[int]] = {rule: set() for rule in rules}
    first_t0 = {r: int(t0[rec == r].min()) for r in np.unique(rec).tolist()}
    for (r, _tid), objs in tracks.items():
        alarm: dict[str, int | None] = dict.fromkeys(rules, None)
        if confirm is None:
            confirmed = feats.confirmed[objs]
        else:
            steps = (t0[feats.window[objs]] - first_t0[r]) // step
            means = None
            if scores is not None:
                means = np.cumsum(scores[objs]) / np.arange(1, len(objs) + 1)
            confirmed = confirm_flags(steps, confirm, means, threshold)
        total, best = 0.0, -math.inf
        for n, j in enumerate(objs, start=1):
            if scores is not None:
                total += float(scores[j])
                best = max(best, float(scores[j]))
            if not confirmed[n - 1]:
                continue
            if alarm["any_spike"] is None:
                alarm["any_spike"] = n - 1
            score = total / n if track_score == "mean" else best
            if scores is not None and alarm["identified"] is None and score >= limit:
                alarm["identified"] = n - 1
        for rule, a in alarm.items():
            if a is None:
                continue
            alarming[rule] += 1
            alarmed[rule].add(r)
            w = int(feats.window[objs[a]])
            on_uav = [
                int(t1[feats.window[j]])
                for j in objs[a:]
                if label[feats.window[j]] and box_meets(feats.boxes[j], truth[feats.window[j]])
            ]
            if on_uav:
                found[rule][r] = min(found[rule].get(r, on_uav[0]), on_uav[0])
            if not label[w]:
                false[rule][r].append(str(cls[w]))
            elif not on_uav:
                stray[rule] += 1

    free_us = {r: _union_us(t0[(rec == r) & ~label], window_us) for r in recordings}
    free_minutes = sum(free_us.values()) / _MINUTE_US
    span = {r: int((t0[rec == r].max() - t0[rec == r].min()) // step + 1) for r in recordings}
    out: dict[str, Any] = {
        "windows": len(data),
        "recordings": len(recordings),
        "uav_recordings": len(first_uav),
        "step_us": step,
        "window_us": window_us,
        "window_coverage": len(data) / sum(span.values()) if recordings else 0.0,
        "alarm_clock": "recording" if from_manifest else "kept windows",
        "uav_free_minutes": free_minutes,
        "confirm": str(confirm or Confirm.of_pair(DEFAULT_CONFIRM)),
        "rules": {},
    }
    kind = {r: recording_class(cls[rec == r]) for r in recordings}
    for rule in rules:
        delays = [found[rule][r] - first_uav[r] for r in first_uav if r in found[rule]]
        per_class: dict[str, int] = {}
        for names in false[rule].values():
            for name in names:
                per_class[name] = per_class.get(name, 0) + 1
        n_false = sum(per_class.values())
        out["rules"][rule] = {
            "found": len(delays),
            "found_rate": len(delays) / len(first_uav) if first_uav else None,
            "missed": [r for r in first_uav if r not in found[rule]],
            "time_to_alarm_ms": delay_stats_ms(delays),
            "alarming_tracks": alarming[rule],
            "false_tracks": n_false,
            "false_tracks_per_class": dict(sorted(per_class.items())),
            "false_tracks_per_minute": n_false / free_minutes if free_minutes else None,
            "false_tracks_per_minute_upper95": (
                poisson_upper(n_false) / free_minutes if free_minutes else None
            ),
            "stray_tracks": stray[rule],
            "decided": decision_figures(
                [r in first_uav for r in recordings],
                [r in alarmed[rule] for r in recordings],
                [kind[r] for r in recordings],
            ),
        }
    # UAV windows with an object on the UAV (the tracker's raw material), per recording.
    met = np.zeros(len(data), dtype=bool)
    for j in range(m):
        w = int(feats.window[j])
        if label[w] and not met[w] and box_meets(feats.boxes[j], truth[w]):
            met[w] = True
    size = np.asarray(data.size_px, dtype=np.float64)
    named = recording_names(data)
    rows = []
    for r in recordings:
        mine = rec == r
        sizes = size[mine & label]
        sizes = sizes[np.isfinite(sizes)]
        kinds, counts = np.unique(cls[mine], return_counts=True)
        row: dict[str, Any] = {
            "recording": r,
            "name": named.get(r),
            "windows": int(mine.sum()),
            "steps": span[r],
            "uav_windows": int((mine & label).sum()),
            "classes": {str(k): int(v) for k, v in zip(kinds, counts, strict=True)},
            "uav_free_ms": free_us[r] / 1000,
            "uav_windows_met": int((mine & met).sum()),
            "uav_size_px": float(np.median(sizes)) if len(sizes) else None,
        }
        for rule in rules:
            row[rule] = {
                "found": r in found[rule] if r in first_uav else None,
                "time_to_alarm_ms": (
                    (found[rule][r] - first_uav[r]) / 1000 if r in found[rule] else None
                ),
                "false_tracks": len(false[rule][r]),
            }
        rows.append(row)
    out["per_recording"] = rows
    return out


def evaluate_tracks(
    network: Network,
    data: LabelledWindows,
    inference: Inference | None = None,
    *,
    features: WindowFeatures | None = None,
    tracker: Tracker | None = None,
    track_score: str = "mean",
    confirm: Confirm | None = None,
) -> dict[str, Any]:
    """:func:`track_figures` of ``network`` on ``data`` (a format-2 dataset split): its objects
    and tracks (``features`` when already made, else :func:`uavsnn.features.window_features`
    with ``tracker``), and with the network's identification (when it has one) both rules.
    Without ``confirm`` the figures' ``confirm`` is the rule of the tracker that made the
    features: ``tracker``'s when it made them here, else the default 3 of 5."""
    from uavsnn.features import window_features

    made_by = None
    if features is None:
        features = window_features(network, data, inference, tracker=tracker)
        if tracker is not None:
            made_by = Confirm(tracker.confirm_hits, tracker.confirm_windows)
    figures = identified_track_figures(
        data, features, network.identification, track_score=track_score, confirm=confirm
    )
    if confirm is None and made_by is not None:
        figures["confirm"] = str(made_by)
    return figures


def identified_track_figures(
    data: LabelledWindows,
    feats: WindowFeatures,
    identifier: Identifier | None,
    *,
    track_score: str = "mean",
    confirm: Confirm | None = None,
    operating_points: bool = True,
) -> dict[str, Any]:
    """:func:`track_figures` of both rules, with ``identifier``'s scores of ``feats`` and its
    threshold (:class:`uavsnn.identify.Identifier`, whose features ``feats`` holds), and with
    ``operating_points`` of the identified rule at each of its operating points set beforehand
    (:attr:`~uavsnn.identify.Identifier.alarm_thresholds`; rule :func:`at_rule` of the share,
    and :attr:`~uavsnn.identify.Identifier.track_alarm_thresholds`; rule
    :func:`tracks_at_rule` of the rate, where ``confirm`` (``None``: the tracker's 3 of 5, as
    ``feats`` were made) is the rule they were set with); with ``identifier`` ``None``, of the
    any-spike rule alone."""
    if identifier is None:
        return track_figures(data, feats, confirm=confirm)
    scores = identifier.scores(feats.x)
    figures = track_figures(
        data, feats, scores, identifier.threshold, track_score=track_score, confirm=confirm
    )
    points = [(at_rule(rate), t) for rate, t in identifier.alarm_thresholds]
    # The track points hold for the confirmation rule they were set with only.
    in_force = DEFAULT_CONFIRM if confirm is None else confirm.pair
    if (confirm is None or confirm.fast is None) and in_force == identifier.track_alarm_confirm:
        points += [(tracks_at_rule(rate), t) for rate, t in identifier.track_alarm_thresholds]
    for rule, threshold in points if operating_points else ():
        at = track_figures(data, feats, scores, threshold, track_score=track_score, confirm=confirm)
        figures["rules"][rule] = at["rules"]["identified"]
    return figures


_RULE_NAMES = {"any_spike": "any-spike", "identified": "any-spike + identification"}
_AT = "identified_at_"
_TRACKS_AT = "identified_tracks_at_"


def at_rule(rate: float) -> str:
    """The name of the identified rule at the threshold set for a false-alarm share ``rate``
    (:attr:`uavsnn.identify.Identifier.alarm_thresholds`): ``"identified_at_0.01"`` for 1 %."""
    return f"{_AT}{rate:g}"


def tracks_at_rule(rate: float) -> str:
    """The name of the identified rule at the threshold set for ``rate`` false tracks per
    minute (:attr:`uavsnn.identify.Identifier.track_alarm_thresholds`):
    ``"identified_tracks_at_0.1"``."""
    return f"{_TRACKS_AT}{rate:g}"


def rule_name(rule: str) -> str:
    """How a rule of :func:`track_figures` (or :func:`identified_track_figures`, or
    :func:`at_rule`, or :func:`tracks_at_rule`) is named in tables."""
    if rule.startswith(_AT):
        return f"+ identification, set for {100 * float(rule[len(_AT) :]):g} % false alarms"
    if rule.startswith(_TRACKS_AT):
        rate = float(rule[len(_TRACKS_AT) :])
        tracks = "false track" if rate == 1 else "false tracks"
        return f"+ identification, set for {rate:g} {tracks} per minute"
    return _RULE_NAMES.get(rule, rule)


def _fmt(value: float | None, digits: int = 0) -> str:
    return "–" if value is None else f"{value:,.{digits}f}"


def ms_text(value: float | None) -> str:
    """A delay in ms as the reports print it: to a tenth, without a trailing ``.0`` (a median
    of two 25 ms steps, 137.5, stays 137.5 instead of rounding to the even 138, as 612.5 would
    to 612); ``–`` for none.

    Raises:
        ParameterError: ``value`` neither ``None`` nor a finite number.
    """
    return _fmt(None if value is None else check_real("value", value), 1).removesuffix(".0")


def _decided(d: dict[str, Any], recordings: int) -> str:
    """``"41 of 67 (61.2 %)"``: the recordings decided right and their share of all; then,
    in a column of its own, the balanced accuracy (``–`` where it is none)."""
    share = f" ({100 * d['right'] / recordings:.1f} %)" if recordings else ""
    balanced = d["balanced_accuracy"]
    return f"{d['right']} of {recordings}{share} | " + (
        "–" if balanced is None else f"{100 * balanced:.1f} %"
    )


def track_table(figures: dict[str, Any]) -> str:
    """A Markdown table of :func:`track_figures`' figures, one row per rule."""
    minutes = figures["uav_free_minutes"]
    lines = [
        "| rule | UAV recordings found | time to first alarm from the first UAV window, median "
        "/ 90th pct (ms) | false tracks | per minute of UAV-free recording (95 % upper bound) "
        "| stray tracks | recordings decided right | balanced accuracy |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for rule, f in figures["rules"].items():
        t = f["time_to_alarm_ms"]
        lines.append(
            f"| {rule_name(rule)} | {f['found']} of {figures['uav_recordings']} "
            f"| {ms_text(t['median'])} / {ms_text(t['p90'])} | {f['false_tracks']} "
            f"| {_fmt(f['false_tracks_per_minute'], 2)} "
            f"({_fmt(f['false_tracks_per_minute_upper95'], 2)}) | {f['stray_tracks']} "
            f"| {_decided(f['decided'], figures['recordings'])} |"
        )
    lines.append("")
    lines.append(
        f"{figures['recordings']} recordings, {figures['windows']} windows "
        f"({100 * figures['window_coverage']:.1f} % of the steps they span), "
        f"{60 * minutes:.2f} s of UAV-free recording; {clock_text(figures)}. A false track "
        "alarms in a window without a UAV, a UAV recording's UAV-free windows included (the "
        "streamed clips of `uavsnn evaluate --clips` count the clips without a UAV only)."
    )
    return "\n".join(lines)


#: What a UAV window is, where the time to first alarm starts (:func:`clock_text`).
UAV_WINDOW_TEXT = (
    "a UAV window has the UAV labelled visible for at least half of its time, so the clock "
    "does not start at the UAV's first event"
)


def clock_text(figures: dict[str, Any]) -> str:
    """Where :func:`track_figures`' time to first alarm starts and ends, in words."""
    if figures.get("alarm_clock") == "recording":
        start = (
            "the time to first alarm runs from each recording's first UAV window (its start; "
            "the first of all the windows the build cut from the recording"
        )
    else:
        start = (
            "the time to first alarm runs from the first UAV window the split kept, which may "
            "be a step or more after the recording's first (its start; the dataset's manifest "
            "does not give the first: build the dataset again"
        )
    return (
        f"{start}; {UAV_WINDOW_TEXT}) to the end of the window where an alarming track first "
        "meets the UAV"
    )
