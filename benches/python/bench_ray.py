"""Ray against one process, in one run: the real-footage dataset build and a tiny reproduce,
serial and on a local Ray cluster of 1 and 2 CPUs (as ratios to the serial time), the
per-task costs, a projection of the time on N machines for the whole Svanström dataset and
for one hour of 1280×720 video, and what a 1280×720 stream costs per detector actor.

Time it on a quiet machine (every figure of docs/distributed.md comes from this script)::

    python benches/python/bench_ray.py --videos ../shared/data/svanstrom-dev --json out.json

``--clips N`` builds from the first N clips of each class only (``--small`` checks that the
script works in a minute or two: 2 clips per class, a smaller reproduce).

The projection is ``driver + work / (machines × cpus)``: ``work`` is the measured serial cost
per second of video (PIX2NVS, windowing and labelling, in one Ray task per clip) times the
seconds of video, ``driver`` the serial part measured here (planning, drawing, writing) scaled
by the number of clips, plus Ray's measured cost per task. The whole dataset's size is an
input (``--dataset-clips``, ``--clip-seconds``; defaults: the 285 visible-light videos of
Svanström et al., Data in Brief 2021, of about 10 s each).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from uavsnn.cli import main as cli
from uavsnn.dataset import build, read_manifest
from uavsnn.dataset.real import find_clips
from uavsnn.sim import probe_video, video_to_recording

_RSS_PROBE = r"""
import json, sys
import numpy as np
from uavsnn import EVENT_DTYPE, Detector, Network

def rss():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS"):
                return int(line.split()[1]) * 1024

width, height, fraction = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
net = Network({"width": width, "height": height})
window_us, windows = 50_000, 8
n = int(fraction * width * height) * windows
rng = np.random.default_rng(0)
ev = np.zeros(n, EVENT_DTYPE)
ev["t"] = np.sort(rng.integers(0, window_us * windows, n))
ev["x"] = rng.integers(0, width, n)
ev["y"] = rng.integers(0, height, n)
before = rss()
det = Detector(net, window_us=window_us, overlap=0.5)
peak = 0
for i in range(0, n, 4096):
    det.push(ev[i : i + 4096])
    peak = max(peak, rss())
weights = sum(net.weights(l).nbytes for l in ("conv1", "conv2", "conv3"))
print(json.dumps({"rss_growth_bytes": peak - before, "weights_bytes": weights,
                  "live_windows": det.live_windows, "events": n}))
"""


def _clips(videos: Path, per_class: int | None, into: Path) -> Path:
    """A folder of links to the first ``per_class`` clips of each class (all for None)."""
    into.mkdir(parents=True, exist_ok=True)
    seen: dict[str, int] = {}
    for clip in find_clips(videos):
        if per_class is not None and seen.get(clip.cls, 0) >= per_class:
            continue
        seen[clip.cls] = seen.get(clip.cls, 0) + 1
        for path in (clip.video, clip.boxes):
            (into / path.name).symlink_to(path.resolve())
    return into


def _timed(fn: Any) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def _ray_start(cpus: int) -> float:
    import ray

    from uavsnn import distributed

    start = time.perf_counter()
    ray.init(num_cpus=cpus, include_dashboard=False, logging_level="ERROR", log_to_driver=False)
    distributed.connect()
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--videos", type=Path, default=Path("../shared/data/svanstrom-dev"))
    parser.add_argument("--clips", type=int, default=None, help="clips per class (all)")
    parser.add_argument("--small", action="store_true", help="a quick check that it works")
    parser.add_argument("--dataset-clips", type=int, default=285)
    parser.add_argument("--clip-seconds", type=float, default=None, help="(measured mean)")
    parser.add_argument("--machines", default="1,2,4,8,16,32")
    parser.add_argument("--cpus-per-machine", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--json", type=Path, help="write every figure here too")
    parser.add_argument(
        "--memory-only", action="store_true", help="only the detector's memory (no timing)"
    )
    args = parser.parse_args()
    if args.memory_only:
        print(json.dumps({"detector_rss": detector_memory()}, indent=2))
        return
    per_class = 2 if args.small and args.clips is None else args.clips
    rep_args = ["--n-train", "40", "--n-test", "20", "--windows-per-layer", "40", "--no-real"]
    if not args.small:
        rep_args = ["--n-train", "200", "--n-test", "100", "--windows-per-layer", "400"]
        rep_args += ["--no-real"]
    out: dict[str, Any] = {"cpus": os.cpu_count(), "clips_per_class": per_class}
    tmp = Path(tempfile.mkdtemp(prefix="bench-ray-"))
    videos = _clips(args.videos, per_class, tmp / "videos")
    build_kw: dict[str, Any] = {"videos": videos, "n_test": 20, "n_train": None, "seed": 0}

    # Serial, then Ray with 1 and 2 CPUs: the same dataset each time.
    times: dict[str, dict[str, float]] = {"build": {}, "reproduce": {}}
    serial_root = tmp / "build-serial"
    times["build"]["serial"] = _timed(lambda: build(serial_root, "real", **build_kw))
    times["reproduce"]["serial"] = _timed(
        lambda: cli(["reproduce", "--out", str(tmp / "rep-serial"), "--quiet", *rep_args])
    )
    import ray

    from uavsnn import distributed

    startup = {}
    for cpus in (1, 2):
        startup[cpus] = _ray_start(cpus)
        runner = distributed.connect()
        root = tmp / f"build-ray{cpus}"
        times["build"][f"ray{cpus}"] = _timed(
            lambda root=root, runner=runner: build(root, "real", runner=runner, **build_kw)
        )
        if read_manifest(root) != read_manifest(serial_root):
            raise SystemExit("the Ray build differs from the serial one")
        rep = ["reproduce", "--out", str(tmp / f"rep-ray{cpus}"), "--quiet", "--ray", *rep_args]
        times["reproduce"][f"ray{cpus}"] = _timed(lambda rep=rep: cli(rep))
        ray.shutdown()
    out["seconds"] = times
    out["ray_startup_seconds"] = startup
    out["ratio_to_serial"] = {
        job: {k: v / t["serial"] for k, v in t.items() if k != "serial"} for job, t in times.items()
    }

    # Per-task costs: each contributing clip simulated alone, in this process.
    manifest = read_manifest(serial_root)
    used = [r for r in manifest["recordings"] if "events" in r]
    seconds_video, seconds_task = 0.0, 0.0
    for r in used:
        info = probe_video(videos / r["video"])
        seconds_video += info.frame_count / info.fps
        seconds_task += _timed(
            lambda v=videos / r["video"]: video_to_recording(v, "sim", size=(240, 180), seed=0)
        )
    per_video_second = seconds_task / seconds_video
    all_clips = find_clips(videos)
    durations = [probe_video(c.video).frame_count / probe_video(c.video).fps for c in all_clips]
    clip_seconds = args.clip_seconds or float(np.mean(durations))
    driver = max(times["build"]["serial"] - seconds_task, 0.0) / max(len(all_clips), 1)
    overhead = max(times["build"]["ray1"] - times["build"]["serial"], 0.0) / max(len(used), 1)
    out["per_task"] = {
        "clips_simulated": len(used),
        "video_seconds": seconds_video,
        "seconds_per_video_second": per_video_second,
        "driver_seconds_per_clip": driver,
        "ray_overhead_seconds_per_task": overhead,
        "mean_clip_seconds": clip_seconds,
    }

    # 1280×720: the cost per second of video, from a clip made by scaling real footage.
    hd = tmp / "hd.mp4"
    _scale_clip(args.videos.parent / "video" / "pbls_drone.mp4", hd, (1280, 720), seconds=2.0)
    hd_info = probe_video(hd)
    hd_cost = _timed(lambda: video_to_recording(hd, "sim", size=(240, 180), seed=0))
    hd_per_second = hd_cost / (hd_info.frame_count / hd_info.fps)
    out["hd_seconds_per_video_second"] = hd_per_second

    machines = [int(m) for m in args.machines.split(",")]
    cpus = args.cpus_per_machine

    def project(work_s: float, tasks: int, driver_s: float) -> dict[int, float]:
        return {
            m: driver_s + (work_s + tasks * overhead) / (m * cpus) for m in machines
        }  # fmt: skip

    n = args.dataset_clips
    out["projection_hours"] = {
        "cpus_per_machine": cpus,
        "svanstrom_visible": {
            m: s / 3600
            for m, s in project(n * clip_seconds * per_video_second, n, n * driver).items()
        },
        "one_hour_1280x720": {
            m: s / 3600
            for m, s in project(3600 * hd_per_second, round(3600 / clip_seconds), 0.0).items()
        },
    }

    # Memory of one stream's detector (one actor), in a fresh process: a network built for
    # 1280×720 input, and the 240×180 model a 1280×720 stream is downsampled to (--downsample).
    out["detector_rss"] = detector_memory()

    print(json.dumps(out, indent=2))
    if args.json:
        args.json.write_text(json.dumps(out, indent=2) + "\n", encoding="utf-8")


def detector_memory() -> dict[str, Any]:
    """Resident memory growth of one detector per sensor size (see _RSS_PROBE)."""
    out = {}
    for width, height in ((1280, 720), (240, 180)):
        probe = subprocess.run(
            [sys.executable, "-c", _RSS_PROBE, str(width), str(height), "0.01"],
            capture_output=True, text=True, check=True,
        )  # fmt: skip
        out[f"{width}x{height}"] = json.loads(probe.stdout)
    return out


def _scale_clip(src: Path, dst: Path, size: tuple[int, int], seconds: float) -> None:
    import cv2

    cap = cv2.VideoCapture(str(src))
    fps = cap.get(cv2.CAP_PROP_FPS) or 30.0
    writer = cv2.VideoWriter(str(dst), cv2.VideoWriter_fourcc(*"mp4v"), fps, size)
    for _ in range(round(seconds * fps)):
        ok, frame = cap.read()
        if not ok:
            break
        writer.write(cv2.resize(frame, size, interpolation=cv2.INTER_LINEAR))
    writer.release()
    cap.release()


if __name__ == "__main__":
    main()
