"""A policy across the link: observation -> first action when the cameras are on the robot's machine and
the policy on the workstation's, emulated on one machine (`rio.machine.netns`; Linux, root, `tc`).

The station: a 6-joint arm and a gripper (`rio.fake_arm`, `rio.fake_gripper`, as in `bench/obs_to_action.py`;
not the MuJoCo sim arm, whose physics process is not on the obs -> action path and would only add noise on a
loaded 2-core machine) and three 640x480 RGB cameras at 30 fps (the synthetic table-top scene of
`bench/multi_machine.py --scenario cameras`, which compresses like real frames), placed on the
robot's namespace (`[machines.robot]`, served by `rio serve STATION --machine robot`); on the workstation's
namespace `rio deploy`'s loop (`run_deploy`, as `bench/obs_to_action.py` runs it) starts the policy node
with the loop and drives the arm. The policy (`PixelPolicy`) reads every pixel of the three frames it is
given (a mean per camera) and sleeps the rest of a fixed 20 ms forward pass; its 10-action chunks at
50 Hz are asked for when half is left. Over the link the loop's camera clients mirror the frames (decoded
once), and each observation carries copies of them to the policy node: every image crosses the veth link,
then the loop->policy request.

Cases, one run each, in this order: the same station all on one machine over `shm` (frames by reference:
the reference), over `zmq` on one machine (loopback: what the network middleware costs without a link),
then zmq across the link at each of `bench/multi_machine.py`'s shapes (1 Gbit/s; 100 Mbit/s), with raw
camera slots (`codec = "raw"`) and compressed ones (`codec = "auto"`: JPEG colour across machines).
This kernel has no `netem` qdisc: `tc` shapes the rate only (tbf), so the links have no added delay or
loss (the bench prints what was applied).

Per case (figures measured from the observation's time `t_obs`, when the loop read the rings for it):
obs -> first action p50/p99 (to the first action of the chunk computed from it leaving `env.step`), the
overhead beyond the forward pass (first action minus that chunk's own measured forward pass, p50/p99),
the forward pass p50, chunks late (the schedule ran out before the next chunk landed: `late_events`),
chunks, the age at `t_obs` of the oldest camera frame in the observation (capture -> the loop's read: where
the link shows; both namespaces read one clock) and the overhead's ratio to the shm reference.

    sudo python bench/policy_link.py [--seconds 15] [--json]

Measured on the 2-core development machine while other engineers' jobs ran (load average 13-15 during the
run: every figure is noisy, p99s the most), 2026-11-29, `--seconds 15`, `tc` tbf (rate only):

    case                first    p99   fwd  overh    p99 x shm  sent @node late     age     p99
    shm, one machine     22.4   45.7  20.4    1.6    8.6  1.00   0.3   0.6    1    28.9    79.0
    zmq, one machine     29.8  120.7  20.2    9.4  100.6  5.86   3.0   8.3    3    28.2    61.0
    zmq, 1gbit, raw      29.2  126.5  20.2    8.8   76.1  5.53   3.0   7.8    8    37.3   114.9
    zmq, 1gbit, jpeg     31.7  104.2  20.2   11.0   77.8  6.89   2.9   9.7    2    32.2   233.3
    zmq, 100mbit, raw    29.7   69.8  20.2    9.3   48.6  5.83   3.1   8.3    4  1532.9  2395.1
    zmq, 100mbit, jpeg   31.4   67.7  20.3   11.0   46.4  6.89   2.9   9.6    5    35.3   149.6
    (ms, p50 unless p99; fwd: the forward pass; overh: first - fwd; sent: t_obs -> the request enqueued;
    @node: t_obs -> the policy node took it; age: the oldest camera frame's at t_obs; 125 chunks each)

An earlier run of the same send path at load average 18-22 agreed within 1 ms at p50 (zmq overheads
9.1-11.4 ms).

What it says:
- The link adds nothing measurable to obs -> first action: the loop reads its cameras' local mirrors, so
  crossing the link happens before `t_obs`. The overhead over zmq (8.8-11.0 ms p50, 5.5-6.9 x shm's 1.6 ms)
  is the loop -> policy request on the workstation: the observation carries copies of the three frames
  (2.8 MB), enqueued 3 ms after `t_obs` and taken by the node 8-10 ms after it, as much on one machine as
  across the link; the node's intake of it takes 0.5 ms (measured apart), the rest is the trip over TCP
  loopback through threads waiting for a CPU on a loaded machine. Over shm the frames go by reference
  (0.3 / 0.6 ms). JPEG costs ~2 ms more than raw, probably the loop process decoding 90 frames/s.
- The link shows in the frames' age. 3 raw 640x480 streams at 30 fps need ~660 Mbit/s: over 100 Mbit/s raw
  the frames the policy acts on are 1.5 s old (p50; 2.4 s p99) while obs -> action looks fine; JPEG brings
  them back to 35 ms. At 1 Gbit/s raw and JPEG are alike (37 / 32 ms; the capture period alone is 33 ms).
- Before the send-path fix made with this bench (`rio.runtime.buffers.RequestSender`, zmq
  `_send_parts`: the request's record copied once after its check, not four times), the same bench (load
  average ~10) measured zmq overheads of 13.8-15.4 ms p50 and the request enqueued 6.1 ms after `t_obs`.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from typing import Any

import numpy as np

from rio.policy.node import PolicyNode
from rio.policy.testing import SleepPolicy
from rio.schema import Observation

#: The forward pass the stand-in model takes, pixels read included (s).
FORWARD_S = 0.020
CAMERAS = ("cam0_camera", "cam1_camera", "cam2_camera")
PORT = 7600
#: (label, tc rate): `bench/multi_machine.py`'s links (rate only: no netem here).
LINKS = [("1gbit", "1gbit"), ("100mbit", "100mbit")]
POLICY = f"policy_link:PixelPolicyNode,forward_s={FORWARD_S},chunk=10,rate_hz=50"


# -- the stand-in model and the bench camera driver ---------------------------------------------------------
class PixelPolicy(SleepPolicy):
    """Reads every pixel of every camera frame (a mean each), then sleeps the rest of `forward_s`: a model that
    consumes the images, with a forward pass of known length."""

    name = "bench.pixels"

    def infer(self, obs: Observation) -> np.ndarray:
        t0 = time.perf_counter()
        means = [float(cam.rgb.mean()) for cam in obs.cameras.values()]
        if len(means) != len(CAMERAS):
            raise RuntimeError(f"policy saw {len(means)} cameras, expected {len(CAMERAS)}")
        left = self.config.forward_s - (time.perf_counter() - t0)
        if left > 0:
            time.sleep(left)
        return np.repeat(np.asarray(obs.proprio, dtype=np.float64)[None, :], self.config.chunk, axis=0)


class PixelPolicyNode(PolicyNode):
    policy_class = PixelPolicy


class _BenchDrivers:
    """A plugin registering the bench camera (`rio.benchmarks.link.SceneCamera`) as a station driver."""

    def __init__(self) -> None:
        from rio.plugins.hookspecs import hookimpl
        from rio.plugins.specs import Spec

        @hookimpl
        def rio_drivers() -> list[Spec]:
            return [Spec("bench.scene_camera", "camera", "rio.benchmarks.link:SceneCamera",
                         "camera: a synthetic table-top scene (bench)")]

        self.rio_drivers = rio_drivers


def register_drivers() -> None:
    from rio.plugins.registry import get_registry

    reg = get_registry()
    if "bench-link" not in reg.plugins:
        reg.register(_BenchDrivers(), name="bench-link")


def station_toml(middleware: str, codec: str, robot: str | None) -> str:
    """The bench station; `robot`: the robot's address (its nodes placed there), None: all on one machine."""
    lines = ['name = "link-policy"', "rate_hz = 50", "[middleware]", f'name = "{middleware}"']
    if middleware != "shm":
        # generous liveness: the figures are the link's, and a loaded machine may pause a reader for a while
        lines += ["insecure = true", "heartbeat_timeout = 30.0", "connect_timeout = 60.0"]
    if robot:
        nodes = ", ".join(f'"{n}"' for n in ("arm", "gripper", *CAMERAS))
        lines += ["[machines.robot]", f'address = "{robot}"', f"nodes = [{nodes}]", f"port = {PORT}"]
    lines += ["[components.arm]", 'driver = "rio.fake_arm"', "dof = 6", "rate_hz = 200.0",
              "[components.gripper]", 'driver = "rio.fake_gripper"', "rate_hz = 200.0"]
    for i, cam in enumerate(CAMERAS):
        lines += [f"[components.{cam}]", 'driver = "bench.scene_camera"', "width = 640", "height = 480",
                  "rate_hz = 30.0", f"seed = {i}", f'codec = "{codec}"']
    return "\n".join(lines) + "\n"


# -- the two sides ------------------------------------------------------------------------------------------
def robot_side(station: str) -> int:
    """`rio serve STATION --machine robot`, with the bench camera registered."""
    register_drivers()
    from rio.cli import main

    return main(["serve", station, "--machine", "robot"])


def loop_side(station: str, seconds: float) -> dict[str, Any]:
    """`rio deploy`'s loop on this machine: the figures as one dict."""
    register_drivers()
    from rio.policy import AsyncConfig
    from rio.workflows.deploy import run_deploy

    ages: list[float] = []

    def on_tick(tick: Any) -> None:
        stamps = [c.meta["timestamp"] for c in tick.step.observation.cameras.values()]
        if stamps:
            ages.append(tick.step.meta["t_obs"] - min(stamps))

    summary = run_deploy(station, POLICY, duration=seconds, on_tick=on_tick, config=AsyncConfig(),
                         log=lambda m: print(f"[policy_link] {m}", file=sys.stderr, flush=True))
    s = summary.details.get("stats", {})
    a = np.asarray(ages[len(ages) // 10:]) * 1e3  # the first tenth: connections settling
    keys = ("first_action_ms_p50", "first_action_ms_p99", "overhead_ms_p50", "overhead_ms_p99", "forward_ms_p50",
            "obs_sent_ms_p50", "obs_to_policy_ms_p50", "chunks", "requests", "late_events", "late_ticks", "timeouts",
            "frame_misses")
    return {**{k: s.get(k) for k in keys},
            "frame_age_ms_p50": round(float(np.percentile(a, 50)), 1) if a.size else None,
            "frame_age_ms_p99": round(float(np.percentile(a, 99)), 1) if a.size else None,
            "loop_overruns": summary.overruns, "seconds": round(summary.seconds, 1), "reason": summary.reason}


# -- the orchestrator ---------------------------------------------------------------------------------------
def _python(*args: str) -> list[str]:
    return [sys.executable, os.path.abspath(__file__), *args]


def _case(net: Any, tmp: str, label: str, middleware: str, codec: str, link: bool, seconds: float) -> dict:
    path = os.path.join(tmp, f"{label}.toml")
    with open(path, "w") as f:
        f.write(station_toml(middleware, codec, net.a.address if link else None))
    print(f"[bench] {label} ...", file=sys.stderr, flush=True)
    robot = None
    try:
        if link:
            robot = net.a.popen(_python("--robot", path), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL, text=True)
            t_end = time.monotonic() + 300
            while time.monotonic() < t_end:  # `rio serve` says "serving ..." once its nodes are ready
                line = robot.stdout.readline()
                if not line:
                    raise RuntimeError(f"rio serve ended (exit code {robot.wait()})")
                if line.startswith("serving "):
                    break
        out = net.b.run(_python("--loop", path, "--seconds", str(seconds)), capture_output=True, text=True,
                        timeout=seconds + 600)
        if out.returncode != 0:
            raise RuntimeError(out.stderr[-3000:])
        return json.loads(out.stdout.strip().splitlines()[-1])
    finally:
        if robot is not None:
            robot.send_signal(2)
            try:
                robot.wait(timeout=30)
            except subprocess.TimeoutExpired:
                robot.kill()


def run(seconds: float) -> list[dict]:
    from rio.machine import netns

    rows = []
    with tempfile.TemporaryDirectory(prefix="rio-pl-") as tmp, netns.TwoMachines() as net:
        for label, mw in (("shm, one machine", "shm"), ("zmq, one machine", "zmq")):
            rows.append({"case": label, "tc": "-", **_case(net, tmp, mw, mw, "auto", False, seconds)})
        for link, rate in LINKS:
            applied = net.shape(rate)
            print(f"[bench] link {link}: {applied}", file=sys.stderr, flush=True)
            for codec in ("raw", "auto"):
                name = f"zmq, {link}, {'raw' if codec == 'raw' else 'jpeg'}"
                rows.append({"case": name, "tc": applied,
                             **_case(net, tmp, f"{link}-{codec}", "zmq", codec, True, seconds)})
        net.shape()
    ref = rows[0]
    for r in rows:
        r["overhead_x_shm"] = (round(r["overhead_ms_p50"] / ref["overhead_ms_p50"], 2)
                               if r.get("overhead_ms_p50") and ref.get("overhead_ms_p50") else None)
        r["first_action_x_shm"] = (round(r["first_action_ms_p50"] / ref["first_action_ms_p50"], 2)
                                   if r.get("first_action_ms_p50") and ref.get("first_action_ms_p50") else None)
    return rows


def _f(x: float | None, w: int, spec: str = ".1f") -> str:
    return f"{x:>{w}{spec}}" if x is not None else f"{'-':>{w}}"


def table(rows: list[dict]) -> str:
    links = "; ".join(dict.fromkeys(f"{r['tc']}" for r in rows if r["tc"] != "-"))
    out = [f"obs -> first action, 3 x 640x480 RGB @ 30 fps on the robot, a {FORWARD_S * 1e3:g} ms forward pass "
           f"reading every pixel on the workstation; links: {links}",
           f"{'case':18} {'first':>6} {'p99':>6} {'fwd':>5} {'overh':>6} {'p99':>6} {'x shm':>5} {'sent':>5} "
           f"{'@node':>5} {'late':>4} {'age':>7} {'p99':>7}"]
    for r in rows:
        out.append(f"{r['case']:18} {_f(r['first_action_ms_p50'], 6)} {_f(r['first_action_ms_p99'], 6)} "
                   f"{_f(r['forward_ms_p50'], 5)} {_f(r['overhead_ms_p50'], 6)} {_f(r['overhead_ms_p99'], 6)} "
                   f"{_f(r['overhead_x_shm'], 5, '.2f')} {_f(r.get('obs_sent_ms_p50'), 5)} "
                   f"{_f(r.get('obs_to_policy_ms_p50'), 5)} {r['late_events'] or 0:4d} "
                   f"{_f(r['frame_age_ms_p50'], 7)} {_f(r['frame_age_ms_p99'], 7)}")
    out.append("ms, p50 unless p99. first: obs -> first action; fwd: forward pass; overh: first - that chunk's fwd; "
               "x shm: overh / the shm case's; sent: t_obs -> the request enqueued; @node: t_obs -> the policy node "
               "took it; late: chunks that landed after the schedule ran out; age: capture -> the loop's read, "
               f"oldest camera; chunks per case: {', '.join(str(r['chunks']) for r in rows)}")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=15.0, help="deploy seconds per case")
    p.add_argument("--json", action="store_true")
    p.add_argument("--robot", help=argparse.SUPPRESS)
    p.add_argument("--loop", help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.robot:
        return robot_side(a.robot)
    if a.loop:
        print(json.dumps(loop_side(a.loop, a.seconds)), flush=True)
        return 0
    from rio.machine import netns

    why = netns.available() or netns.TC.missing()
    if why:
        print(f"cannot emulate two machines here: {why}", file=sys.stderr)
        return 2
    rows = run(a.seconds)
    print(json.dumps(rows, indent=2) if a.json else table(rows))
    return 0


if __name__ == "__main__":  # spawned children re-import this file as __mp_main__: run nothing then
    raise SystemExit(main())
