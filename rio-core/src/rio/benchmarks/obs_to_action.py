"""Observation-to-action latency benchmark (`python bench/obs_to_action.py [--json]`).

Setup (the RIO paper's pi0.5 profile, with the model replaced by a stand-in so the figures measure
the framework): a station of a 6-joint arm, a gripper and three 640x480 RGB cameras at 30 Hz
(`rio.fake_*` drivers, `--middleware shm` by default), and `SleepPolicy`, whose forward pass is an
86 ms sleep returning 50-action chunks at 50 Hz. `rio deploy`'s loop (`run_deploy`) runs it with
continuous asynchronous inference (`--threshold 1`: the next observation goes out as each chunk
lands) at `--rate` Hz for `--seconds`. Camera frames reach the policy node by reference where the
middleware shares rings (shm, thread), handed to the policy in place; `--frames copy` copies them into
every request instead, the path network middlewares take, so both can be compared in one sitting. The
stand-in reads no pixels: a real model's preprocessing reads them once either way, from the ring or from
a copy, so what the figures leave out is the same for every path.

Every figure is measured from the observation's time, `t_obs` (when the control loop read the
state and camera ring buffers for it; the same instant LeRobot's client stamps):

- `first_action_ms`: to the moment the first action of the chunk computed from it is sent to the
  robot (`env.step`); `overhead_ms` = that minus the chunk's own forward pass, per chunk;
- `action_age_ms`: the age of every action sent to the robot, the paper's 130.3 ms figure;
- `obs_sent_ms`: to the request being enqueued (reading the cameras' rings included);
- `loop_jitter_us_p99`: wake-up lateness p99 of the control loop's periodic ticks while inference runs;
- `camera_age_ms_p50`: how old the oldest camera frame in an observation was at `t_obs` (30 Hz
  cameras; the same for any framework reading the newest frame).

The reference is LeRobot 0.4.4's asynchronous inference (policy server + robot client) measured on
this machine with the same cameras, an 86 ms forward pass, 50-action chunks and 30 Hz, at two values
of its `chunk_size_threshold`, which plays the part of `--threshold` (how much of the chunk is left
when the next observation goes out). The age of the actions it executes depends on it: 502 ms at 0.5,
234.5 ms at 1.0; its first action (167-170 ms) and overhead (81-84 ms) barely move. Both are printed;
ratios are taken against the one measured at `--threshold` (none when it matches neither). `--json`
prints one object; progress goes to stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

import numpy as np

#: LeRobot 0.4.4 on this machine, keyed by its `chunk_size_threshold` (compared with `--threshold`).
LEROBOT_044 = {
    "0.5": {"first_action_ms_p50": 167.0, "overhead_ms_p50": 81.0, "action_age_ms_p50": 502.0},
    "1.0": {"first_action_ms_p50": 170.0, "overhead_ms_p50": 84.0, "action_age_ms_p50": 234.5},
}
PAPER = {"rio_action_age_ms": 130.3, "lerobot_action_age_ms": 581.2, "forward_ms": 85.8}
TARGETS = {"overhead_ms_p50": 2.0, "action_age_ms_p50": 135.0}
_ROWS = (("first_action_ms_p50", "first action p50 (ms)"), ("overhead_ms_p50", "overhead p50 (ms)"),
         ("action_age_ms_p50", "action age p50 (ms)"))


def lerobot_reference(threshold: float) -> str | None:
    """The key of the LeRobot figures measured at `threshold`, or None if none were."""
    return next((k for k in LEROBOT_044 if abs(float(k) - threshold) < 1e-9), None)


def bench_station(middleware: str, cameras: int, width: int, height: int, camera_hz: float) -> Any:
    from rio.station import parse_station

    comps: dict[str, Any] = {"arm": {"driver": "rio.fake_arm", "dof": 6, "rate_hz": 200.0},
                             "gripper": {"driver": "rio.fake_gripper", "rate_hz": 200.0}}
    for i in range(cameras):
        comps[f"cam{i}_camera"] = {"driver": "rio.fake_camera", "width": width, "height": height,
                                   "rate_hz": camera_hz}
    return parse_station({"name": "bench-o2a", "rate_hz": 50, "middleware": {"name": middleware},
                          "components": comps})


def run(args: argparse.Namespace) -> dict[str, Any]:
    from rio.policy import AsyncConfig
    from rio.workflows.deploy import run_deploy

    camera_age: list[float] = []

    def on_tick(tick: Any) -> None:
        stamps = [c.meta["timestamp"] for c in tick.step.observation.cameras.values()]
        if stamps:
            camera_age.append(tick.step.meta["t_obs"] - min(stamps))

    st = bench_station(args.middleware, args.cameras, args.width, args.height, args.camera_hz)
    policy = (f"rio.policy.testing:SleepPolicyNode,forward_s={args.forward_ms / 1000},chunk={args.chunk},"
              f"rate_hz=50,frames={args.frames}")
    summary = run_deploy(st, policy, duration=args.seconds, rate_hz=args.rate, on_tick=on_tick,
                         config=AsyncConfig(request_threshold=args.threshold, blend=args.blend),
                         log=lambda m: print(f"[obs_to_action] {m}", file=sys.stderr, flush=True))
    s = summary.details.get("stats", {})
    ref_key = lerobot_reference(args.threshold)
    out: dict[str, Any] = {
        "setup": {"middleware": args.middleware, "cameras": f"{args.cameras} x {args.width}x{args.height} @ "
                  f"{args.camera_hz:g} Hz", "forward_ms": args.forward_ms, "chunk": f"{args.chunk} @ 50 Hz",
                  "control_hz": args.rate, "threshold": args.threshold, "blend": args.blend, "frames": args.frames,
                  "seconds": round(summary.seconds, 1)},
        **{k: s.get(k) for k in ("first_action_ms_p50", "first_action_ms_p99", "action_age_ms_p50",
                                 "action_age_ms_p99", "overhead_ms_p50", "overhead_ms_p99", "forward_ms_p50",
                                 "obs_sent_ms_p50", "obs_to_policy_ms_p50", "chunks", "frame_misses",
                                 "late_events", "late_ticks")},
        "loop_jitter_us_p99": summary.lateness_us.get("p99"),
        "loop_overruns": summary.overruns,
        "camera_age_ms_p50": round(float(np.median(camera_age)) * 1000, 2) if camera_age else None,
        "reference_lerobot_0_4_4": LEROBOT_044,
        "reference_threshold": ref_key,
        "paper": PAPER,
        "targets": TARGETS,
    }
    out["ratio_lerobot_over_rio"] = None if ref_key is None else {
        k: (round(v / s[k], 2) if s.get(k) else None) for k, v in LEROBOT_044[ref_key].items()}
    out["targets_met"] = {k: (s.get(k) is not None and s[k] <= v) for k, v in TARGETS.items()}
    return out


def _cell(x: float | None, width: int) -> str:
    return f"{x:>{width}.1f}" if x is not None else f"{'-':>{width}s}"


def report(out: dict[str, Any]) -> str:
    """The human-readable table: RIO next to LeRobot at each threshold it was measured at."""
    setup, ratios, ref_key = out["setup"], out["ratio_lerobot_over_rio"] or {}, out["reference_threshold"]
    lines = [f"observation -> action latency ({setup['cameras']}, {setup['forward_ms']:g} ms forward pass, "
             f"{setup['middleware']}, frames {setup['frames']}, threshold {setup['threshold']:g}, control "
             f"{setup['control_hz']:g} Hz, {setup['seconds']} s)"]
    heads = [f"LeRobot @{k}" + ("*" if k == ref_key else "") for k in LEROBOT_044]
    lines.append(f"{'':24s}{'RIO':>8s}" + "".join(f"{h:>15s}" for h in heads) + f"{'ratio*':>8s}")
    for key, label in _ROWS:
        lines.append(f"{label:24s}{_cell(out[key], 8)}" + "".join(_cell(r[key], 15) for r in LEROBOT_044.values())
                     + _cell(ratios.get(key), 8))
    lines.append("* LeRobot 0.4.4 at this chunk_size_threshold; the ratio is LeRobot / RIO against it" if ref_key
                 else f"(LeRobot was measured at thresholds {', '.join(LEROBOT_044)} only: no ratio)")
    lines.append(f"obs sent p50 {out['obs_sent_ms_p50']} ms; first action p99 {out['first_action_ms_p99']} ms; "
                 f"action age p99 {out['action_age_ms_p99']} ms; loop wake-up lateness p99 {out['loop_jitter_us_p99']}"
                 f" us; camera frame age p50 {out['camera_age_ms_p50']} ms; policy late {out['late_events']} times; "
                 f"frames missed {out['frame_misses']}")
    lines.append(f"paper: RIO {PAPER['rio_action_age_ms']} ms vs LeRobot {PAPER['lerobot_action_age_ms']} ms "
                 f"({PAPER['forward_ms']} ms forward pass); targets met: {out['targets_met']}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seconds", type=float, default=20.0)
    p.add_argument("--rate", type=float, default=50.0, help="control loop rate (Hz)")
    p.add_argument("--middleware", default="shm")
    p.add_argument("--cameras", type=int, default=3)
    p.add_argument("--width", type=int, default=640)
    p.add_argument("--height", type=int, default=480)
    p.add_argument("--camera-hz", type=float, default=30.0)
    p.add_argument("--forward-ms", type=float, default=86.0)
    p.add_argument("--chunk", type=int, default=50)
    p.add_argument("--threshold", type=float, default=1.0)
    p.add_argument("--blend", default="crossfade")
    p.add_argument("--frames", choices=("auto", "copy"), default="auto",
                   help="camera frames to the policy node: by reference where the middleware allows (auto), "
                        "or copied into each request")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    args = p.parse_args(argv)
    out = run(args)
    print(json.dumps(out, indent=2) if args.json else report(out))
    return 0
