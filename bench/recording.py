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

`--write-path` measures only what the control loop spends putting one camera frame (640x480 rgb + uint16
depth) from its camera node's ring into the encoder's ring, and what the encoder then spends preparing
the depth, both ways in the same run: "copied out" (the observation's checked copy, depth converted to
meters, then copied into the encoder ring and converted back to the stored units: the former path) and
"in place" (one copy from the ring slot into the encoder slot, checked after; depth kept as the camera's
integers).
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


def write_path(frames: int = 300, h: int = 480, w: int = 640) -> None:
    """The recorder's per-frame cost, copied out first vs read in place (see the module docstring)."""
    from rio.recording.episode_writer import fill_slot
    from rio.recording.frame_ring import FrameRing
    from rio.recording.video import depth_units
    from rio.runtime.buffers import RingBuffer
    from rio.runtime.layout import Layout
    from rio.schema import RingCamera

    example = {"rgb": np.zeros((h, w, 3), np.uint8), "intrinsics": np.eye(3), "depth": np.zeros((h, w), np.uint16),
               "depth_scale": 0.001}
    ring = RingBuffer(Layout(example, owner="cam"), 8)
    rgb_out, depth_m_out, depth_u_out = FrameRing((h, w, 3), "|u1", 4), FrameRing((h, w), "<f4", 4), \
        FrameRing((h, w), "<u2", 4)
    rng = np.random.default_rng(0)
    clip = [(SyntheticCamera(h, w, seed=k).frame(k / 30), rng.integers(300, 4000, (h, w), dtype=np.uint16))
            for k in range(4)]

    def one(k: int, in_place: bool) -> tuple[float, float]:
        rgb, depth = clip[k % len(clip)]
        ring.put({"rgb": rgb, "intrinsics": np.eye(3), "depth": depth, "depth_scale": 0.001, "timestamp": float(k)})
        cam = RingCamera(ring, "cam", {"timestamp": float(k)})
        t0 = time.process_time()
        if in_place:
            with cam.in_place() as px:
                for out, kind in ((rgb_out, "rgb"), (depth_u_out, "depth")):
                    slot = out.reserve()
                    fill_slot(out.view(slot), px[kind], px["depth_scale"] if kind == "depth" else None, 0.001)
            rgb_out.commit(), depth_u_out.commit()
            t1 = time.process_time()
            depth_u_out.view(slot)  # stored as it is: the camera's unit is the stored one
        else:
            rgb_out.try_put(cam.rgb)
            depth_m_out.try_put(cam.depth)
            t1 = time.process_time()
            depth_units(depth_m_out.view((depth_m_out.produced - 1) % depth_m_out.slots), 0.001)
        t2 = time.process_time()
        for r in (rgb_out, depth_m_out, depth_u_out):
            r.consumed = r.produced  # the encoder released them
        return t1 - t0, t2 - t1

    for k in range(20):  # warm up both
        one(k, k % 2 == 0)
    cost: dict[bool, list[tuple[float, float]]] = {False: [], True: []}
    for k in range(frames * 2):  # interleaved, so both see the same machine load
        cost[k % 2 == 0].append(one(k, k % 2 == 0))
    loop = {m: 1e3 * sum(c[0] for c in v) / len(v) for m, v in cost.items()}
    enc = {m: 1e3 * sum(c[1] for c in v) / len(v) for m, v in cost.items()}
    raw = h * w * 3 + h * w * 2
    print(f"recorder write path, one {w}x{h} rgb + depth frame, {frames} frames each way, {os.cpu_count()} cores")
    print(f"  copied out first   loop {loop[False]:.3f} ms + encoder depth {enc[False]:.3f} ms per frame; bytes "
          f"written {(raw + h * w * 4 * 2 + h * w * 3 + h * w * 4) / raw:.1f}x the frame (record copy, depth "
          "to float and scaled, both into the ring)")
    print(f"  in place           loop {loop[True]:.3f} ms + encoder depth {enc[True]:.3f} ms per frame; bytes "
          "written 1.0x the frame (one copy into the ring)")
    print(f"  ratio              loop {loop[False] / max(loop[True], 1e-9):.1f}x less CPU in place; loop + encoder "
          f"{(loop[False] + enc[False]) / max(loop[True] + enc[True], 1e-9):.1f}x")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--codec", default="h264")
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--write-path", action="store_true", help="measure only the recorder's per-frame write path")
    args = ap.parse_args()
    if args.write_path:
        write_path(h=args.height, w=args.width)
        return
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
