"""Whole clips (recordings) of a dataset split, streamed: the decision per clip.

A dataset split keeps some windows of each recording: the SPEC §5 dvs test split keeps about
four in five of its recordings' steps, the real set's test split 11.9 % of its 42 clips'. The
tracks ``uavsnn evaluate --tracks`` follows in a split are therefore gappy and confirm late. A
user runs the detector on whole recordings. :func:`evaluate_clips` makes each clip of a split
into events again exactly as the dataset's build made them (:func:`clip_set`: the manifest's
window cut, sensor, scene sources, simulator parameters and seeds; a real clip through
:func:`uavsnn.dataset.footage.clip_recording`, a rendered one through
:func:`uavsnn.dataset.synthetic.synthetic_recording`; each clip's event count is checked
against the manifest's). It streams every window of it through a
:class:`~uavsnn.detector.Detector` as ``uavsnn detect`` runs it, and decides the clip under
each rule of :func:`uavsnn.false_alarms.alarm_rules`: **UAV** when a track alarms during it
(any-spike: a confirmed track; with identification: a confirmed track whose running mean UAV
score reaches the rule's threshold). A clip is **decided right** when that decision is whether
a UAV is labelled in one of its frames (SPEC §5's target for real footage: at least 90 % of
clips); its class is the one labelled in most of its frames (``"none"`` where no object is
labelled, as in a drone clip whose drone is never labelled visible). As in
:func:`uavsnn.track_eval.track_figures`, a UAV clip is also **found** when an alarming track
meets the labelled UAV from its alarm on, and its **time to first alarm** runs from the start
of its first labelled UAV window to the end of the window where that happens. A **false track**
is an alarming track of a clip without a UAV, counted per minute of those clips (a UAV clip's
UAV-free stretches do not count: its tracks are the clip's decision); ``track_figures`` counts
one whose alarm window holds no UAV, in any recording, per minute of UAV-free windows.

    >>> figures = evaluate_clips(network, "runs/reproduce/data/real")
    >>> print(clip_table(figures))
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from uavsnn.distributed import SERIAL, Runner
from uavsnn.errors import DatasetError, InternalError, ParameterError
from uavsnn.false_alarms import alarm_rules, count_alarms, stream_reports
from uavsnn.track_eval import (
    DEFAULT_CONFIRM,
    UAV_WINDOW_TEXT,
    Confirm,
    box_meets,
    decision_figures,
    delay_stats_ms,
    ms_text,
    poisson_upper,
    recording_class,
    rule_name,
)

if TYPE_CHECKING:
    from uavsnn.dataset.footage import ClipPlan
    from uavsnn.dataset.labels import WindowLabels
    from uavsnn.dataset.splits import WindowCut
    from uavsnn.dataset.synthetic import SceneSource
    from uavsnn.grouping import WindowReport
    from uavsnn.network import Network
    from uavsnn.scenes import SceneSpec
    from uavsnn.sim import Pix2NvsParams

__all__ = [
    "ClipSet",
    "StreamedClip",
    "Whole",
    "box_events",
    "clip_alarms",
    "clip_figures",
    "clip_set",
    "clip_stream",
    "clip_table",
    "evaluate_clips",
    "scene_source",
]


@dataclass(frozen=True)
class Whole:
    """One clip (a recording) of a split, and how its build made it: its ``name``, its event
    count at the build, and either ``real`` (the build's seed, the clip's position among the
    folder's clips, which keys its simulation, its plan, and the PIX2NVS parameters) or
    ``scene`` (the scene source, kind, seed and object kind of a rendered recording)."""

    name: str
    events: int
    real: tuple[int, int, ClipPlan, Pix2NvsParams] | None = None
    scene: tuple[SceneSource, str, int, str | None] | None = None

    def make(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
        """Its events again, its frames' times, labels and whether each is labelled (and
        decoded), and its end in µs."""
        if self.real is not None:
            from uavsnn.dataset.footage import clip_recording, decoded_labelled

            seed, j, plan, params = self.real
            recording = clip_recording(seed, j, plan, params)
            labelled = decoded_labelled(plan, recording)
            return recording.events, plan.timestamps_us, plan.frame_labels, labelled, plan.end_us
        from uavsnn.dataset.synthetic import synthetic_recording

        if self.scene is None:
            raise InternalError(f"clip {self.name} has no way to be made")
        lr = synthetic_recording(*self.scene)
        return lr.recording.events, lr.timestamps_us, lr.labels, lr.labelled, lr.end_us

    def spec(self) -> SceneSpec | None:
        """The scene of a rendered clip as its build drew it (its objects' kinds, sizes, paths
        and rates), without rendering it; ``None`` for real footage."""
        from uavsnn.dataset.synthetic import scene_spec

        return None if self.scene is None else scene_spec(*self.scene)


@dataclass(frozen=True)
class ClipSet:
    """The clips of one split of a dataset, as its build made them, with its window ``cut``
    and ``sensor``."""

    dataset: Path
    split: str
    cut: WindowCut
    sensor: tuple[int, int]
    clips: tuple[Whole, ...]


def scene_source(described: dict[str, Any]) -> SceneSource:
    """The :class:`~uavsnn.dataset.synthetic.SceneSource` a manifest's ``sources`` entry
    describes (:meth:`~uavsnn.dataset.synthetic.SceneSource.describe`)."""
    from uavsnn.dataset.synthetic import SceneSource
    from uavsnn.scenes import Lens
    from uavsnn.sim import DvsParams, Pix2NvsParams

    domain = str(described["domain"])
    fps = described["fps"]
    params = described["simulator_params"]
    lens = described.get("lens")
    return SceneSource(
        domain,
        (int(described["render_size"][0]), int(described["render_size"][1])),
        float(fps) if isinstance(fps, (int, float)) else None,
        float(described["duration_s"]),
        sensor=(int(described["sensor_size"][0]), int(described["sensor_size"][1])),
        dvs_params=DvsParams(**params) if domain == "dvs" else None,
        pix2nvs_params=Pix2NvsParams(**params) if domain == "sim" else None,
        lens=None if lens is None else Lens(**lens),
        # a list in the manifest; SceneSource checks it and keeps it as a pair of floats
        fov_deg=described.get("fov_deg"),
    )


def clip_set(dataset: str | Path, split: str = "test", videos: str | Path | None = None) -> ClipSet:
    """The clips of ``dataset``'s ``split``: rendered recordings (dvs, sim) made again from
    their seeds, or real footage read from ``videos`` (default: the folder its build read, as
    the manifest names it).

    Raises:
        DatasetError: no such split, a manifest that does not say how the split was made
            (an older uavsnn's), the videos' folder missing, or a clip of the split not in it.
        ParameterError: ``videos`` for a split without real footage.
    """
    from uavsnn.dataset.format import read_manifest

    root = Path(dataset)
    manifest = read_manifest(root)
    if split not in manifest.get("splits", {}):
        raise DatasetError(f"{root} has no {split!r} split")
    try:
        return _clip_set(root, manifest, split, videos)
    except (KeyError, TypeError) as exc:
        raise DatasetError(
            f"{root}'s manifest does not say how its {split} recordings were made ({exc!r} "
            "missing or wrong): build it again with this uavsnn"
        ) from exc


def _clip_set(
    root: Path, manifest: dict[str, Any], split: str, videos: str | Path | None
) -> ClipSet:
    from uavsnn.dataset.footage import plan_clip
    from uavsnn.dataset.format import file_sha256
    from uavsnn.dataset.real import find_clips
    from uavsnn.dataset.splits import WindowCut
    from uavsnn.dataset.synthetic import stratified_object
    from uavsnn.scenes import object_shares
    from uavsnn.sim import Pix2NvsParams

    params = manifest["parameters"]
    sources = {str(s["domain"]): s for s in params["sources"]}
    cut = WindowCut(
        int(params["window_us"]), float(params["overlap"]), float(params["min_visible_fraction"])
    )
    sensor = (int(params["sensor_size"][0]), int(params["sensor_size"][1]))
    records = {int(r["id"]): r for r in manifest["recordings"]}
    mine = [records[int(i)] for i in manifest["splits"][split]["recordings"]]
    real = [r for r in mine if r["domain"] == "real"]
    if videos is not None and not real:
        raise ParameterError(
            f"the folder of videos is for real footage; {root}'s {split} split holds none"
        )
    found: dict[str, int] = {}
    if real:
        folder = Path(sources["real"]["videos"] if videos is None else videos)
        if not folder.is_dir() and videos is not None:
            raise DatasetError(f"the folder of videos {folder} is not a folder")
        # The folder as the build was given it is relative to the build's working folder; a
        # build also records it from the dataset's folder, which holds from anywhere.
        from_dataset = sources["real"].get("videos_from_dataset")
        if videos is None and from_dataset is not None and (root / from_dataset).is_dir():
            folder = root / from_dataset
        if not folder.is_dir():
            raise DatasetError(
                f"the clips of {root} were read from {folder}, which is not a folder here: "
                "give the folder of the videos (--videos)"
            )
        folder_clips = find_clips(folder)
        found = {c.name: j for j, c in enumerate(folder_clips)}
    # A stratified split gave its object scenes their kinds in turn, in the build's order.
    stratified = params.get("object_scenes") == "stratified"
    objects_before: dict[int, int] = {}
    ordered = sorted(manifest["recordings"], key=lambda r: int(r["id"]))
    for domain in sources if stratified else ():
        key = (domain, split, "object")
        kept = [r for r in ordered if (r["domain"], r["split"], r["kind"]) == key]
        objects_before.update({int(r["id"]): n for n, r in enumerate(kept)})
    chosen = []
    for record in mine:
        name, events = str(record["name"]), int(record["events"])
        if record["domain"] == "real":
            if name not in found:
                raise DatasetError(f"clip {name} of {root}'s {split} split is not in {folder}")
            j = found[name]
            built = record.get("boxes_sha256")  # older sets lack it
            if built is not None and file_sha256(folder_clips[j].boxes) != built:
                raise DatasetError(
                    f"box file {folder_clips[j].boxes} of clip {name} changed since {root} was "
                    "built: its windows would be labelled otherwise than the dataset's; "
                    "build the dataset again, or give --videos the folder it was built from"
                )
            pix2nvs = Pix2NvsParams(**sources["real"]["simulator_params"])
            plan = plan_clip(cut, folder_clips[j], sensor)
            chosen.append(Whole(name, events, real=(int(manifest["seed"]), j, plan, pix2nvs)))
            continue
        source = scene_source(sources[str(record["domain"])])
        object_kind = None
        if stratified and record["kind"] == "object":
            shares = object_shares(source.domain)
            object_kind = stratified_object(shares, objects_before[int(record["id"])])
        scene = (source, str(record["kind"]), int(record["seed"]), object_kind)
        chosen.append(Whole(name, events, scene=scene))
    return ClipSet(root, split, cut, sensor, tuple(chosen))


def clip_alarms(
    reports: Sequence[WindowReport],
    rules: dict[str, float | None],
    uav: np.ndarray,
    boxes: np.ndarray,
) -> dict[str, Any]:
    """Per rule, the alarms among ``reports`` (one stream's windows; ``uav`` and ``boxes``: each
    window's label and labelled box): ``alarmed``, ``alarming_tracks``, ``false_tracks``
    (alarming in a window without a UAV), ``first_alarm_us`` (the end of the first window
    where a track alarms) and ``found_us`` (the end of the first window where an alarming
    track meets the labelled UAV, from its alarm on), with ``None`` where none; and
    ``track_peaks``, each confirmed track's highest score (as
    :func:`uavsnn.false_alarms.count_alarms` gives them)."""
    tracks: dict[int, list[tuple[int, Any]]] = {}
    for k, report in enumerate(reports):
        if not report.detected:
            continue
        for o in report.objects:
            if o.track_id is not None:
                tracks.setdefault(o.track_id, []).append((k, o))
    # Each confirmed track's peak, as the streamed false-alarm figures define it.
    out: dict[str, Any] = {"rules": {}, "track_peaks": count_alarms(reports, {})["track_peaks"]}
    for rule, threshold in rules.items():
        first = found = None
        alarming = false = 0
        for objs in tracks.values():
            at = next(
                (
                    n
                    for n, (_, o) in enumerate(objs)
                    if o.track_confirmed
                    and (
                        threshold is None
                        or (o.track_score is not None and o.track_score >= threshold)
                    )
                ),
                None,
            )
            if at is None:
                continue
            alarming += 1
            k = objs[at][0]
            first = reports[k].t1 if first is None else min(first, reports[k].t1)
            false += not uav[k]
            on = [reports[j].t1 for j, o in objs[at:] if uav[j] and box_meets(o.box, boxes[j])]
            if on:
                found = on[0] if found is None else min(found, on[0])
        out["rules"][rule] = {
            "alarmed": first is not None,
            "alarming_tracks": alarming,
            "false_tracks": false,
            "first_alarm_us": first,
            "found_us": found,
        }
    return out


def box_events(events: np.ndarray, t0: np.ndarray, length_us: int, boxes: np.ndarray) -> np.ndarray:
    """How many of ``events`` (sorted by time) fall in each window ``[t0, t0 + length_us)``
    on a pixel that meets its box (``boxes`` ``(n, 4)``: x0, y0, x1, y1; pixel ``x`` covers
    ``[x, x + 1)``): what a labelled object gave the network to see."""
    t = events["t"]
    starts = np.asarray(t0, dtype=np.uint64)
    lo = np.searchsorted(t, starts)
    hi = np.searchsorted(t, starts + np.uint64(length_us))
    out = np.zeros(len(starts), dtype=np.int64)
    for k, (a, b) in enumerate(zip(lo.tolist(), hi.tolist(), strict=True)):
        x = events["x"][a:b].astype(np.float64)
        y = events["y"][a:b].astype(np.float64)
        x0, y0, x1, y1 = boxes[k]
        out[k] = int(np.count_nonzero((x + 1 > x0) & (x < x1) & (y + 1 > y0) & (y < y1)))
    return out


@dataclass(frozen=True)
class StreamedClip:
    """One clip made into events as its build made them and streamed whole
    (:func:`clip_stream`): its ``events``, its frames' labels (``frame_labels``, ``labelled``)
    and length (``end_us``), the detector's ``reports``, every window's start (``every``) and
    labels (``labels``, as the build labels them), and where each report's window is among
    them (``at``)."""

    whole: Whole
    events: np.ndarray
    frame_labels: np.ndarray
    labelled: np.ndarray
    end_us: int
    reports: list[WindowReport]
    every: np.ndarray
    labels: WindowLabels
    at: np.ndarray

    @property
    def uav(self) -> bool:
        """A UAV is labelled in one of the clip's frames."""
        return bool(self.frame_labels["uav"][self.labelled].any())

    @property
    def window_uav(self) -> np.ndarray:
        """Each window of the clip (``every``): a usable window labelled UAV."""
        return self.labels.label & self.labels.usable

    @property
    def report_uav(self) -> np.ndarray:
        """Each report's window: a usable window labelled UAV."""
        return self.window_uav[self.at]

    @property
    def report_boxes(self) -> np.ndarray:
        """Each report's window's labelled box."""
        return self.labels.box[self.at]


def clip_stream(
    network: Network, clips: ClipSet, which: int, confirm: tuple[int, int] | None = None
) -> StreamedClip:
    """Clip ``which`` of ``clips`` made into events as its build made them, streamed through a
    fresh detector (the tracker confirming by ``confirm`` ``(hits, windows)``, default 3 of
    5), and every window of it labelled as the build labels them.

    Raises:
        DatasetError: the clip gives another number of events than at the build (another
            video, video decoder or uavsnn).
        InternalError: the detector's windows are not the build's.
    """
    whole = clips.clips[which]
    events, frame_us, frame_labels, labelled, end_us = whole.make()
    if len(events) != whole.events:
        raise DatasetError(
            f"clip {whole.name} gives {len(events)} events here and gave {whole.events} when "
            "the dataset was built: another video, another video decoder, or another uavsnn"
        )
    reports = stream_reports(
        network,
        events,
        clips.sensor,
        confirm,
        window_us=clips.cut.length_us,
        overlap=clips.cut.overlap,
    )
    # Every window of the clip labelled as the build labels them; the stream reports those up
    # to its last event.
    every = clips.cut.starts(end_us)
    labels = clips.cut.label(every, frame_us, frame_labels, labelled)
    t0 = np.asarray([r.t0 for r in reports], dtype=np.uint64)
    at = np.searchsorted(every, t0)
    if np.any(at >= len(every)) or not np.array_equal(every[at], t0):
        raise InternalError(f"the detector's windows of {whole.name} are not the build's")
    return StreamedClip(whole, events, frame_labels, labelled, end_us, reports, every, labels, at)


def stream_clip(
    network: Network, clips: ClipSet, which: int, confirm: tuple[int, int] | None = None
) -> dict[str, Any]:
    """Clip ``which`` of ``clips`` streamed (:func:`clip_stream`): its row of
    :func:`evaluate_clips`'s ``per_clip`` (the unit of work).

    Raises:
        DatasetError: as :func:`clip_stream`.
    """
    clip = clip_stream(network, clips, which, confirm)
    labels, every = clip.labels, clip.every
    uav = clip.window_uav
    rules = alarm_rules(network, confirm or DEFAULT_CONFIRM)
    alarms = clip_alarms(clip.reports, rules, clip.report_uav, clip.report_boxes)
    first_uav = int(every[uav].min()) if uav.any() else None
    sizes = labels.size_px[uav]
    sizes = sizes[np.isfinite(sizes)]
    on_uav = box_events(clip.events, every[uav], clips.cut.length_us, labels.box[uav])
    for rule in alarms["rules"].values():
        found = rule["found_us"]
        rule["time_to_alarm_us"] = None if found is None or first_uav is None else found - first_uav
    return {
        "clip": clip.whole.name,
        "class": recording_class(clip.frame_labels["cls"][clip.labelled]),
        "uav": clip.uav,
        "seconds": clip.end_us / 1e6,
        "events": len(clip.events),
        "windows": len(clip.reports),
        "uav_windows": int(uav.sum()),
        "uav_size_px": float(np.median(sizes)) if len(sizes) else None,
        "uav_events_per_window": float(np.median(on_uav)) if len(on_uav) else None,
        **alarms,
    }


def clip_figures(rows: Sequence[dict[str, Any]], rules: Sequence[str]) -> dict[str, Any]:
    """The figures of :func:`evaluate_clips` from its rows: per rule of ``rules``, the clips
    decided right (:func:`uavsnn.track_eval.decision_figures`), the UAV clips ``found`` and
    their ``time_to_alarm_ms``, and the ``false_tracks`` of the clips without a UAV with their
    rate per minute of those clips (and its 95 % upper bound)."""
    free_minutes = sum(r["seconds"] for r in rows if not r["uav"]) / 60
    out: dict[str, Any] = {
        "clips": len(rows),
        "uav_clips": sum(1 for r in rows if r["uav"]),
        "minutes": sum(r["seconds"] for r in rows) / 60,
        "uav_free_minutes": free_minutes,
        "windows": sum(r["windows"] for r in rows),
        "rules": {},
    }
    for rule in rules:
        mine = [r["rules"][rule] for r in rows]
        pairs = list(zip(rows, mine, strict=True))
        false = sum(m["alarming_tracks"] for r, m in pairs if not r["uav"])
        delays = [m["time_to_alarm_us"] for m in mine if m["time_to_alarm_us"] is not None]
        out["rules"][rule] = decision_figures(
            [r["uav"] for r in rows], [m["alarmed"] for m in mine], [r["class"] for r in rows]
        ) | {
            "found": sum(1 for r, m in pairs if r["uav"] and m["found_us"] is not None),
            "time_to_alarm_ms": delay_stats_ms(delays),
            "false_tracks": false,
            "false_tracks_per_minute": false / free_minutes if free_minutes else None,
            "false_tracks_per_minute_upper95": (
                poisson_upper(false) / free_minutes if free_minutes else None
            ),
        }
    return out


def evaluate_clips(
    network: Network,
    dataset: str | Path,
    split: str = "test",
    *,
    videos: str | Path | None = None,
    confirm: Confirm | None = None,
    runner: Runner = SERIAL,
) -> dict[str, Any]:
    """Every clip of ``dataset``'s ``split`` (:func:`clip_set`) streamed whole through
    ``network``'s detector, one clip a unit of work on ``runner``, and decided under each of
    its rules (the module's docs): :func:`clip_figures` with ``confirm`` (the rule as text),
    ``split`` and ``per_clip`` (a row per clip, :func:`stream_clip`).

    Raises:
        DatasetError: as :func:`clip_set` and :func:`stream_clip`.
        ParameterError: a score-aware ``confirm`` (the detector confirms by hits alone), or
            a network of another sensor size than the dataset's.
    """
    if confirm is not None and (not isinstance(confirm, Confirm) or confirm.fast is not None):
        raise ParameterError(
            f"the detector confirms tracks by HITS/WINDOWS alone, got confirm={confirm!r}"
        )
    clips = clip_set(dataset, split, videos)
    size = (int(network.config["width"]), int(network.config["height"]))
    if size != clips.sensor:
        raise ParameterError(
            f"the network takes a {size[0]}x{size[1]} sensor, the dataset's clips are "
            f"{clips.sensor[0]}x{clips.sensor[1]}"
        )
    pair = None if confirm is None else confirm.pair
    shared = runner.put(network)
    rows = list(
        runner.imap(stream_clip, [(shared, clips, k, pair) for k in range(len(clips.clips))])
    )
    rules = list(alarm_rules(network, pair or DEFAULT_CONFIRM))
    return clip_figures(rows, rules) | {
        "split": split,
        "confirm": str(confirm or Confirm.of_pair(DEFAULT_CONFIRM)),
        "per_clip": rows,
    }


def _percent(n: int, of: int) -> str:
    return f"{n} of {of}" + (f" ({100 * n / of:.1f} %)" if of else "")


def _size(px: float | None) -> str:
    return "size unknown" if px is None else f"{px:.1f} px"


def _events(n: float | None) -> str:
    if n is None:
        return "no labelled UAV window"
    return f"{n:g} {'event' if n == 1 else 'events'} per window on it"


def clip_table(figures: dict[str, Any]) -> str:
    """Markdown tables of :func:`evaluate_clips`' figures: one row per rule, then the clips
    of each class decided UAV."""
    uav, clips = figures["uav_clips"], figures["clips"]
    lines = [
        "| rule | clips decided right | balanced | UAV clips alarmed (found on the UAV) "
        "| other clips without an alarm | time to first alarm from the first UAV window, "
        "median / 90th pct (ms) "
        "| false tracks per minute of other clips (95 % upper bound) |",
        "|---|---|---|---|---|---|---|",
    ]
    for rule, f in figures["rules"].items():
        t = f["time_to_alarm_ms"]
        med = "–" if t["median"] is None else f"{ms_text(t['median'])} / {ms_text(t['p90'])}"
        rate = f["false_tracks_per_minute"]
        per_minute = (
            "–" if rate is None else f"{rate:.2f} ({f['false_tracks_per_minute_upper95']:.2f})"
        )
        lines.append(
            f"| {rule_name(rule)} | **{_percent(f['right'], clips)}** "
            f"| {100 * f['balanced_accuracy']:.1f} % "
            f"| {f['uav_alarmed']} of {uav} ({f['found']}) "
            f"| {f['other_quiet']} of {clips - uav} | {med} | {per_minute} |"
        )
    classes = sorted({c for f in figures["rules"].values() for c in f["per_class"]})
    lines += [
        "",
        "Clips decided UAV, per class:",
        "",
        "| rule | " + " | ".join(classes) + " |",
        "|---|" + "---|" * len(classes),
    ]
    for rule, f in figures["rules"].items():
        per_class = f["per_class"]
        cells = [f"{per_class[c]['decided_uav']} of {per_class[c]['recordings']}" for c in classes]
        lines.append(f"| {rule_name(rule)} | " + " | ".join(cells) + " |")
    missed = [
        f"{r['clip']} ({_size(r['uav_size_px'])}, {_events(r['uav_events_per_window'])})"
        for r in figures.get("per_clip", [])
        if r["uav"] and not r["rules"]["any_spike"]["alarmed"]
    ]
    if missed:
        lines.append(
            "\nUAV clips where no track alarmed by the any-spike rule (the labelled UAV's "
            "median size, and the median events of a UAV window on its box): "
            + ", ".join(missed)
            + "."
        )
    lines += [
        "",
        f"{clips} clips ({uav} with a UAV), {figures['minutes']:.1f} minutes, "
        f"{figures['windows']:,} windows streamed (every window of each clip up to its last "
        f"event); tracks confirmed at {figures['confirm']}; the time to first alarm runs from "
        f"the start of each UAV clip's first UAV window ({UAV_WINDOW_TEXT}) to the end of the "
        "window where an alarming track first meets the UAV. A false track here is an alarming "
        "track of a clip without a UAV, per minute of those clips (the windowed tracks of "
        "`uavsnn evaluate --tracks` count one whose alarm window holds no UAV, in any "
        "recording, per minute of UAV-free windows).",
    ]
    return "\n".join(lines)
