"""Ordinary video in, events out: reading through OpenCV and the whole video-to-recording path.

Frames are cropped, centred, to the aspect ratio of the target sensor (4:3 for the default
240×180) and resized with area averaging (``cv2.INTER_AREA``: a larger pixel integrates the
light of the smaller ones it covers). Frame ``i`` is at ``round(i · 10⁶ / fps)`` µs, with ``fps``
from the container unless given (:data:`FPS_RANGE`), ``i`` counted from the video's first frame
also when reading starts later (``start``).

Where the down-sampling happens is a parameter of :func:`video_to_recording`:

- ``"events"`` (default for ``mode="sim"``): what Kirkland et al. did — simulate PIX2NVS on the
  full-resolution (cropped) frames and pool the events onto the sensor afterwards;
- ``"frames"`` (always for ``mode="dvs"``): resize the frames to the sensor first, then simulate
  at sensor size — the physical picture of a sensor with larger pixels, and much cheaper.
"""

from __future__ import annotations

import itertools
import math
import queue
import sys
import threading
from collections.abc import Callable, Iterable, Iterator
from dataclasses import asdict
from pathlib import Path
from typing import Any, Literal

import cv2
import numpy as np

from uavsnn._validate import MAX_TIME_US, check_path
from uavsnn.errors import ParameterError, SimulationError
from uavsnn.events import EVENT_DTYPE, Recording
from uavsnn.sim.checks import check_choice, check_int, check_real, check_seed, check_size
from uavsnn.sim.dvs import DvsEmulator, DvsParams
from uavsnn.sim.pix2nvs import POOLING_MODES, Pix2NvsParams, Pix2NvsSimulator

__all__ = [
    "FPS_RANGE",
    "VideoInfo",
    "check_fps",
    "check_start",
    "crop_to_aspect",
    "iter_video",
    "prefetch",
    "probe_video",
    "read_video",
    "video_to_recording",
]

Color = Literal["gray", "bgr"]

#: Decoded frames held ahead of the simulator.
PREFETCH_FRAMES = 4

#: The frame rates ``fps=`` (``uavsnn simulate --fps``) may give: at least one frame a second
#: (the scenes' lowest rate; at 10^-6 fps the frames were 11.6 days apart), at most one a
#: microsecond (the events' time resolution).
FPS_RANGE = (1.0, 1e6)


def check_fps(fps: Any, name: str = "fps") -> float:
    """``fps`` as ``float``, if it is a frame rate in :data:`FPS_RANGE`; else a
    :class:`~uavsnn.ParameterError` naming ``name`` and the range."""
    low, high = FPS_RANGE
    try:
        return check_real(name, fps, low=low, high=high)
    except ParameterError as exc:
        raise ParameterError(
            f"{exc}: a frame rate is from {low:,.0f} to {high:,.0f} frames per second (at "
            "most a frame a microsecond, the events' time resolution)"
        ) from exc


def check_start(start: Any, name: str = "start") -> float:
    """``start`` as ``float``, if it is a time in seconds from 0 to the engine's latest
    (2^62 µs); else a :class:`~uavsnn.ParameterError` naming ``name``."""
    return check_real(name, start, low=0.0, high=MAX_TIME_US / 1e6)


def _first_frame(start: float, fps: float) -> int:
    """The index of the first frame at or after ``start`` seconds, frame ``i`` being at
    ``round(i · 10⁶ / fps)`` µs (compared in whole µs, so that 0.4 s at 25 fps is frame 10)."""
    start_us = round(start * 1e6)
    i = max(0, math.ceil(start_us * fps / 1e6) - 1)
    while round(i * 1e6 / fps) < start_us:
        i += 1
    return i


def crop_to_aspect(frame: np.ndarray, aspect: float) -> np.ndarray:
    """The largest centred crop of ``frame`` (``(h, w)`` or ``(h, w, c)``) whose width/height
    is ``aspect``; a view, no copy."""
    h, w = frame.shape[:2]
    cw, ch = _crop_size((w, h), aspect)
    x0, y0 = (w - cw) // 2, (h - ch) // 2
    return frame[y0 : y0 + ch, x0 : x0 + cw]


def _crop_size(size: tuple[int, int], aspect: float) -> tuple[int, int]:
    """The ``(width, height)`` of :func:`crop_to_aspect`'s crop of a frame of ``size``."""
    w, h = size
    if w / h > aspect:
        return min(w, max(1, round(h * aspect))), h
    return w, min(h, max(1, round(w / aspect)))


class VideoInfo:
    """What OpenCV reports about a video: ``width``, ``height``, ``fps``, ``frame_count``
    (an estimate from the container; 0 when unknown)."""

    def __init__(self, width: int, height: int, fps: float, frame_count: int) -> None:
        self.width = width
        self.height = height
        self.fps = fps
        self.frame_count = frame_count

    def __repr__(self) -> str:
        return (
            f"VideoInfo(width={self.width}, height={self.height}, fps={self.fps}, "
            f"frame_count={self.frame_count})"
        )


def _open(path: str | Path) -> cv2.VideoCapture:
    p = Path(check_path(path))
    if not p.exists():
        raise SimulationError(f"video {str(p)!r} does not exist")
    if not p.is_file():
        raise SimulationError(f"video {str(p)!r} is not a file")
    if p.stat().st_size == 0:
        # Refused before FFmpeg sees it: FFmpeg would print its own line ("moov atom not found")
        # to standard error, past OpenCV's logging, before this one.
        raise SimulationError(f"cannot read {str(p)!r} as a video (the file is empty)")
    try:
        # Opened here first: OpenCV would print its own warning ("can't open/read file") to
        # standard error, and then report no more than an unknown format.
        with open(p, "rb"):
            pass
    except OSError as exc:
        why = "permission denied" if isinstance(exc, PermissionError) else exc.strerror or exc
        raise SimulationError(f"cannot read {str(p)!r} ({why})") from exc
    cap = cv2.VideoCapture(str(p))
    if not cap.isOpened():
        cap.release()
        why = "unknown format or corrupt"
        if sys.platform == "win32" and not str(p).isascii():
            why += "; or its path, which is not ASCII: OpenCV cannot open such a path on Windows"
        raise SimulationError(f"cannot read {str(p)!r} as a video ({why})")
    return cap


def _fps(cap: cv2.VideoCapture, fps: float | None, path: str | Path) -> float:
    """``fps`` (checked by :func:`iter_video`), else the container's frame rate, which must lie
    in :data:`FPS_RANGE` as a given one must."""
    if fps is not None:
        return fps
    reported = float(cap.get(cv2.CAP_PROP_FPS))
    low, high = FPS_RANGE
    if not math.isfinite(reported) or not low <= reported <= high:
        raise SimulationError(
            f"{str(path)!r} reports no usable frame rate ({reported:g} fps; a frame rate is "
            f"from {low:,.0f} to {high:,.0f} frames per second); give the rate its frames were "
            "taken at (fps=, uavsnn simulate --fps)"
        )
    return reported


def _memory_limit() -> int | None:
    """``uavsnn.windows.MEMORY_LIMIT``, read when it is needed (a test may change it)."""
    from uavsnn import windows

    return windows.MEMORY_LIMIT


def _check_frame_memory(target: tuple[int, int], color: str) -> None:
    """Refuse, before any frame is read, frames resized to ``target`` whose bytes (the
    resized BGR frame, and for ``"gray"`` its gray copy) exceed
    ``uavsnn.windows.MEMORY_LIMIT``."""
    limit = _memory_limit()
    width, height = target
    need = width * height * (4 if color == "gray" else 3)
    if limit is not None and need > limit:
        raise ParameterError(
            f"size={width}x{height}: a frame resized to it takes {need / 2**30:.2f} GiB (BGR"
            f"{' and gray' if color == 'gray' else ''}), more than the {limit / 2**30:.2f} "
            "GiB allowed (uavsnn.windows.MEMORY_LIMIT): give a smaller size"
        )


def probe_video(path: str | Path) -> VideoInfo:
    """Open a video and report its size, frame rate and (estimated) frame count."""
    cap = _open(path)
    try:
        return VideoInfo(
            int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)),
            int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)),
            float(cap.get(cv2.CAP_PROP_FPS)),
            max(0, int(cap.get(cv2.CAP_PROP_FRAME_COUNT))),
        )
    finally:
        cap.release()


def iter_video(
    path: str | Path,
    *,
    size: tuple[int, int] | None = (240, 180),
    max_frames: int | None = None,
    color: Color = "gray",
    fps: float | None = None,
    resize: bool = True,
    start: float | None = None,
) -> Iterator[tuple[np.ndarray, int]]:
    """Yield ``(frame, t_us)`` one frame at a time.

    Args:
        path: any file OpenCV's FFmpeg back end reads (mp4, avi, mkv, mov, ...).
        size: ``(width, height)`` to crop (centred, to its aspect ratio) and resize to;
            ``None`` keeps frames as decoded (then they must all have one size).
        max_frames: stop after this many frames (from ``start``).
        color: ``"gray"`` (OpenCV's BT.601 luma rounded to ``uint8``) or ``"bgr"`` (``uint8``,
            3 channels; the simulators then take luma in floating point, as PIX2NVS does —
            :func:`video_to_recording` reads BGR for that reason).
        fps: frame rate to assume, overriding the container's; in :data:`FPS_RANGE`.
        resize: with ``size``, ``False`` only crops to its aspect ratio (for simulating at full
            resolution and pooling the events afterwards).
        start: begin at the first frame at or after this time in seconds, on the frames' own
            time (frame ``i`` at ``i / fps``: ``fps``'s when given). The frames before it are
            decoded and dropped (exact, where OpenCV's seek lands a few frames off in some
            H.264 files); the frames keep their times, ``t_us`` starting near ``start``.

    Raises:
        SimulationError: a missing, unreadable or empty video, no usable frame rate, frames
            that change size when ``size`` is ``None`` (as the frames are read).
        ParameterError: a bad parameter, or frames resized to ``size`` that would not fit in
            ``uavsnn.windows.MEMORY_LIMIT`` (at the call, before a frame is read); a ``path``
            that is not a ``str`` or ``os.PathLike[str]``, or a ``start`` at or past the
            video's end (at the first frame).
    """
    check_choice("color", color, ("gray", "bgr"))
    target = None if size is None else check_size(size)
    limit = None if max_frames is None else check_int("max_frames", max_frames, low=1, high=2**62)
    rate = None if fps is None else check_fps(fps)
    begin = None if start is None else check_start(start)
    if target is not None and resize:
        _check_frame_memory(target, color)
    return _frames(path, target, limit, color, rate, resize, begin)


def _frames(
    path: str | Path,
    target: tuple[int, int] | None,
    limit: int | None,
    color: Color,
    fps: float | None,
    resize: bool,
    start: float | None,
) -> Iterator[tuple[np.ndarray, int]]:
    """:func:`iter_video`'s frames, its arguments checked."""
    cap = _open(path)
    try:
        rate = _fps(cap, fps, path)
        first = 0 if start is None else _first_frame(start, rate)
        i = 0
        while i < first and cap.grab():
            i += 1  # decoded and dropped (not converted): exact, where a seek may land off
        first_shape: tuple[int, ...] | None = None
        while i >= first and (limit is None or i - first < limit):
            ok, frame = cap.read()
            if not ok or frame is None:
                break
            if first_shape is None:
                first_shape = frame.shape
            elif frame.shape != first_shape and target is None:
                raise SimulationError(
                    f"frame {i} of {str(path)!r} is {frame.shape[1]}x{frame.shape[0]}, the "
                    f"first was {first_shape[1]}x{first_shape[0]}; give size= to resize them"
                )
            if frame.ndim == 2:
                frame = cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR)
            if target is not None:
                frame = crop_to_aspect(frame, target[0] / target[1])
                if resize and frame.shape[1::-1] != target:
                    frame = cv2.resize(frame, target, interpolation=cv2.INTER_AREA)
            if color == "gray":
                frame = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
            yield frame, round(i * 1e6 / rate)
            i += 1
        if i == 0:
            raise SimulationError(f"no frame could be decoded from {str(path)!r} (empty video?)")
        if i <= first:
            raise _past_end(start, path, i, rate)
    finally:
        cap.release()


def _past_end(start: float | None, path: str | Path, frames: int, fps: float) -> ParameterError:
    """The error of a ``start`` at or past the end of a video of ``frames`` frames."""
    return ParameterError(
        f"start={start:g} s (uavsnn simulate --start) is at or past the end of {str(path)!r}: "
        f"its {frames} frames last {frames / fps:g} s at {fps:g} fps"
    )


def prefetch(items: Iterable[Any], depth: int = PREFETCH_FRAMES) -> Iterator[Any]:
    """Iterate ``items`` from a background thread, ``depth`` items ahead.

    OpenCV's decoder and the engine both release the GIL, so decoding the next frames overlaps
    with simulating the current one. An exception in the producer is raised here; stopping
    early stops the producer.
    """
    slots: queue.Queue[tuple[bool, Any]] = queue.Queue(maxsize=depth)
    stop = threading.Event()

    def produce() -> None:
        try:
            for item in items:
                while not stop.is_set():
                    try:
                        slots.put((True, item), timeout=0.1)
                        break
                    except queue.Full:
                        continue
                if stop.is_set():
                    return
            slots.put((False, None))
        except BaseException as exc:  # handed to the consumer, raised there
            slots.put((False, exc))

    worker = threading.Thread(target=produce, name="uavsnn-video-reader", daemon=True)
    worker.start()
    try:
        while True:
            more, item = slots.get()
            if not more:
                if item is not None:
                    raise item
                return
            yield item
    finally:
        stop.set()
        while worker.is_alive():
            try:
                slots.get_nowait()
            except queue.Empty:
                worker.join(timeout=0.05)


def read_video(
    path: str | Path,
    *,
    size: tuple[int, int] | None = (240, 180),
    max_frames: int | None = None,
    color: Color = "gray",
    fps: float | None = None,
    start: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Read a whole video (from ``start``, see :func:`iter_video`): ``(frames, timestamps_us)``.

    ``frames`` is ``(n, h, w)`` ``uint8`` gray or ``(n, h, w, 3)`` BGR, cropped to the aspect
    ratio of ``size`` and resized to it (see :func:`iter_video`); ``timestamps_us`` is
    ``(n,)`` ``uint64``. For long or large videos prefer :func:`iter_video` or
    :func:`video_to_recording`, which stream.

    Raises:
        SimulationError: as :func:`iter_video`.
        ParameterError: as :func:`iter_video`, or frames that would not fit in
            ``uavsnn.windows.MEMORY_LIMIT`` all together (twice: as read, then stacked),
            refused before the frame that would pass it is kept.
    """
    frames: list[np.ndarray] = []
    times: list[int] = []
    limit = _memory_limit()
    held = 0
    stream = iter_video(path, size=size, max_frames=max_frames, color=color, fps=fps, start=start)
    for frame, t in stream:
        held += frame.nbytes
        if limit is not None and 2 * held > limit:
            raise ParameterError(
                f"read_video holds every frame: {len(frames) + 1} frames of "
                f"{frame.shape[1]}x{frame.shape[0]} would take {2 * held / 2**30:.2f} GiB (read, "
                f"then stacked), more than the {limit / 2**30:.2f} GiB allowed "
                "(uavsnn.windows.MEMORY_LIMIT): give fewer max_frames or a smaller size, or "
                "stream the video (iter_video, video_to_recording)"
            )
        frames.append(frame)
        times.append(t)
    return np.stack(frames), np.asarray(times, dtype=np.uint64)


def video_to_recording(
    path: str | Path,
    mode: Literal["sim", "dvs"] = "sim",
    size: tuple[int, int] = (240, 180),
    seed: int = 0,
    *,
    params: Pix2NvsParams | DvsParams | None = None,
    downsample: Literal["events", "frames"] | None = None,
    pooling: Literal["strongest", "all"] = "strongest",
    max_frames: int | None = None,
    fps: float | None = None,
    progress: bool | Callable[[int], None] = False,
    start: float | None = None,
) -> Recording:
    """Turn a video file into a :class:`~uavsnn.Recording` of ``size``, streaming it.

    Args:
        path: the video.
        mode: ``"sim"`` (PIX2NVS) or ``"dvs"`` (the sensor emulator).
        size: the sensor's ``(width, height)``.
        seed: for the ``"dvs"`` noise; recorded in the metadata in both modes.
        params: :class:`Pix2NvsParams` for ``"sim"``, :class:`DvsParams` for ``"dvs"``.
        downsample: ``"events"`` (simulate at full resolution, pool the events — the paper's
            way, default for ``"sim"``) or ``"frames"`` (resize first; the only choice for
            ``"dvs"``).
        pooling: with ``downsample="events"``, ``"strongest"`` or ``"all"`` (see
            :class:`~uavsnn.sim.Pix2NvsSimulator`).
        max_frames: stop after this many frames (from ``start``).
        fps: frame rate to assume, overriding the container's; in :data:`FPS_RANGE`.
        progress: ``True`` for a progress bar, or a callable given the number of frames done.
        start: begin at the first frame at or after this time in seconds (see
            :func:`iter_video`); the events keep the video's time, so they start near
            ``start``, not at 0.

    The metadata holds the source, mode, seed, parameters, frame rate, frame count (the
    frames read) and down-sampling; with ``start``, also ``start_s`` (``start``) and
    ``start_frame`` (the index of the first frame read).

    Raises:
        ParameterError: a bad parameter, a ``path`` that is not a ``str`` or
            ``os.PathLike[str]``, or a ``start`` at or past the video's end (before the
            progress bar starts).
        SimulationError: as :func:`iter_video`, or frames the simulator cannot take.
    """
    check_choice("mode", mode, ("sim", "dvs"))
    if fps is not None:
        fps = check_fps(fps)
    if start is not None:
        start = check_start(start)
    sensor = check_size(size)
    seed = check_seed(seed)
    check_choice("pooling", pooling, POOLING_MODES)
    if downsample is None:
        downsample = "events" if mode == "sim" else "frames"
    check_choice("downsample", downsample, ("events", "frames"))
    if mode == "dvs" and downsample == "events":
        raise ParameterError(
            "downsample='events' is for mode='sim'; the dvs emulator models the sensor's own "
            "pixels, so it always takes frames resized to the sensor (downsample='frames')"
        )
    expected = Pix2NvsParams if mode == "sim" else DvsParams
    if params is not None and not isinstance(params, expected):
        raise ParameterError(
            f"mode={mode!r} takes {expected.__name__}, got {type(params).__name__}"
        )
    info = probe_video(path)
    sim: Pix2NvsSimulator | DvsEmulator | None = None
    if downsample == "frames":
        # Frames resized to the sensor: its simulator (and the engine's check of its size)
        # before a frame is decoded and resized.
        sim = _simulator(mode, sensor, sensor, params, pooling, seed, downsample)
    stream = iter_video(
        path,
        size=sensor,
        max_frames=max_frames,
        color="bgr",
        fps=fps,
        resize=downsample == "frames",
        start=start,
    )
    # The first frame here, before the progress bar: the frames before a start are decoded
    # then, and a start past the end is refused.
    head = next(stream)
    rate = info.fps if fps is None else fps  # usable: the stream read a frame at it
    first = 0 if start is None else _first_frame(start, rate)
    total = max(info.frame_count - first, 0)
    bar = _progress(progress, total if max_frames is None else max_frames, path)
    chunks: list[np.ndarray] = []
    n = 0
    try:
        # One frame per call: the engine reads the cropped view in place, without a copy.
        for frame, t in prefetch(itertools.chain([head], stream)):
            if sim is None:
                frame_size = (int(frame.shape[1]), int(frame.shape[0]))
                sim = _simulator(mode, frame_size, sensor, params, pooling, seed, downsample)
            chunks.append(sim.process(frame[None], [t]))
            n += 1
            bar(1)
    except BaseException:
        bar(_STOPPED)  # closed without "done": the frames were not all read
        raise
    bar(None)
    if n < 2:
        # Events are changes between frames: one frame (an image, max_frames=1) makes none,
        # and OpenCV gives an image a frame rate of its own.
        since = "" if start is None else f" from start={start:g} s"
        raise SimulationError(
            f"{str(path)!r} gave {n} frame{'s' if n != 1 else ''}{since}: a recording needs at "
            "least 2 (events are the changes between frames; an image is no video)"
        )
    events = np.concatenate(chunks) if chunks else np.zeros(0, dtype=EVENT_DTYPE)
    used = sim.params if sim is not None else expected()
    metadata: dict[str, Any] = {
        "source": str(path),
        "mode": mode,
        "seed": seed,
        "params": asdict(used),
        "fps": float(rate),
        "frames": n,
        "downsample": downsample,
        "pooling": pooling if downsample == "events" else None,
        "video_size": [info.width, info.height],
    }
    if start is not None:
        metadata["start_s"] = start
        metadata["start_frame"] = first
    crop = _crop_size((info.width, info.height), sensor[0] / sensor[1])
    if downsample == "frames" and (crop[0] < sensor[0] or crop[1] < sensor[1]):
        # Frames scaled up: the events are those of a sensor of the crop's size, spread.
        metadata["upscaled_from"] = list(crop)
    return Recording(events, sensor, metadata)


def _simulator(
    mode: str,
    frame_size: tuple[int, int],
    sensor: tuple[int, int],
    params: Any,
    pooling: Any,
    seed: int,
    downsample: str,
) -> Pix2NvsSimulator | DvsEmulator:
    """The simulator of ``mode`` for frames of ``frame_size`` and a ``sensor``."""
    if mode == "dvs":
        return DvsEmulator(sensor, params=params, seed=seed)
    if downsample == "frames":
        return Pix2NvsSimulator(sensor, params=params)
    if frame_size[0] < sensor[0] or frame_size[1] < sensor[1]:
        raise ParameterError(
            f"the video's {frame_size[0]}x{frame_size[1]} crop is smaller than the "
            f"{sensor[0]}x{sensor[1]} sensor; resize the frames instead (downsample='frames', "
            "uavsnn simulate --downsample frames)"
        )
    return Pix2NvsSimulator(frame_size, params=params, output_size=sensor, pooling=pooling)


#: What a :func:`_progress` step is given when the work stopped before its end.
_STOPPED = "stopped"


def _progress(
    progress: bool | Callable[[int], None], total: int, path: str | Path
) -> Callable[[int | str | None], None]:
    """A ``step(n)`` function; ``step(None)`` closes the bar, ``step(_STOPPED)`` closes it
    without its "done" line (the work stopped)."""
    if callable(progress):
        user = progress
        done = [0]

        def step_user(k: int | str | None) -> None:
            if isinstance(k, int):
                done[0] += k
                user(done[0])

        return step_user
    if not progress:
        return lambda k: None
    from uavsnn.progress import bar as new_bar
    from uavsnn.progress import stop

    bar = new_bar(total=total or None, unit="frame", desc=Path(path).name)

    def step_bar(k: int | str | None) -> None:
        if k is None:
            bar.close()
        elif k == _STOPPED:
            stop(bar)
        else:
            bar.update(k)

    return step_bar
