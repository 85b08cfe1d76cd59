"""``uavsnn dataset``: build labelled datasets, look at them, and look at the scenes behind them.

- ``uavsnn dataset build OUT_DIR --domain dvs|sim|real|combined [--videos DIR] ...``
- ``uavsnn dataset demo OUT_DIR`` — the small set that ``uavsnn demo`` uses
- ``uavsnn dataset info DIR [--json]``
- ``uavsnn dataset preview OUT.png --domain dvs --kind uav [--sensor WxH] [--lens F] [--fov LO,HI]``
  — a contact sheet of a scene
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn import _jsonout
from uavsnn._files import check_output_dir
from uavsnn.cli import counted
from uavsnn.cli._camera import add_camera_options, fov_option, lens_option, through_lens
from uavsnn.dataset import (
    DATASET_DOMAINS,
    TEST_FRACTION,
    DatasetPaths,
    SceneSource,
    build,
    build_demo,
    default_source,
    parse_sensor,
    read_manifest,
)
from uavsnn.distributed import add_ray_option, runner_for
from uavsnn.errors import DatasetError, ParameterError
from uavsnn.scenes import (
    OBJECT_KINDS,
    SCENE_KINDS,
    ObjectSpec,
    SceneSpec,
    contact_sheet,
    sample_spec,
    sheet_frames,
    write_png,
)
from uavsnn.scenes.renderer import LABEL_DTYPE
from uavsnn.scenes.renderer import frames as scene_frames
from uavsnn.sim import Pix2NvsParams

__all__ = ["register"]


def _add_output_options(parser: Any) -> None:
    """``--overwrite``, ``--json`` and ``--quiet``, as ``dataset build`` and ``demo`` take them."""
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the dataset in OUT_DIR (its own files; a folder that holds anything "
        "else is refused)",
    )
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def register(subparsers: Any) -> None:
    """Add ``uavsnn dataset`` and its actions."""
    parser = subparsers.add_parser(
        "dataset",
        help="build and inspect labelled datasets of windows",
        description="Build labelled train/test sets (split by recording, balanced test sets, "
        "a manifest) from rendered scenes or labelled videos; see docs/dataset.md.",
    )
    actions = parser.add_subparsers(dest="dataset_action", metavar="ACTION", required=True)

    b = actions.add_parser(
        "build",
        help="build a dataset",
        description="Render or read recordings, turn them into events, cut windows, label them "
        "and write train/test splits (by recording; balanced) with a manifest. Domains: dvs "
        "(rendered scenes through the DVS emulator), sim (rendered video through PIX2NVS), "
        "real (labelled videos through PIX2NVS), combined (train on dvs+sim[+real], test on "
        "dvs). Rules and format: docs/dataset.md.",
    )
    b.add_argument("out_dir", type=Path, help="folder to write (created; must be empty)")
    b.add_argument(
        "--domain",
        choices=DATASET_DOMAINS,
        required=True,
        help="where the recordings come from: dvs, sim, real or combined (see above)",
    )
    b.add_argument(
        "--videos",
        type=Path,
        help="real and combined: labelled videos (V_<CLASS>_<ID>.mp4 + .csv)",
    )
    b.add_argument("--n-test", type=int, default=2000, help="test windows, half UAV (2000)")
    b.add_argument(
        "--n-train",
        type=int,
        default=None,
        help="train windows, half UAV: an even number, or 0 for no train split (default: "
        "4000; for --domain real all usable windows)",
    )
    b.add_argument("--window-ms", type=float, default=50.0, help="window length (50)")
    b.add_argument("--overlap", type=float, default=0.5, help="window overlap in [0, 1) (0.5)")
    b.add_argument(
        "--seed",
        type=int,
        default=0,
        help="seed of every draw (the scenes, their events, the real clips' split, the windows "
        "kept): the same seed builds the same dataset (0)",
    )
    b.add_argument(
        "--min-fraction",
        type=float,
        default=0.5,
        help="share of a window the UAV must be visible to count (0.5)",
    )
    b.add_argument(
        "--test-fraction",
        type=float,
        default=None,
        help="real, and combined with --videos: share of the real clips kept for test "
        f"({TEST_FRACTION:g})",
    )
    b.add_argument(
        "--sensor",
        default="240x180",
        metavar="WxH",
        help="sensor size (240x180; also 346x260, 640x480, 1280x720): scenes keep their field "
        "of view, so objects cover more pixels on larger sensors",
    )
    b.add_argument(
        "--pix2nvs-compat",
        action="store_true",
        help="sim and real: PIX2NVS as the released program runs, quirks included "
        "(Pix2NvsParams.original(); docs/simulation.md)",
    )
    b.add_argument(
        "--pix2nvs-threshold",
        type=float,
        metavar="THETA",
        help="sim and real: PIX2NVS's threshold on the change of log luma (default 0.4; "
        "PIX2NVS accepts 0.2-0.7): lower makes events of fainter changes",
    )
    b.add_argument(
        "--stratify",
        action="store_true",
        help="rendered scenes of non-UAV objects take each kind (bird, aircraft, helicopter, "
        "ball, insect, leaf) in its share instead of at random: for tuning sets, which must "
        "hold every kind",
    )
    add_camera_options(b, "dvs")
    _add_output_options(b)
    add_ray_option(b, "the recordings' simulation as tasks (the same dataset)")
    b.set_defaults(handler=_build)

    d = actions.add_parser(
        "demo",
        help="build the small built-in synthetic set",
        description="Build the small synthetic set that 'uavsnn demo' trains and tests on: the "
        "dvs domain, 1 s scenes rendered at 400 fps, windows of 50 ms with 50 % overlap, "
        "split by recording into balanced train and test sets, with a manifest.",
    )
    d.add_argument("out_dir", type=Path, help="folder to write (created; must be empty)")
    d.add_argument(
        "--seed",
        type=int,
        default=0,
        help="seed of every draw (the scenes, their events, the windows kept): the same seed "
        "builds the same set (0)",
    )
    d.add_argument("--n-test", type=int, default=200, help="test windows, half UAV (200)")
    d.add_argument("--n-train", type=int, default=400, help="train windows, half UAV (400)")
    _add_output_options(d)
    d.set_defaults(handler=_demo)

    i = actions.add_parser(
        "info",
        help="summarise a dataset",
        description="Print what a dataset's manifest says of it: its domain, source and seed, "
        "its windows' length, overlap and sensor, and each split's windows (UAV and not), "
        "recordings and classes.",
    )
    i.add_argument("dir", type=Path, help="dataset folder (with manifest.json)")
    i.add_argument("--json", action="store_true", help="print the manifest's summary as JSON")
    i.set_defaults(handler=_info)

    p = actions.add_parser(
        "preview",
        help="render a sampled scene to a PNG contact sheet",
        description="Draw a scene as a dataset build draws them and write some of its frames, "
        "with their labels, to a PNG contact sheet; print its background, light and objects.",
    )
    p.add_argument("out", type=Path, help="PNG to write")
    p.add_argument(
        "--domain",
        choices=("dvs", "sim"),
        default="dvs",
        help="whose scenes: dvs (rendered for the DVS emulator) or sim (video for PIX2NVS) (dvs)",
    )
    p.add_argument(
        "--kind",
        choices=(*SCENE_KINDS, *OBJECT_KINDS),
        default="uav",
        help="what the scene holds: uav (a UAV, now and then with a distractor), object (a "
        "non-UAV object), empty (background only), or that one kind of object (uav)",
    )
    p.add_argument(
        "--seed", type=int, default=0, help="seed of the scene's draw and of its rendering (0)"
    )
    p.add_argument("--frames", type=int, default=8, help="frames on the sheet (8)")
    p.add_argument("--duration", type=float, default=None, help="seconds (domain default)")
    p.add_argument(
        "--sensor",
        metavar="WxH",
        help="dvs: the sensor the scene is drawn for (default 240x180), e.g. 1280x720",
    )
    add_camera_options(p, "dvs")
    p.set_defaults(handler=_preview)


#: What reading a field of a damaged manifest (hand-edited, cut short) raises.
_MALFORMED = (KeyError, TypeError, AttributeError, ValueError, IndexError)


def _parameters(manifest: dict[str, Any]) -> dict[str, Any]:
    """The manifest's parameters but its sources; real footage draws no scenes, so its
    ``object_scenes`` is ``None`` (manifests written before said ``"drawn"``)."""
    params = {k: v for k, v in manifest["parameters"].items() if k != "sources"}
    if manifest["domain"] == "real":
        params["object_scenes"] = None
    return params


#: The share of a real clip's windows left unscored above which `dataset build` and `dataset
#: info` name the clip (none of the reference clips but one leaves more than 8 %).
PARTLY_LABELLED = 0.1


def _summary(root: Path, manifest: dict[str, Any]) -> dict[str, Any]:
    return {
        "root": str(root),
        "domain": manifest["domain"],
        "source": manifest["source"],
        "seed": manifest["seed"],
        "parameters": _parameters(manifest),
        "splits": {
            name: {k: v for k, v in s.items() if k != "recordings"}
            | {"recordings": len(s["recordings"])}
            for name, s in manifest["splits"].items()
        },
        "recordings": len(manifest.get("recordings", [])),
        # Real clips that gave no usable window (a box file of its header alone, or labels
        # that leave every window unscored): listed, and said, rather than dropped silently.
        "unusable_clips": sorted(
            str(r.get("name"))
            for r in manifest.get("recordings", [])
            if isinstance(r, dict) and r.get("domain") == "real" and r.get("usable") == 0
        ),
        # Real clips that leave more than PARTLY_LABELLED of their windows unscored (frames
        # without a box row: labels that stop short of the video, or gaps): said, as a box file
        # made for part of a clip leaves it.
        "partly_labelled_clips": [
            {"name": str(r.get("name")), "usable": r["usable"], "windows": r["windows"]}
            for r in manifest.get("recordings", [])
            if isinstance(r, dict)
            and r.get("domain") == "real"
            and isinstance(r.get("windows"), int)
            and isinstance(r.get("usable"), int)
            and 0 < r["usable"] < (1 - PARTLY_LABELLED) * r["windows"]
        ],
        "lens": next(
            (src["lens"] for src in manifest["parameters"].get("sources", []) if "lens" in src),
            None,
        ),
    }


def _print(summary: dict[str, Any], as_json: bool) -> None:
    if as_json:
        print(_jsonout.document(summary))
        return
    print(f"{summary['root']}: {summary['domain']} — {summary['source']} (seed {summary['seed']})")
    p = summary["parameters"]
    stratified = ", object scenes stratified" if p.get("object_scenes") == "stratified" else ""
    lens = summary.get("lens")
    if lens is not None:
        focus = "infinity" if lens["focus_m"] is None else f"{lens['focus_m']:g} m"
        stratified += f", lens f/{lens['f_number']:g} focused at {focus}"
    print(
        f"  windows of {p['window_ms']} ms, overlap {p['overlap']}, sensor "
        f"{p['sensor_size'][0]}x{p['sensor_size'][1]}{stratified}"
    )
    for name, s in summary["splits"].items():
        classes = ", ".join(f"{k} {v}" for k, v in sorted(s["classes"].items()))
        print(
            f"  {name}: {s['windows']} windows ({s['uav']} UAV, {s['non_uav']} not) from "
            f"{counted(s['recordings'], 'recording')} — {classes}"
        )
    unusable = summary.get("unusable_clips") or []
    if unusable:
        print(
            f"  {counted(len(unusable), 'clip')} gave no usable window (no window with its "
            f"frames labelled; see each box file): {', '.join(unusable)}"
        )
    partly = summary.get("partly_labelled_clips") or []
    if partly:
        named = ", ".join(f"{c['name']} ({c['usable']} of {c['windows']})" for c in partly)
        print(
            f"  {counted(len(partly), 'clip')} left more than {100 * PARTLY_LABELLED:g} % of "
            f"{'its' if len(partly) == 1 else 'their'} windows unscored (frames without a box "
            f"row; see each box file): {named}"
        )


def _progress(quiet: bool) -> bool:
    return not quiet


def _done(paths: DatasetPaths, as_json: bool) -> int:
    _print(_summary(paths.root, read_manifest(paths.root)), as_json)
    return 0


def _check_domain_options(args: argparse.Namespace) -> None:
    """Refuse the options that the domain would ignore: the real clips' (``--videos``,
    ``--test-fraction``) where no real clip is read, PIX2NVS's where nothing goes through it.
    (``--lens``, ``--focus-m`` and ``--fov`` outside dvs and combined: :func:`_dvs_source`.)"""
    if args.videos is not None and args.domain in ("dvs", "sim"):
        raise ParameterError(
            f"--videos holds real clips: for --domain real or combined, not --domain {args.domain}"
        )
    if args.test_fraction is not None and args.videos is None and args.domain != "real":
        raise ParameterError(
            "--test-fraction splits the real clips: for --domain real, or combined with "
            f"--videos, not --domain {args.domain}"
            + (" without --videos" if args.domain == "combined" else "")
        )


def _pix2nvs(args: argparse.Namespace) -> Pix2NvsParams | None:
    """The PIX2NVS parameters of --pix2nvs-compat and --pix2nvs-threshold (None: defaults)."""
    theta = args.pix2nvs_threshold
    if theta is not None and args.domain == "dvs":
        raise ParameterError("--pix2nvs-threshold sets PIX2NVS: for sim, real or combined")
    if args.pix2nvs_compat and args.domain == "dvs":
        raise ParameterError("--pix2nvs-compat sets PIX2NVS: for sim, real or combined")
    options = {} if theta is None else {"threshold": theta}
    if args.pix2nvs_compat:
        return Pix2NvsParams.original(**options)
    return Pix2NvsParams(**options) if options else None


def _build(args: argparse.Namespace) -> int:
    # A folder nobody can make is named here, not by the OSError of making it.
    check_output_dir(args.out_dir, "OUT_DIR")
    _check_domain_options(args)
    n_train = args.n_train
    if n_train is None and args.domain != "real":
        n_train = 4000
    paths = build(
        args.out_dir,
        args.domain,
        videos=args.videos,
        n_test=args.n_test,
        n_train=n_train,
        window_ms=args.window_ms,
        overlap=args.overlap,
        seed=args.seed,
        min_fraction=args.min_fraction,
        test_fraction=args.test_fraction,
        sensor=args.sensor,
        pix2nvs_params=_pix2nvs(args),
        dvs=_dvs_source(args),
        overwrite=args.overwrite,
        progress=_progress(args.quiet),
        runner=runner_for(args.ray),
        stratify=args.stratify,
    )
    return _done(paths, args.json)


def _dvs_source(args: argparse.Namespace) -> SceneSource | None:
    """The dvs scenes through ``--lens`` and with ``--fov`` (``None``: the default source, a
    pinhole of 45-70°)."""
    lens = lens_option(args.lens, args.focus_m)
    if lens is None and args.fov is None:
        return None
    for flag, value in (("--lens", lens), ("--fov", args.fov)):
        if value is not None and args.domain not in ("dvs", "combined"):
            raise ParameterError(f"{flag} is for rendered dvs scenes, not --domain {args.domain}")
    return replace(
        default_source("dvs", parse_sensor(args.sensor)), lens=lens, fov_deg=fov_option(args.fov)
    )


def _demo(args: argparse.Namespace) -> int:
    paths = build_demo(
        args.out_dir,
        args.seed,
        n_test=args.n_test,
        n_train=args.n_train,
        overwrite=args.overwrite,
        progress=_progress(args.quiet),
    )
    return _done(paths, args.json)


def _info(args: argparse.Namespace) -> int:
    manifest = read_manifest(args.dir)  # checks the format and its version, not every field
    try:
        _print(_summary(args.dir, manifest), args.json)
    except _MALFORMED as exc:
        what = f"it has no field {exc.args[0]!r}" if isinstance(exc, KeyError) else str(exc)
        raise DatasetError(
            f"{args.dir}/manifest.json is not a whole dataset manifest: {what}"
        ) from exc
    return 0


def _preview(args: argparse.Namespace) -> int:
    if args.frames < 1:
        raise ParameterError(f"--frames must be >= 1, got {args.frames}")
    if args.seed < 0:
        raise ParameterError(f"--seed must be >= 0, got {args.seed}")
    if args.out.suffix.lower() != ".png":
        raise ParameterError(f"the contact sheet is a PNG: OUT must end in .png, got {args.out}")
    camera = (args.sensor, args.lens, args.focus_m, args.fov)
    if args.domain != "dvs" and any(v is not None for v in camera):
        raise ParameterError(
            "--sensor, --lens, --focus-m and --fov set the event camera: --domain dvs only"
        )
    size = None if args.sensor is None else parse_sensor(args.sensor)
    lens = lens_option(args.lens, args.focus_m)
    spec = sample_spec(
        args.domain,
        args.kind,
        np.random.default_rng(args.seed),
        size=size,
        duration_s=args.duration,
        fov_deg=fov_option(args.fov),
    )
    spec = through_lens(spec, lens, (spec.width, spec.height))
    # The frames the sheet shows, drawn one at a time (render() held every frame: 7.8 GB for
    # a 90 s scene).
    picks = set(sheet_frames(spec.n_frames, args.frames).tolist())
    shown = [f for f in scene_frames(spec, seed=args.seed, samples_per_pass=0) if f.k in picks]
    labels = np.array([f.label for f in shown], dtype=LABEL_DTYPE)
    # a 240-pixel frame is drawn twice its size to be seen; wider ones as they are
    scale = 2.0 if args.domain == "dvs" and spec.width <= 320 else 1.0
    sheet = contact_sheet(
        np.stack([f.image for f in shown]), labels, count=len(shown), columns=4, scale=scale
    )
    write_png(args.out, sheet)
    objects = ", ".join(_preview_object(spec, o) for o in spec.objects) or "none"
    print(
        f"{args.out}: {args.domain} scene, {spec.background.kind} background, light "
        f"{spec.lighting.level:.3f}, objects: {objects}"
    )
    return 0


def _preview_object(spec: SceneSpec, obj: ObjectSpec) -> str:
    """An object as the preview names it: its kind and range, and through a lens its blur."""
    text = f"{obj.kind} at {obj.path.start[2]:.1f} m"
    if spec.aperture_mm > 0:
        blur = float(spec.blur_px(np.array([spec.focal_px / obj.path.start[2]]))[0])
        text += f" (blur {blur:.1f} px)"
    return text
