"""Teleop device latency: from a device event to the command applied at a fake arm node.

    python bench/teleop_latency.py [--device gello|webxr ...] [--events N] [--json]

One function per device (`DEVICES`) sets up its device, runs `rio teleop`'s controller on a station
(thread middleware: one process, so the arm node's `write_joints` can be timed) and returns a dict of
figures; `main` runs the devices asked for and prints them (`--json`: one object keyed by device).
All timestamps are `rio.clock.now()`.

gello: an emulated GELLO (xArm 7 layout, eight XL330s answering Protocol 2.0 on a pseudo-terminal, read by
the unmodified dynamixel-sdk) drives a 7-joint `rio.fake_arm`. Once the follower is aligned, the
bench moves the leader's first joint by a step (`STEP_RAD`, alternating sign, at random intervals so
events fall anywhere in the cycles) and times, from that instant, the first `write_joints` at the arm
that moved 10 % of the step towards it (`event_to_arm`) and the one that reached 90 % (`..._done`).
The reference, measured on the same emulated bus in the same run before teleop starts: one
Protocol 2.0 READ of Present Position through the SDK (`pty_read`, the raw round trip) and one Sync
Read of all eight servos (`pty_sync_read`, what the leader does each tick). The ratio is
event_to_arm p50 / pty_read p50: what the node, the control loop and the arm's cycle add to the bus.
"""

from __future__ import annotations

import argparse
import json
import random
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

STEP_RAD = 0.05


def _pct(xs: list[float], scale: float = 1e3) -> dict[str, float]:
    a = np.asarray(xs, float) * scale
    return {"p50": round(float(np.percentile(a, 50)), 3), "p99": round(float(np.percentile(a, 99)), 3)} if a.size \
        else {"p50": float("nan"), "p99": float("nan")}


def _pty_round_trips(port: str, ids: tuple[int, ...], n: int) -> tuple[list[float], list[float]]:
    import dynamixel_sdk as sdk
    from rio_teleop.gello.bus import DynamixelBus

    from rio.clock import now

    ph = sdk.PortHandler(port)
    ph.openPort()
    pk = sdk.PacketHandler(2.0)
    reads = []
    try:
        for _ in range(n):
            t0 = now()
            _, result, _ = pk.read4ByteTxRx(ph, ids[0], 132)
            if result == sdk.COMM_SUCCESS:
                reads.append(now() - t0)
    finally:
        ph.closePort()
    syncs = []
    with DynamixelBus(port) as bus:  # (an in-process emulator: rio.machine.servo_port gives its slack)
        for _ in range(n):
            t0 = now()
            bus.read_state(ids)
            syncs.append(now() - t0)
    return reads, syncs


def bench_gello(args: argparse.Namespace, say: Callable[[str], None]) -> dict[str, Any]:
    from rio_teleop.gello.calibration import save_calibration
    from rio_teleop.gello.emulator import GelloEmulator
    from rio_teleop.gello.layouts import get_layout

    from rio.clock import now
    from rio.fakes.arms import FakeArm
    from rio.station.load import parse_station
    from rio.workflows.teleop import run_teleop

    lay = get_layout("xarm7")
    q0 = np.asarray(lay.known_pose, float)
    with GelloEmulator(lay) as g, tempfile.TemporaryDirectory(prefix="dG") as tmp:
        cal_file = save_calibration(g.mounting, Path(tmp) / "virtual.json")
        say(f"gello: raw round trips on {g.port} ...")
        reads, syncs = _pty_round_trips(g.port, lay.ids, args.round_trips)

        writes: list[tuple[float, float]] = []
        orig = FakeArm.write_joints

        def spy(self, joint_pos):
            writes.append((now(), float(joint_pos[0])))
            return orig(self, joint_pos)

        aligned = threading.Event()
        events: list[tuple[float, float, float]] = []  # (t, from, to)

        def fire() -> None:
            if not aligned.wait(30):
                return
            time.sleep(0.3)
            q = q0.copy()
            for k in range(args.events):
                before = float(q[0])
                q[0] = q0[0] + (STEP_RAD if k % 2 == 0 else 0.0)
                with g.bus.lock:
                    g.pose(q)
                    events.append((now(), before, float(q[0])))
                time.sleep(random.uniform(0.12, 0.2))

        st = parse_station({
            "name": "bench-gello", "rate_hz": args.rate, "middleware": {"name": "thread"},
            "embodiment": {"action_space": "joint_pos"},
            "components": {
                "arm": {"driver": "rio.fake_arm", "dof": lay.dof, "home": list(q0), "rate_hz": args.arm_rate},
                "teleop": {"driver": "gello.xarm7", "port": g.port, "calibration": str(cal_file),
                           "rate_hz": args.leader_rate, "gripper": False},
            }}, source="<bench>")
        duration = 2.0 + args.events * 0.16 + 1.0
        say(f"gello: {args.events} leader steps over ~{duration:.0f} s (loop {args.rate:g} Hz, leader "
            f"{args.leader_rate:g} Hz, arm {args.arm_rate:g} Hz) ...")
        firing = threading.Thread(target=fire, daemon=True)
        firing.start()
        FakeArm.write_joints = spy
        try:
            summary = run_teleop(st, duration=duration, log=None,
                                 on_tick=lambda tick: tick.info["pairs"][0].aligned and aligned.set())
        finally:
            FakeArm.write_joints = orig
        firing.join(5)

    t_w = np.array([w[0] for w in writes])
    q_w = np.array([w[1] for w in writes])
    first, done = [], []
    for t_e, a, b in events:
        i = np.searchsorted(t_w, t_e)
        moved = (q_w[i:] - a) / (b - a)
        k10, k90 = np.flatnonzero(moved >= 0.1), np.flatnonzero(moved >= 0.9)
        if k10.size:
            first.append(t_w[i + k10[0]] - t_e)
        if k90.size:
            done.append(t_w[i + k90[0]] - t_e)
    out = {"events": len(events), "event_to_arm_ms": _pct(first), "event_to_arm_done_ms": _pct(done),
           "pty_read_ms": _pct(reads), "pty_sync_read_ms": _pct(syncs),
           "loop_hz": args.rate, "leader_hz": args.leader_rate, "arm_hz": args.arm_rate,
           "late_ticks": summary.late_ticks, "ticks": summary.ticks}
    ref = out["pty_read_ms"]["p50"]
    out["ratio_p50"] = round(out["event_to_arm_ms"]["p50"] / ref, 1) if ref else None
    return out


def bench_webxr(args: argparse.Namespace, say: Callable[[str], None]) -> dict[str, Any]:
    """The WebXR page in headless Chromium: injected poses through the page's own message path ->
    WebSocket -> teleop node -> fake arm; reference: a bare WebSocket echo from the same page over the same
    TLS connection setup (`rio_teleop.webxr.bench`)."""
    from rio_teleop.webxr.bench import webxr_latency
    from rio_teleop.webxr.harness import chromium_path

    if not chromium_path():
        say("webxr: no Chromium here (install chromium, or set RIO_CHROMIUM): skipped")
        return {"skipped": "no Chromium"}
    say("webxr: headless Chromium, page -> robot ...")
    r = webxr_latency(trials=min(args.events, 30), echo_samples=200, rate_hz=args.rate)
    r["ratio_p50"] = round(r["teleop_ms"]["p50"] / r["echo_one_way_ms"]["p50"], 1)
    return r


#: One entry per device: name -> function(args, say) returning its figures.
DEVICES: dict[str, Callable[[argparse.Namespace, Callable[[str], None]], dict[str, Any]]] = {
    "gello": bench_gello, "webxr": bench_webxr}


def _print(name: str, f: dict[str, Any]) -> None:
    if "skipped" in f:
        print(f"{name}: skipped ({f['skipped']})")
        return
    if name == "webxr":
        print(f"webxr: {f['teleop_ms'].get('n')} trials, loop {f.get('loop_hz')} Hz")
        for key, label in (("teleop_ms", "page pose -> fake arm moves"),
                           ("page_to_node_sample_ms", "page pose -> teleop node sample"),
                           ("echo_one_way_ms", "reference: bare WebSocket echo, one way")):
            print(f"  {label:48s} p50 {f[key]['p50']:8.3f} ms   p99 {f[key]['p99']:8.3f} ms")
        print(f"  ratio (page -> arm p50 / bare WebSocket one way p50): {f['ratio_p50']:g}x")
        return
    print(f"{name}: {f['events']} events, loop {f['loop_hz']:g} Hz, leader {f['leader_hz']:g} Hz, arm "
          f"{f['arm_hz']:g} Hz")
    for key, label in (("event_to_arm_ms", "device event -> arm write_joints (10 %)"),
                       ("event_to_arm_done_ms", "device event -> arm write_joints (90 %)"),
                       ("pty_read_ms", "reference: one Protocol 2.0 READ on the pty"),
                       ("pty_sync_read_ms", "reference: one Sync Read of 8 servos")):
        if key in f:
            print(f"  {label:48s} p50 {f[key]['p50']:8.3f} ms   p99 {f[key]['p99']:8.3f} ms")
    if f.get("ratio_p50") is not None:
        print(f"  ratio (event -> arm p50 / raw pty read p50): {f['ratio_p50']:g}x")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--device", action="append", choices=sorted(DEVICES),
                   help="device(s) to measure (repeat; default: all)")
    p.add_argument("--events", type=int, default=100, help="device events per device")
    p.add_argument("--round-trips", type=int, default=500, help="raw bus round trips for the reference")
    p.add_argument("--rate", type=float, default=100.0, help="control loop rate (Hz)")
    p.add_argument("--leader-rate", type=float, default=200.0, help="teleop device node rate (Hz)")
    p.add_argument("--arm-rate", type=float, default=200.0, help="fake arm node rate (Hz)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    args = p.parse_args(argv)
    results = {}
    for name in args.device or sorted(DEVICES):
        results[name] = DEVICES[name](args, lambda m: print(m, file=sys.stderr))
    if args.json:
        print(json.dumps(results, indent=2))
    else:
        for name, f in results.items():
            _print(name, f)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
