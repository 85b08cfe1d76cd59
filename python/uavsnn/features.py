"""The objects identification describes, and their features (SPEC §3).

Each window's conv3 detections are merged into objects (:func:`uavsnn.grouping.merge_boxes`,
as :class:`uavsnn.grouping.WindowGrouper` groups them in the streaming path, so batch and
streaming see the same boxes). Each object is described by :data:`FEATURES`, measured on the
window's raw events (``[t0, t0 + L)``) inside its box:

- rotor: the rotor signature (:func:`uavsnn.signature.rotor_signature`) — frequency, strength
  and agreeing pixels, log-scaled, and whether it passed the estimator's threshold;
- shape: the box's width, height, area (log), aspect ratio (log) and conv3 spike count (log);
- activity: raw events per pixel of the box (log), the ON/OFF balance and how strongly the
  box's event rate swings within the window (:func:`rate_swing`, log);
- track: the statistics of the object's track so far (:data:`TRACK_FEATURES`): the windows of
  each recording are fed in time order to a :class:`uavsnn.tracks.Tracker`, as the streaming
  :class:`uavsnn.detector.Detector` feeds them (a window missing from the dataset counts as a
  miss), and each object reads its track as it stands after its own window (causal).

For training, :func:`window_features` also labels each object (a UAV object, its class, or
unusable) from its window's labelled box. :mod:`uavsnn.identify` fits and applies the model on
these features, and re-exports every name of this module.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from uavsnn import _core
from uavsnn.boxes import corners, xywh
from uavsnn.errors import DatasetError, ParameterError, ShapeError
from uavsnn.signature import RotorEstimate, measure_box
from uavsnn.windows import noise_per_window

if TYPE_CHECKING:
    from uavsnn.dataset import LabelledWindows
    from uavsnn.network import Inference, Network
    from uavsnn.tracks import Track, Tracker

__all__ = [
    "CLUTTER_CLASS",
    "FEATURES",
    "MAX_MEASURED_WINDOW_US",
    "RATE_BIN_US",
    "TRACK_ACTIVITY",
    "TRACK_FEATURES",
    "UAV_CLASS",
    "WindowFeatures",
    "activity",
    "object_features",
    "rate_bins",
    "rate_swing",
    "raw_noise_events",
    "track_features",
    "window_features",
    "window_steps",
]

#: The class guess of an object called a UAV, and the class of a UAV object in training.
UAV_CLASS = "uav"

#: The training class of an object in a window without a labelled object (dataset class
#: ``"none"``): something moved that is not a labelled object (texture, noise, a leaf's shadow).
CLUTTER_CLASS = "clutter"

#: The track's activity history (the last of :data:`TRACK_FEATURES`): the mean and standard
#: deviation of its objects' raw events per pixel, and the mean of their ON/OFF balance and rate
#: swing, each as :func:`activity` gives them for one object.
TRACK_ACTIVITY: tuple[str, ...] = (
    "track_log_events_per_px",
    "track_log_events_per_px_std",
    "track_on_balance",
    "track_log_rate_swing",
)

#: The track group of :data:`FEATURES` (:func:`track_features`), from the object's track as it
#: stands after its window (:class:`uavsnn.tracks.Track`).
TRACK_FEATURES: tuple[str, ...] = (
    "track_log_age_ms",
    "track_log_hits",
    "track_log_speed",
    "track_straightness",
    "track_log_turn_rate",
    "track_log_speed_std",
    "track_vertical_speed",
    "track_rotor_strength",
    *TRACK_ACTIVITY,
)

#: The width of the bins in which an object's events are counted over its window, µs
#: (:func:`rate_swing`): ten bins over the default 50 ms window.
RATE_BIN_US = 5000
#: The most bins the engine counts a box's rate in (``rust/signature/rate.rs``), so the
#: longest window whose objects are measured is ``MAX_RATE_BINS * RATE_BIN_US``, 20.48 s.
MAX_RATE_BINS = 4096
#: The longest window whose objects are measured, µs (:data:`MAX_RATE_BINS` bins of
#: :data:`RATE_BIN_US`): the limit the Detector and ``uavsnn detect --window-ms`` refuse past.
MAX_MEASURED_WINDOW_US = MAX_RATE_BINS * RATE_BIN_US


def rate_bins(t0: int, length_us: int) -> tuple[int, int, int]:
    """The bins a window ``[t0, t0 + length_us)`` is counted in for :func:`rate_swing`, as
    :func:`uavsnn.signature.measure_box`'s ``rate``: ``(t0, RATE_BIN_US, bins)``, at least one
    bin (the events of a last, partial bin are not counted)."""
    return int(t0), RATE_BIN_US, max(1, int(length_us) // RATE_BIN_US)


def rate_swing(counts: npt.ArrayLike) -> float:
    """How strongly an object's event rate swings within its window, beyond shot noise.

    ``counts``: the object's events per bin (:data:`RATE_BIN_US`) over the window. They are
    divided by a straight line fitted to them (least squares; kept above 5 % of their mean), so
    that a steady rise or fall is not a swing, and less 1; ``v`` is the variance of what is
    left. Poisson counts of mean ``m`` would give ``v`` about ``1 / m`` by chance alone, so the
    swing is ``sqrt(max(v - 1 / m, 0))``: 0 for a steady rate of any size, about the relative
    amplitude of a rate that rises and falls within the window (a wing stroke, a bounce, a
    blade that passes a few times per window). 0 with fewer than three bins or no event.
    Computed by the engine (``rust/signature.rs``), which also gives it for a box measured with
    its rate (:func:`uavsnn.signature.measure_box`).

    Raises:
        ParameterError: counts that are not whole numbers in ``0..2**32``.
    """
    c = np.asarray(counts)
    if c.size and (
        c.dtype.kind not in "iubf"
        or not np.all(np.isfinite(c) & (c >= 0) & (c <= np.iinfo(np.uint32).max))
        or (c.dtype.kind == "f" and not np.all(c == np.floor(c)))
    ):
        raise ParameterError(f"rate counts must be whole numbers in 0..2**32, got {c!r}")
    return float(_core.rate_swing(c.astype(np.uint32).ravel().tolist()))


FEATURES: tuple[str, ...] = (
    "rotor_log_hz",
    "rotor_strength",
    "rotor_log_pixels",
    "rotor_detected",
    "log_width",
    "log_height",
    "log_area",
    "log_aspect",
    "log_spikes",
    "log_events_per_px",
    "on_balance",
    "log_rate_swing",
    *TRACK_FEATURES,
)
"""The features of one object, in the order of the model's coefficients."""


def track_features(track: Track | None) -> list[float]:
    """The :data:`TRACK_FEATURES` of an object whose track stands at ``track`` after its
    window (zeros for an object without a track): age (log of ms), hits (log), filtered speed
    (log of px/s), straightness, turn rate (log of rad/s), the segment speeds' standard
    deviation (log of px/s), vertical speed (signed log of px/s; positive downwards), the
    mean rotor strength of its detections so far, and its activity history: the mean and
    standard deviation of its objects' raw events per pixel (log), and the mean of their
    ON/OFF balance and rate swing (log), each as :func:`activity` gives them for one object
    (:attr:`uavsnn.tracks.Track.activity_measured` of them)."""
    if track is None:
        return [0.0] * len(TRACK_FEATURES)
    v = track.vertical_speed
    return [
        math.log1p(track.age_us / 1000),
        math.log1p(track.hits),
        math.log1p(track.speed),
        track.straightness,
        math.log1p(track.turn_rate),
        math.log1p(track.speed_std),
        math.copysign(math.log1p(abs(v)), v),
        track.rotor_strength_mean,
        track.events_per_px_mean,
        track.events_per_px_std,
        track.on_balance_mean,
        track.rate_swing_mean,
    ]


def activity(
    box: tuple[int, int, int, int], counts: tuple[int, int, float]
) -> tuple[float, float, float]:
    """An object's activity features: raw events per pixel of ``box`` ``(x0, y0, x1, y1)``
    (log), the ON/OFF balance ``(ON − OFF) / events`` (0 without an event) and the rate swing
    (log), from ``counts`` ``(events, on, swing)`` (:func:`uavsnn.signature.measure_box`).

    Raises:
        ParameterError: an empty box, or counts that no box gives (negative, more ON events
            than events, a negative or non-finite swing).
    """
    try:
        n, on, swing = (int(counts[0]), int(counts[1]), float(counts[2]))
        w, h = int(box[2]) - int(box[0]), int(box[3]) - int(box[1])
    except (TypeError, ValueError, IndexError, OverflowError) as err:
        raise ParameterError(
            f"activity needs a box (x0, y0, x1, y1) and counts (events, on, swing), got {box} "
            f"and {counts}"
        ) from err
    if w < 1 or h < 1:
        raise ParameterError(f"an object's box must not be empty, got {box}")
    if not (0 <= on <= n and math.isfinite(swing) and swing >= 0):
        raise ParameterError(f"counts must be (events, on <= events, swing >= 0), got {counts}")
    return math.log1p(n / (w * h)), (2 * on - n) / n if n else 0.0, math.log1p(swing)


def object_features(
    box: tuple[int, int, int, int],
    spikes: int,
    events: np.ndarray | None,
    rotor: RotorEstimate | None = None,
    track: Track | None = None,
    *,
    counts: tuple[int, int, float] | None = None,
    window: tuple[int, int] | None = None,
) -> np.ndarray:
    """The :data:`FEATURES` (float64) of one object: ``box`` ``(x0, y0, x1, y1)`` half-open,
    its conv3 ``spikes``, and the window's raw ``events`` (time order; only those inside the box
    are used). ``rotor``: the box's rotor signature when already measured (else measured
    here on the same events); ``track``: its track after this window (:func:`track_features`;
    ``None``: no track). ``counts``: ``(events, on, swing)``, the window's events inside the
    box, the ON ones among them and the :func:`rate_swing` of its events per bin of
    :data:`RATE_BIN_US` over the window, when already measured with the rotor
    (:func:`uavsnn.signature.measure_box`); with both
    ``rotor`` and ``counts``, ``events`` is not read (it may be ``None``). ``window``: the
    window's ``(t0, length_us)``, needed to count the rate when it is measured here from
    ``events``.

    Raises:
        ParameterError: an empty box, or neither ``counts`` (with ``rotor``) nor ``events``
            and ``window``.
    """
    x0, y0, x1, y1 = corners(box)
    w, h = x1 - x0, y1 - y0
    if w < 1 or h < 1:
        raise ParameterError(f"an object's box must not be empty, got {box}")
    if rotor is not None and counts is not None:
        n, on, swing = int(counts[0]), int(counts[1]), float(counts[2])
    elif events is None or window is None:
        raise ParameterError(
            "object_features needs the events and the window's (t0, length_us) unless rotor "
            "and counts are given"
        )
    else:
        measured, n, on, swing = measure_box(events, (x0, y0, w, h), rate=rate_bins(*window))
        rotor = measured if rotor is None else rotor
    return np.array(
        [
            math.log1p(rotor.frequency_hz),
            rotor.strength,
            math.log1p(rotor.pixels),
            float(rotor.detected),
            math.log(w),
            math.log(h),
            math.log(w * h),
            math.log(w / h),
            math.log1p(spikes),
            *activity((x0, y0, x1, y1), (n, on, swing)),
            *track_features(track),
        ]
    )


@dataclass(frozen=True)
class WindowFeatures:
    """The objects of many windows: ``x`` ``(m, len(FEATURES))``, ``window`` ``(m,)`` (the
    window each object belongs to), ``boxes`` ``(m, 4)``; ``windows``: how many windows;
    ``label`` ``(m,)`` bool: for training, a UAV object (an object of a UAV window whose box
    meets the labelled box), ``usable`` ``(m,)``: False for the objects of a UAV window that
    miss its box (left out of a fit: they are not the UAV, nor known not to be one);
    ``track`` ``(m,)`` int64: the object's track id, unique within its window's recording
    (0: no track), and ``confirmed`` ``(m,)`` bool: its track is confirmed after this
    window. ``gate_px``: the gate (px) of the tracker the track features were built with
    (``None``: not known, e.g. features made by hand); a model fitted on them records it
    (:attr:`uavsnn.identifier.Identifier.gate_px`)."""

    x: np.ndarray
    window: np.ndarray
    boxes: np.ndarray
    windows: int
    label: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    usable: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    track: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    confirmed: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    cls: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype="<U12"))
    gate_px: float | None = None

    def columns(self, names: Sequence[str]) -> WindowFeatures:
        """The same objects with only the features ``names``."""
        idx = [FEATURES.index(n) for n in names]
        return replace(self, x=self.x[:, idx])


def window_steps(data: LabelledWindows) -> tuple[np.ndarray, int]:
    """The windows of ``data`` in stream order, and the step between window starts (µs).

    Returns ``order`` (every window index, grouped by recording in ascending id, each
    recording's windows by start time) and ``step``: the dataset's ``step_us``
    (``manifest["parameters"]``) when it has one, else the greatest common divisor of the
    gaps between successive starts within a recording (the window length when no recording
    has two windows). A window's position in its recording's stream is
    ``(t0 - first t0) // step``.

    Raises:
        DatasetError: two windows of one recording start at the same time (a stream holds
            each window once), or a start off the recording's grid of ``step``.
    """
    t0 = np.asarray(data.windows.t0, dtype=np.int64)
    rec = np.asarray(data.recording, dtype=np.int64)
    order = np.lexsort((t0, rec))
    same = rec[order][1:] == rec[order][:-1]
    gaps = np.diff(t0[order])[same]
    if np.any(gaps == 0):
        i = int(np.flatnonzero(same & (np.diff(t0[order]) == 0))[0])
        raise DatasetError(
            f"recording {int(rec[order][i])} has two windows starting at {int(t0[order][i])} "
            "us: tracks need each window of a recording once"
        )
    step = (data.manifest or {}).get("parameters", {}).get("step_us")
    if step is None:
        step = int(np.gcd.reduce(gaps)) if len(gaps) else int(data.windows.length_us)
    step = int(step)
    if step < 1 or (len(gaps) and np.any(gaps % step)):
        raise DatasetError(f"window starts are not on a grid of the {step} us step")
    return order, step


def window_features(
    network: Network,
    data: LabelledWindows,
    inference: Inference | None = None,
    *,
    tracker: Tracker | None = None,
    raw_noise: tuple[float, int] | None = None,
) -> WindowFeatures:
    """The features of every object of every window of ``data`` (a dataset of format 2, with
    raw events), from ``network``'s detections (``inference`` when already run).

    ``raw_noise`` ``(fraction, seed)``: add uniform noise to each window's raw events before
    measuring them, at the density :func:`uavsnn.windows.add_noise` adds to the windows
    (:func:`raw_noise_events`), so that features of noisy windows see noisy events.

    The track features come from ``tracker`` (default: :func:`uavsnn.tracks.tracker_for`
    ``network``, the tracker the network runs with: the gate its identification was fitted with
    when the model records one, else its sensor's; a fit passes its sensor's,
    :meth:`uavsnn.tracks.Tracker.for_sensor`, as :func:`uavsnn.identify.fit_network` does). It
    is reset before each recording, and its gate is the result's ``gate_px``. Each recording's
    windows are fed to it in time order (:func:`window_steps`), as
    :meth:`uavsnn.detector.Detector.push_windows` feeds a stream, windows without an object
    included. A window the dataset left out counts as a window without a detection. As the
    streaming detector, only the first :data:`uavsnn.detector.MAX_ROTOR_BOXES` objects of a
    window (most spikes first) are measured and get a row; the others are tracked only.

    Raises:
        DatasetError: a dataset without raw events, or windows that cannot form a stream
            (:func:`window_steps`).
        ShapeError: the dataset's sensor size is not the network's input.
    """
    from uavsnn.detector import MAX_ROTOR_BOXES
    from uavsnn.grouping import WindowReport, merge_boxes
    from uavsnn.tracks import Tracker, tracker_for

    expected = (int(network.config["width"]), int(network.config["height"]))
    if tuple(data.windows.sensor_size) != expected:
        raise ShapeError(
            f"the data's sensor is {data.windows.sensor_size[0]}x{data.windows.sensor_size[1]} "
            f"but the model's input is {expected[0]}x{expected[1]}"
        )

    if data.raw is None:
        raise DatasetError(
            "identification needs each window's raw events: rebuild the dataset "
            "(`uavsnn dataset build`, format 2)"
        )
    if tracker is None:
        tracker = tracker_for(network)
    elif not isinstance(tracker, Tracker):
        raise ParameterError(f"tracker must be a uavsnn.tracks.Tracker, got {tracker!r}")
    order, step = window_steps(data)
    if inference is None:
        inference = network.infer(data.windows)
    if len(inference) != len(data):
        raise ShapeError(f"inference has {len(inference)} windows, the data {len(data)}")
    length = int(data.raw.before_us)
    window_us = int(data.windows.length_us)
    min_detections = int(network.config["detection"]["min_detections"])
    found = inference.detections
    found = found[np.argsort(found["window"], kind="stable")]
    starts = np.searchsorted(found["window"], np.arange(len(data) + 1))
    t0s = np.asarray(data.windows.t0, dtype=np.int64)
    recording = np.asarray(data.recording, dtype=np.int64)
    per_window: dict[int, list[tuple[Any, np.ndarray]]] = {}
    first_t0, current = 0, None
    for i in order.tolist():
        if recording[i] != current:
            current, first_t0 = recording[i], int(t0s[i])
            tracker.reset()
        t0 = int(t0s[i])
        spikes = found[starts[i] : starts[i + 1]]
        objects = merge_boxes(spikes)
        measured = []
        if objects:
            raw = data.raw.window(i)
            measured_boxes = [xywh(o.box) for o in objects[:MAX_ROTOR_BOXES]]
            if raw_noise is not None:
                # Only the noise in the measured boxes: measure_box reads nothing else.
                raw = raw_noise_events(
                    raw,
                    t0,
                    length,
                    data.windows.sensor_size,
                    *raw_noise,
                    window=int(i),
                    boxes=measured_boxes,
                )
            # A binary search on the times in place (np.searchsorted would copy them first).
            t = raw["t"]
            events = raw[bisect.bisect_left(t, t0) : bisect.bisect_left(t, t0 + length)]
            # Each object's rotor and event counts in one pass over the window's events; as
            # the streaming detector, only the first MAX_ROTOR_BOXES objects are measured (and
            # scored): the others are tracked only.
            rate = rate_bins(t0, window_us)
            measured = [measure_box(events, box, rate=rate) for box in measured_boxes]
            objects = tuple(
                replace(o, rotor=measured[j].rotor, counts=measured[j].counts)
                if j < len(measured)
                else o
                for j, o in enumerate(objects)
            )
        report = tracker.update(
            WindowReport(
                window=(t0 - first_t0) // step,
                t0=t0,
                t1=t0 + window_us,
                detected=len(spikes) >= min_detections,
                detections=spikes,
                objects=objects,
            )
        )
        if measured:
            per_window[i] = [
                (o, object_features(o.box, o.spikes, None, m.rotor, o.track, counts=m.counts))
                for o, m in zip(report.objects, measured, strict=False)
            ]
    rows, which, boxes, label, usable, track, confirmed, cls = [], [], [], [], [], [], [], []
    for i in sorted(per_window):
        truth = np.asarray(data.box[i], dtype=np.float64)
        is_uav = bool(data.label[i])
        named = str(data.cls[i])
        for obj, feats in per_window[i]:
            rows.append(feats)
            which.append(i)
            boxes.append(obj.box)
            meets = bool(
                np.isfinite(truth).all()
                and obj.box[0] < truth[2]
                and truth[0] < obj.box[2]
                and obj.box[1] < truth[3]
                and truth[1] < obj.box[3]
            )
            label.append(is_uav and meets)
            usable.append(not is_uav or meets)
            if is_uav:
                cls.append(UAV_CLASS if meets else "")
            elif named == "none":
                cls.append(CLUTTER_CLASS)
            else:
                cls.append(named if meets else "")
            track.append(0 if obj.track_id is None else obj.track_id)
            confirmed.append(bool(obj.track_confirmed))
    return WindowFeatures(
        x=np.array(rows, dtype=np.float64).reshape(-1, len(FEATURES)),
        window=np.array(which, dtype=np.int64),
        boxes=np.array(boxes, dtype=np.int64).reshape(-1, 4),
        windows=len(data),
        label=np.array(label, dtype=bool),
        usable=np.array(usable, dtype=bool),
        track=np.array(track, dtype=np.int64),
        confirmed=np.array(confirmed, dtype=bool),
        cls=np.array(cls, dtype="<U12"),
        gate_px=tracker.gate_px,
    )


def raw_noise_events(
    events: np.ndarray,
    t0: int,
    length_us: int,
    sensor: tuple[int, int],
    fraction: float,
    seed: int,
    *,
    window: int,
    boxes: Sequence[tuple[int, int, int, int]] | None = None,
) -> np.ndarray:
    """``events`` (one window's raw events, time order) with uniform noise added: in each of
    ``[t0 − length_us, t0)`` and ``[t0, t0 + length_us)``, ``floor(fraction · W · H + 0.5)``
    events at uniform pixels, times and polarities — the count :func:`uavsnn.windows.add_noise`
    adds to a window and its preceding interval. Drawn from ``(seed, window)``, so the same
    window gets the same noise; a different draw from the windows' own noise (that one is made
    in the engine), of the same density. Returned in time order (stable: an event's
    order among equal times is kept, the noise after the signal).

    ``boxes`` ``(x0, y0, width, height)``: keep only the noise inside one of them (the same
    draws, the others left out): what :func:`uavsnn.signature.measure_box` of those boxes reads
    is then the same, in the same order, at the cost of sorting the noise it reads."""
    from uavsnn.events import EVENT_DTYPE

    if not 0.0 <= fraction <= 1.0:
        raise ParameterError(f"noise fraction must be in [0, 1], got {fraction!r}")
    width, height = int(sensor[0]), int(sensor[1])
    n = noise_per_window(fraction, (width, height))
    if n == 0:
        return events
    rng = np.random.default_rng([int(seed), int(window)])
    lo = max(int(t0) - int(length_us), 0)
    # Drawn in this order whatever is kept, so that the same window gets the same noise.
    t = np.concatenate(
        [
            rng.integers(lo, max(int(t0), lo + 1), n),
            rng.integers(int(t0), int(t0) + int(length_us), n),
        ]
    )
    x, y = rng.integers(0, width, 2 * n), rng.integers(0, height, 2 * n)
    p = rng.integers(0, 2, 2 * n)
    keep: slice | np.ndarray = slice(None)
    if boxes is not None:
        keep = np.zeros(2 * n, dtype=bool)
        for x0, y0, w, h in boxes:
            keep |= (x >= x0) & (x < x0 + w) & (y >= y0) & (y < y0 + h)
    noise = np.zeros(len(t[keep]), dtype=EVENT_DTYPE)
    noise["t"], noise["x"], noise["y"], noise["p"] = t[keep], x[keep], y[keep], p[keep]
    noise = noise[np.argsort(noise["t"], kind="stable")]
    signal_t = events["t"]
    if len(signal_t) > 1 and (signal_t[1:] < signal_t[:-1]).any():  # not in time order
        out = np.concatenate([events, noise])
        return out[np.argsort(out["t"], kind="stable")]
    # Each noise event after the signal's of the same time: the order a stable sort of the
    # signal then the noise gives, without sorting the signal again.
    return np.insert(events, np.searchsorted(signal_t, noise["t"], side="right"), noise)
