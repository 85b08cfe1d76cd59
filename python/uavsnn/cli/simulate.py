"""``uavsnn simulate``: turn a video into an event recording (``.npz``), optionally with a PNG
strip of event frames to look at.

Examples::

    uavsnn simulate clip.mp4 -o clip.npz --mode sim --size 240x180 --preview clip.png
    uavsnn simulate render.avi -o render.npz --mode dvs --seed 3 --json
    uavsnn simulate long.mp4 -o part.npz --start 600 --max-frames 300   # 10 s from 10 min in
    uavsnn simulate clip.mp4 -o clip.npz --pix2nvs-compat --reference event_increment
    uavsnn simulate --scene uav -o uav.npz --seed 3        # a sampled "dvs" scene
    uavsnn simulate --scene scene.json -o scene.npz         # a scene described in JSON
    uavsnn simulate --scene insect -o i.npz --size 1280x720 --lens 1.4   # through a lens

A scene (``--scene``) is rendered and recorded by :func:`uavsnn.scenes.record`; its per-frame
labels go beside the events, in ``OUTPUT.labels.npz`` (``timestamps_us``, ``labels``).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from dataclasses import asdict, fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn import _jsonout
from uavsnn._files import write_atomic
from uavsnn.cli._camera import add_camera_options
from uavsnn.errors import ParameterError
from uavsnn.events import Recording
from uavsnn.sim import SCENE_PARAMS, DvsParams, Pix2NvsParams, video_to_recording, write_preview
from uavsnn.sim.checks import check_size
from uavsnn.sim.video import check_fps, check_start

__all__ = ["register", "run", "write_recording"]


def register(subparsers: Any) -> None:
    """Add the ``simulate`` sub-command."""
    parser = subparsers.add_parser(
        "simulate",
        help="turn a video into events (PIX2NVS 'sim' or DVS emulation 'dvs')",
        description=(
            "Turn a video into an event recording. 'sim' is PIX2NVS as the paper used it "
            "(simulated at full resolution, events pooled onto the sensor); 'dvs' emulates a "
            "DVS with noise on frames resized to the sensor."
        ),
    )
    parser.add_argument("video", type=Path, nargs="?", help="input video (any format OpenCV reads)")
    parser.add_argument(
        "--scene",
        default=None,
        help="instead of a video: a scene kind to sample (uav, object, empty, or an object "
        "kind) or a JSON file describing a scene (uavsnn.scenes.spec_to_dict's form)",
    )
    parser.add_argument(
        "--duration", type=float, default=None, help="sampled scene's length in seconds (1)"
    )
    add_camera_options(parser, "--scene")
    parser.add_argument("-o", "--output", type=Path, required=True, help="output .npz")
    parser.add_argument(
        "--mode",
        choices=("sim", "dvs"),
        default=None,
        help="a video's simulator (sim, the default); --scene is always dvs",
    )
    parser.add_argument(
        "--size",
        help="sensor WIDTHxHEIGHT (240x180; a JSON scene's own width and height where it gives "
        "them)",
    )
    parser.add_argument("--seed", type=int, default=0, help="seed of the dvs noise (0)")
    parser.add_argument(
        "--downsample",
        choices=("events", "frames"),
        default=None,
        help="sim only: pool events after simulating at full resolution (events, default) "
        "or resize frames first (frames)",
    )
    model = parser.add_argument_group(
        "PIX2NVS model (sim only; defaults: the documented model, docs/simulation.md)"
    )
    model.add_argument(
        "--pix2nvs-compat",
        action="store_true",
        help="reproduce the released PIX2NVS program's events exactly, quirks included "
        "(its luma read two bytes late, log without offset, adaptive 0.05 by default)",
    )
    model.add_argument("--threshold", type=float, help="threshold on the log change (0.4)")
    model.add_argument("--n-max", type=int, help="events per pixel per frame at most (5)")
    model.add_argument(
        "--reference",
        choices=("frame", "event_copy", "event_increment"),
        help="reference update, PIX2NVS -r 1/2/3 (frame)",
    )
    model.add_argument("--block-size", type=int, help="local inhibition block side (1: none)")
    model.add_argument(
        "--adaptive", type=float, help="adaptive threshold step (0; 0.05 with --pix2nvs-compat)"
    )
    model.add_argument("--threshold-min", type=float, help="adaptive threshold floor (0)")
    model.add_argument("--threshold-max", type=float, help="adaptive threshold ceiling (none)")
    model.add_argument("--log-offset", type=float, help="added to luma before the log (1)")
    dvs = parser.add_argument_group(
        "DVS model (--mode dvs and --scene; defaults: a DAVIS240-like sensor for a video, the "
        "scenes' sensor for --scene, docs/simulation.md)"
    )
    dvs.add_argument(
        "--dvs-preset",
        choices=tuple(DVS_PRESETS),
        help="the sensor to start from: default (uavsnn.sim.DvsParams()), scene "
        "(SCENE_PARAMS: a 3 kHz photoreceptor), ideal, noisy (v2e's) or gen3 (a Prophesee "
        "Gen3-like sensor)",
    )
    dvs.add_argument(
        "--dvs-set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="set one field of the sensor (uavsnn.sim.DvsParams: threshold_on, cutoff_hz, "
        "leak_rate_hz, ...); repeat for more",
    )
    parser.add_argument(
        "--start",
        type=float,
        default=None,
        metavar="SECONDS",
        help="begin at the first frame at or after this time of the video (frames before it are "
        "decoded and dropped); the events keep the video's time (default: its first frame)",
    )
    parser.add_argument(
        "--max-frames", type=int, default=None, help="stop after N frames (from --start)"
    )
    parser.add_argument(
        "--fps",
        type=float,
        default=None,
        help="override the video's rate (1 to 1,000,000 frames per second)",
    )
    parser.add_argument("--preview", type=Path, default=None, help="write a PNG strip here")
    parser.add_argument("--json", action="store_true", help="print a JSON summary")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.set_defaults(handler=run)


def write_recording(recording: Recording, path: Path) -> None:
    """Write ``recording`` as ``.npz`` (arrays ``events``, ``sensor_size``, and ``metadata`` as
    JSON text) atomically: :func:`uavsnn.io.write_npz`."""
    from uavsnn.io import write_npz

    write_npz(recording, path)


#: The sensor of ``--size`` when neither it nor a JSON scene gives one.
_SIZE = "240x180"


def _fill_size(data: dict[str, Any], size: tuple[int, int], *, given: bool) -> None:
    """A JSON scene ``data``'s ``width`` and ``height``, filled in from ``size`` (``--size``'s,
    or the default) where it leaves both out; where it gives them and ``--size`` was
    ``given``, the two must agree (without ``--size`` the scene is recorded at its own)."""
    has = [key for key in ("width", "height") if key in data]
    if not has:
        data["width"], data["height"] = size
    elif len(has) == 1:
        other = "height" if has[0] == "width" else "width"
        raise ParameterError(
            f"the scene gives {has[0]} and not {other}: give both, or leave both out for --size's"
        )
    elif given and (data["width"], data["height"]) != size:
        raise ParameterError(
            f"the scene's width and height are {data['width']}x{data['height']}, --size "
            f"{size[0]}x{size[1]}: leave --size out to record at the scene's size, or edit "
            "the scene's"
        )


def _scene(args: argparse.Namespace, size: tuple[int, int]) -> Recording:
    """Record the scene ``--scene`` names; its labels go beside the output."""
    from uavsnn.cli._camera import fov_option, lens_option, through_lens
    from uavsnn.scenes import OBJECT_KINDS, SCENE_KINDS, record, sample_spec, spec_from_dict

    lens = lens_option(args.lens, args.focus_m)
    fov = fov_option(args.fov)
    if args.scene.lower().endswith(".json"):
        if fov is not None:
            raise ParameterError("--fov draws a sampled scene's view; a JSON scene has its own")
        if args.duration is not None:
            raise ParameterError(
                "--duration sets a sampled scene's length; a JSON scene has its own"
            )
        try:
            data = json.loads(Path(args.scene).read_text(encoding="utf-8"))
        except (OSError, ValueError, RecursionError) as exc:
            # RecursionError: arrays or objects nested too deep for the JSON parser.
            what = "nested too deep" if isinstance(exc, RecursionError) else exc
            raise ParameterError(f"cannot read the scene {args.scene}: {what}") from exc
        if isinstance(data, dict):
            _fill_size(data, size, given=args.size is not None)
        spec = spec_from_dict(data)
        size = (spec.width, spec.height)
    elif args.scene in SCENE_KINDS or args.scene in OBJECT_KINDS:
        rng = np.random.default_rng(args.seed)
        duration = 1.0 if args.duration is None else args.duration
        spec = sample_spec("dvs", args.scene, rng, size=size, duration_s=duration, fov_deg=fov)
    else:
        kinds = ", ".join((*SCENE_KINDS, *OBJECT_KINDS))
        raise ParameterError(f"--scene must be a .json file or one of {kinds}, got {args.scene}")
    spec = through_lens(spec, lens, size)
    params = dvs_params(args, "scene") or SCENE_PARAMS
    out = record(spec, sensor=size, seed=args.seed, params=params)
    labels_path = args.output.with_suffix(".labels.npz")
    write_atomic(
        labels_path, lambda f: np.savez(f, timestamps_us=out.timestamps_us, labels=out.labels)
    )
    meta = dict(
        out.recording.metadata,
        frames=spec.n_frames,
        labels=str(labels_path),
        params=asdict(params),  # the sensor, as a video's recording names it
    )
    return Recording(out.recording.events, out.recording.sensor_size, meta)


_MODEL_OPTIONS = (
    "threshold",
    "n_max",
    "reference",
    "block_size",
    "adaptive",
    "threshold_min",
    "threshold_max",
    "log_offset",
)


def pix2nvs_params(args: argparse.Namespace) -> Pix2NvsParams | None:
    """The PIX2NVS parameters the options ask for (``None``: none given, the defaults).

    Raises:
        ParameterError: model options with ``--mode dvs``, or impossible values.
    """
    given = {k: getattr(args, k) for k in _MODEL_OPTIONS if getattr(args, k, None) is not None}
    compat = bool(getattr(args, "pix2nvs_compat", False))
    if not given and not compat:
        return None
    if args.mode != "sim":
        names = ["--" + k.replace("_", "-") for k in given] + (["--pix2nvs-compat"] * compat)
        raise ParameterError(f"{', '.join(names)} set PIX2NVS, which only --mode sim uses")
    return Pix2NvsParams.original(**given) if compat else Pix2NvsParams(**given)


#: Below this frame rate ``--mode dvs`` notes that the video holds no fast flicker.
SLOW_FPS = 200.0

#: The sensors ``--dvs-preset`` starts from, each taking the fields ``--dvs-set`` gives.
DVS_PRESETS: dict[str, Callable[..., DvsParams]] = {
    "default": DvsParams,
    "scene": lambda **given: replace(SCENE_PARAMS, **given),
    "ideal": DvsParams.ideal,
    "noisy": DvsParams.noisy,
    "gen3": DvsParams.gen3,
}


def dvs_params(args: argparse.Namespace, preset: str) -> DvsParams | None:
    """The DVS sensor ``--dvs-preset`` and ``--dvs-set`` ask for (``None``: neither given, the
    caller's default); ``preset`` is the one to start from when ``--dvs-preset`` is not given.

    Raises:
        ParameterError: ``--dvs-*`` with ``--mode sim``, a field that ``DvsParams`` does not
            have or a value that is not a number, or an impossible value.
    """
    chosen = getattr(args, "dvs_preset", None)
    settings = getattr(args, "dvs_set", None) or []
    if chosen is None and not settings:
        return None
    if args.mode == "sim":
        raise ParameterError(
            "--dvs-preset and --dvs-set set the DVS model, which --mode sim does not use"
        )
    names = {f.name for f in fields(DvsParams)}
    given: dict[str, float] = {}
    for item in settings:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or name not in names:
            known = ", ".join(sorted(names))
            raise ParameterError(
                f"--dvs-set {item!r}: expected NAME=VALUE with NAME one of {known}"
            )
        try:
            given[name] = float(value)
        except ValueError as exc:
            raise ParameterError(f"--dvs-set {item!r}: {value!r} is not a number") from exc
    return DVS_PRESETS[chosen or preset](**given)


def run(args: argparse.Namespace) -> int:
    """Handler of ``uavsnn simulate``."""
    size = check_size(args.size or _SIZE)
    if args.output.suffix.lower() != ".npz":
        print(
            f"uavsnn simulate: error: output must end in .npz, got {args.output}", file=sys.stderr
        )
        return 2
    if args.video is None and args.scene is None:
        raise ParameterError("give a video to simulate, or --scene to render and record one")
    if args.video is not None and args.scene is not None:
        raise ParameterError("give a video or --scene, not both")
    _check_outputs(args)  # before any work: a refusal writes nothing
    if args.scene is not None:
        _check_scene_options(args)
        args.mode = "dvs"
        recording = _scene(args, size)
    elif args.lens is not None or args.focus_m is not None or args.fov is not None:
        raise ParameterError("--lens, --focus-m and --fov are for --scene (a rendered scene)")
    elif args.duration is not None:
        raise ParameterError(
            "--duration sets a --scene's length; a video runs whole (--start and --max-frames "
            "cut it)"
        )
    else:
        args.mode = args.mode or "sim"
        if args.fps is not None:
            check_fps(args.fps, "--fps")
        if args.start is not None:
            check_start(args.start, "--start")
        # Each refuses its options with the other mode.
        pix2nvs, dvs = pix2nvs_params(args), dvs_params(args, "default")
        recording = _video(args, size, dvs if args.mode == "dvs" else pix2nvs)
    return _finish(args, recording)


def _check_outputs(args: argparse.Namespace) -> None:
    """The output's and the preview's folders exist, neither is a folder itself, and the preview
    is a PNG.

    Raises:
        ParameterError: otherwise.
    """
    for flag, path in (("-o", args.output), ("--preview", args.preview)):
        if path is not None and not path.parent.is_dir():
            raise ParameterError(f"{flag} {path}: the folder {path.parent} does not exist")
        if path is not None and path.is_dir():
            raise ParameterError(f"{flag} {path}: is a folder, not a file")
    if args.preview is not None and args.preview.suffix.lower() != ".png":
        raise ParameterError(f"--preview must be a .png file, got {args.preview}")


def _check_scene_options(args: argparse.Namespace) -> None:
    """Refuse the options of a video with ``--scene``, which records through the DVS emulator.

    Raises:
        ParameterError: ``--mode sim``, a PIX2NVS option, ``--downsample``, ``--start``,
            ``--max-frames`` or ``--fps`` with ``--scene``.
    """
    given = ["--" + k.replace("_", "-") for k in _MODEL_OPTIONS if getattr(args, k) is not None]
    given += ["--pix2nvs-compat"] * bool(args.pix2nvs_compat)
    given += ["--mode sim"] * (args.mode == "sim")
    video_options = {
        "--downsample": args.downsample,
        "--start": args.start,
        "--max-frames": args.max_frames,
        "--fps": args.fps,
    }
    given += [flag for flag, value in video_options.items() if value is not None]
    if given:
        raise ParameterError(
            f"{', '.join(given)}: for a video; --scene records a rendered scene through the "
            "DVS emulator (--mode dvs) at the scene's own frame rate"
        )


def _video(
    args: argparse.Namespace, size: tuple[int, int], params: Pix2NvsParams | DvsParams | None
) -> Recording:
    return video_to_recording(
        args.video,
        args.mode,
        size,
        args.seed,
        downsample=args.downsample,
        max_frames=args.max_frames,
        fps=args.fps,
        start=args.start,
        params=params,
        progress=not (args.quiet or args.json),
    )


def _finish(args: argparse.Namespace, recording: Recording) -> int:
    write_recording(recording, args.output)
    if args.preview is not None:
        write_preview(recording, args.preview)
    ev = recording.events
    duration_s = recording.metadata["frames"] / recording.metadata["fps"]
    summary = {
        "output": str(args.output),
        "preview": None if args.preview is None else str(args.preview),
        "mode": args.mode,
        "sensor_size": list(recording.sensor_size),
        "frames": recording.metadata["frames"],
        "start_s": recording.metadata.get("start_s"),
        "events": len(ev),
        "on_fraction": float(ev["p"].mean()) if len(ev) else 0.0,
        "events_per_second": len(ev) / duration_s if duration_s > 0 else 0.0,
        "seed": args.seed,
        "params": recording.metadata.get("params"),
        "upscaled_from": recording.metadata.get("upscaled_from"),
    }
    rate = float(recording.metadata["fps"])
    if args.video is not None and args.mode == "dvs" and rate < SLOW_FPS:
        # The emulator interpolates between frames: nothing faster than half their rate is in
        # the events (a rotor's blade pass is hundreds of hertz).
        print(
            f"uavsnn simulate: note: the video's {rate:g} fps frames hold nothing faster than "
            f"{rate / 2:g} Hz, which the DVS emulator cannot bring back (a rotor's blade pass is "
            "hundreds of hertz: docs/simulation.md)",
            file=sys.stderr,
        )
    up = summary["upscaled_from"]
    if up is not None:
        w, h = recording.sensor_size
        print(
            f"uavsnn simulate: note: the video's {up[0]}x{up[1]} crop is smaller than the "
            f"{w}x{h} sensor: its frames were scaled up, so the events are those of a "
            f"{up[0]}x{up[1]} sensor spread over {w}x{h} (give --size {up[0]}x{up[1]} or "
            "less for the video's own pixels)",
            file=sys.stderr,
        )
    if args.json:
        print(_jsonout.document(summary, indent=None))
    else:
        print(
            f"{summary['events']} events from {summary['frames']} frames "
            f"({summary['events_per_second']:.0f} ev/s, {summary['on_fraction']:.0%} ON) "
            f"-> {args.output}"
        )
    return 0
