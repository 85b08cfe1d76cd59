"""The "sim" path on 1080p30 video to 240×180, decoding included, against real time.

Writes a 1920×1080, 30 fps test video (moving shapes over a textured sky-and-ground scene) into
a temporary directory, then times :func:`uavsnn.sim.video_to_recording` on it — OpenCV decoding,
centred 4:3 crop, PIX2NVS at 1440×1080, pooling onto 240×180 — and reports how many times
faster than real time it runs. References measured in the same run: decoding alone (the floor
any video path pays) and the resize-first variant (``downsample="frames"``).

Usage::

    python benches/python/bench_sim.py [--seconds 5] [--repeat 3] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from uavsnn.sim import video_to_recording

FPS = 30.0
SIZE = (1920, 1080)


def write_test_video(path: Path, seconds: float) -> int:
    """A 1080p30 clip: a drone-sized dark shape and a bird-sized one crossing a sky with a
    gradient and texture, above a darker ground strip. Returns the number of frames."""
    w, h = SIZE
    n = round(seconds * FPS)
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), FPS, SIZE)
    if not writer.isOpened():
        raise RuntimeError("OpenCV cannot write mp4v video here")
    yy, xx = np.mgrid[0:h, 0:w]
    sky = (150 + 60 * yy / h + 10 * np.sin(xx / 37.0) * np.cos(yy / 23.0)).astype(np.uint8)
    base = np.dstack([sky + 20, sky + 5, sky]).clip(0, 255).astype(np.uint8)
    base[int(0.8 * h) :] = (40, 70, 50)
    for k in range(n):
        frame = base.copy()
        cx, cy = int(200 + 40 * k) % w, int(0.3 * h + 80 * np.sin(k / 15))
        cv2.rectangle(frame, (cx - 30, cy - 10), (cx + 30, cy + 10), (30, 30, 30), -1)
        for dx in (-35, 35):  # rotors
            cv2.circle(frame, (cx + dx, cy - 12), 14, (60, 60, 60), 2)
        bx, by = int(w - 60 * k) % w, int(0.5 * h + 30 * np.cos(k / 5))
        wing = int(12 * np.sin(k))
        cv2.line(frame, (bx - 20, by + wing), (bx, by), (20, 20, 20), 4)
        cv2.line(frame, (bx, by), (bx + 20, by + wing), (20, 20, 20), 4)
        writer.write(frame)
    writer.release()
    return n


def time_decode(path: Path) -> float:
    cap = cv2.VideoCapture(str(path))
    start = time.perf_counter()
    while True:
        ok, _ = cap.read()
        if not ok:
            break
    cap.release()
    return time.perf_counter() - start


def best_of(repeat: int, fn) -> tuple[float, object]:
    best, result = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - start)
    return best, result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=5.0, help="length of the test video")
    parser.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "test_1080p30.mp4"
        n = write_test_video(path, args.seconds)
        real_time = n / FPS
        decode, _ = best_of(args.repeat, lambda: time_decode(path))
        cpu0 = time.process_time()
        sim, rec = best_of(args.repeat, lambda: video_to_recording(path, "sim", (240, 180)))
        cpu_per_run = (time.process_time() - cpu0) / args.repeat
        frames_first, rec_f = best_of(
            args.repeat, lambda: video_to_recording(path, "sim", (240, 180), downsample="frames")
        )
    result = {
        "video": f"{SIZE[0]}x{SIZE[1]} @ {FPS:g} fps, {n} frames ({real_time:.1f} s)",
        "cpu_count": os.cpu_count(),
        "load_average": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
        "decode_only_s": decode,
        "sim_events_s": sim,
        "sim_events_process_cpu_s": cpu_per_run,
        "sim_frames_first_s": frames_first,
        "x_real_time_sim_events": real_time / sim,
        "x_real_time_sim_frames_first": real_time / frames_first,
        "x_real_time_decode_only": real_time / decode,
        "sim_over_decode": sim / decode,
        "events_sim_events": len(rec),  # type: ignore[arg-type]
        "events_sim_frames_first": len(rec_f),  # type: ignore[arg-type]
    }
    if args.json:
        print(json.dumps(result))
        return
    print(
        f"video: {result['video']}  (machine: {os.cpu_count()} CPUs, load {result['load_average']})"
    )
    print(f"decoding alone            {decode:7.2f} s  = {real_time / decode:5.1f} x real time")
    print(
        f"sim, simulate then pool   {sim:7.2f} s  = {real_time / sim:5.1f} x real time "
        f"({sim / decode:.2f} x decoding alone; {len(rec)} events)"  # type: ignore[arg-type]
    )
    print(
        f"  (process CPU time per sim run: {cpu_per_run:.2f} s over {os.cpu_count()} CPUs, "
        "decoder threads included)"
    )
    print(
        f"sim, resize then simulate {frames_first:7.2f} s  = {real_time / frames_first:5.1f} x "
        f"real time ({len(rec_f)} events)"  # type: ignore[arg-type]
    )


if __name__ == "__main__":
    main()
