"""Recording throughput: 3 cameras at 640x480 / 30 fps plus state at 100 Hz, for --seconds.

Reports, each beside a reference measured in the same run:
- CPU: the recording run's CPU (this process + the encoder process) per second of data, against a
  run of the same loop that records nothing (so the difference is what recording costs);
- real-time factor: seconds of data per wall-clock second spent, including draining the encoder at
  the end (>= 1: keeps up), and the encoder's backlog; the loop's own timing with and without
  recording (p99 lateness);
- MB per minute of three-camera video, against the raw frame bytes per minute;
- the time to close an episode (keep), against encoding the same episode after the fact (what a
  save-frames-then-encode pipeline makes the operator wait).

Frames are synthetic but camera-like (textured background, moving shapes, sensor noise).
    .venv/bin/python bench/recording.py --seconds 60
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
from rio import clock
from rio.recording import Recorder, VideoOptions
from rio.recording.synthetic import SyntheticCamera, synthetic_step

CAMS = ("front", "wrist", "side")


def cpu_s(children: bool = False) -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN if children else resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def make_frames(h: int, w: int, n: int) -> dict[str, list[np.ndarray]]:
    """Pre-rendered clips (n frames per camera) so rendering does not count as recording cost."""
    return {c: [SyntheticCamera(h, w, seed=k).frame(i / 30) for i in range(n)] for k, c in enumerate(CAMS)}


def loop(seconds: float, frames: dict[str, list[np.ndarray]], rec: Recorder | None, hz: float = 100.0,
         cam_hz: float = 30.0) -> dict:
    rate = clock.Rate(hz)
    t0 = clock.now()
    late, add_ms = [], []
    n_clip = len(next(iter(frames.values())))
    i = 0
    while True:
        t = clock.now()
        if t - t0 >= seconds:
            break
        k = int((t - t0) * cam_hz)
        tc = t0 + k / cam_hz
        step = synthetic_step(i, t, {c: (frames[c][k % n_clip], tc) for c in CAMS})
        if rec is not None:
            a = time.perf_counter()
            rec.add(step)
            add_ms.append((time.perf_counter() - a) * 1000)
        i += 1
        target = rate._t_next
        rate.sleep()
        late.append(max(clock.now() - target, 0.0) * 1000)
    return {"steps": i, "late_p99_ms": float(np.percentile(late, 99)), "late_max_ms": float(np.max(late)),
            "add_p50_ms": float(np.median(add_ms)) if add_ms else 0.0,
            "add_p99_ms": float(np.percentile(add_ms, 99)) if add_ms else 0.0, "overruns": rate.overruns}


def offline_encode_s(frames: dict[str, list[np.ndarray]], seconds: float, video: VideoOptions, tmp: Path) -> float:
    """Encode the same episode's frames after the fact, one camera after another."""
    from rio.recording.video import StreamWriter

    n = int(seconds * 30)
    t = time.perf_counter()
    for c, clip in frames.items():
        w = StreamWriter(tmp / f"{c}.mp4", "rgb", clip[0].shape[0], clip[0].shape[1], 30, video)
        for i in range(n):
            w.write(clip[i % len(clip)])
        w.close()
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--codec", default="h264")
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--width", type=int, default=640)
    args = ap.parse_args()
    video = VideoOptions(codec=args.codec)
    frames = make_frames(args.height, args.width, 90)
    tmp = Path(tempfile.mkdtemp(prefix="rio-bench-rec-"))
    try:
        c0, w0 = cpu_s(), time.perf_counter()
        base = loop(args.seconds, frames, None)
        base_cpu = (cpu_s() - c0) / (time.perf_counter() - w0)

        c0, ch0 = cpu_s(), cpu_s(children=True)
        with Recorder(tmp / "ds", fps=100, video=video, camera_fps=30) as rec:
            time.sleep(1.0)  # let the encoder process start (done once per session, not per episode)
            w0 = time.perf_counter()
            run = loop(args.seconds, frames, rec)
            backlog = rec.encoder.backlog()
            t_keep = time.perf_counter()
            meta = rec.keep()
            close_s = time.perf_counter() - t_keep
            wall = time.perf_counter() - w0
        rec_cpu_parent = cpu_s() - c0
        rec_cpu_child = cpu_s(children=True) - ch0  # the encoder process, reaped at close
        data_s = meta["duration_s"]
        video_bytes = sum((tmp / "ds" / meta["dir"] / s["file"]).stat().st_size for s in meta["streams"].values())
        raw_bytes = sum(s["frames"] * s["height"] * s["width"] * 3 for s in meta["streams"].values())
        mb_min = video_bytes / 1e6 / (data_s / 60)
        raw_mb_min = raw_bytes / 1e6 / (data_s / 60)
        dropped = sum(s["dropped"] for s in meta["streams"].values())
        offline = offline_encode_s(frames, min(args.seconds, 20.0), video, tmp)
        offline_per_s = offline / min(args.seconds, 20.0)

        print(f"recording benchmark: 3 cameras {args.width}x{args.height} @ 30 fps + state @ 100 Hz, "
              f"{args.seconds:g} s, codec {args.codec} (crf {video.crf}, {video.preset}), {os.cpu_count()} cores")
        print(f"  steps recorded            {meta['length']} ({meta['measured_fps']:.1f} Hz measured)")
        counts = ", ".join(f"{k} {s['frames']}" for k, s in meta["streams"].items())
        print(f"  camera frames encoded     {counts}; dropped {dropped}")
        print(f"  CPU (cores)               recording {(rec_cpu_parent + rec_cpu_child) / data_s:.2f} "
              f"(loop {rec_cpu_parent / data_s:.2f} + encoder {rec_cpu_child / data_s:.2f})"
              f"   | reference: same loop, no recording {base_cpu:.2f}")
        print(f"  real-time factor          {data_s / wall:.3f} (data s / wall s until all on disk), backlog at "
              f"stop {backlog} frames   | reference: 1.00 = real time; encoder alone {1 / offline_per_s:.2f}x")
        print(f"  loop lateness p99 / max   {run['late_p99_ms']:.2f} / {run['late_max_ms']:.2f} ms   | reference: "
              f"no recording {base['late_p99_ms']:.2f} / {base['late_max_ms']:.2f} ms")
        print(f"  rec.add() p50 / p99       {run['add_p50_ms']:.3f} / {run['add_p99_ms']:.3f} ms")
        print(f"  MB per minute (3 cams)    {mb_min:.2f}   | reference: raw frames {raw_mb_min:.0f} "
              f"(ratio {raw_mb_min / mb_min:.0f}x)")
        print(f"  close an episode (keep)   {close_s * 1000:.0f} ms   | reference: encoding it afterwards "
              f"{offline_per_s * data_s:.1f} s ({offline_per_s:.2f} s per recorded second)")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
