"""How fast joint targets reach an xArm through the SDK, bare and through RIO's arm driver, against the
controller emulator in its own process (as a real controller costs the host nothing).

    python plugins/rio-ufactory/bench/servo_rate.py [--seconds 3] [--model xarm7] [--json]

Rows, measured in this run against the same emulator:
  sdk max rate        set_servo_angle_j back to back (each call waits for the controller's reply)
  rio max rate        the XArm node's cycle back to back: report read + commander + set_servo_angle_j
  sdk @250 Hz         paced at the controller's servo rate: achieved rate and period jitter
  rio @250 Hz         the node's cycle paced the same way
  latency             command issued -> the real-time report shows the joint moving (p50 / p99 over
                      repeated small steps; the report runs at 250 Hz, so 4 ms is its resolution)
The ratio column is RIO / bare SDK. The xArm's own servo loop runs at 250 Hz: a path that sustains
250 Hz paced with low jitter keeps up with the controller.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

import numpy as np


def start_emulator(model: str) -> tuple[subprocess.Popen, str]:
    from rio_ufactory.loopback import free_loopback, is_free

    host = free_loopback()
    proc = subprocess.Popen([sys.executable, "-m", "rio", "ufactory", "emulator", "--model", model, "--ip", host,
                             "--gripper", "none"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t_end = time.monotonic() + 30
    while is_free(host):
        if time.monotonic() > t_end or proc.poll() is not None:
            raise RuntimeError("the emulator did not start")
        time.sleep(0.05)
    return proc, host


def rate(step, seconds: float, period: float | None = None) -> dict:
    step()
    times, t0 = [], time.perf_counter()
    next_t = t0
    while time.perf_counter() - t0 < seconds:
        if period is not None:
            next_t += period
            while time.perf_counter() < next_t:
                pass
        t = time.perf_counter()
        step()
        times.append(t)
    dt = np.diff(times)
    return {"hz": len(times) / (times[-1] - t0), "period_p99_ms": float(np.percentile(dt, 99) * 1e3)}


def latency(send, joint0, trials: int = 40) -> dict:
    """send(q) issues a target; joint0() reads joint 0 from the report. Small alternating steps."""
    out = []
    base = joint0()
    for k in range(trials):
        goal = base + (0.004 if k % 2 == 0 else 0.0)
        before = joint0()
        t = time.perf_counter()
        send(goal)
        while abs(joint0() - before) < 0.001 and time.perf_counter() - t < 0.5:
            time.sleep(0.0002)
        out.append(time.perf_counter() - t)
        time.sleep(0.05)
    a = np.array(out) * 1e3
    return {"p50_ms": float(np.percentile(a, 50)), "p99_ms": float(np.percentile(a, 99))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--model", default="xarm7")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    from rio_ufactory.arm.driver import XArm
    from xarm.wrapper import XArmAPI

    from rio import clock
    from rio.testing import lifecycle

    proc, host = start_emulator(a.model)
    res: dict[str, dict] = {}
    try:
        sdk = XArmAPI(host, is_radian=True, report_type="real")
        sdk.motion_enable(True)
        sdk.set_mode(1)
        sdk.set_state(0)
        time.sleep(0.3)
        q = list(sdk.angles[: sdk.axis])
        res["sdk max rate"] = rate(lambda: sdk.set_servo_angle_j(q), a.seconds)
        res["sdk @250 Hz"] = rate(lambda: sdk.set_servo_angle_j(q), a.seconds, 1 / 250)

        def sdk_send(g0):
            q[0] = g0
            sdk.set_servo_angle_j(q)

        res["sdk latency"] = latency(sdk_send, lambda: sdk.angles[0])
        sdk.disconnect()

        with lifecycle(XArm(ip=host, model=a.model)) as arm:
            res["rio max rate"] = rate(arm.read_state, a.seconds)
            res["rio @250 Hz"] = rate(arm.read_state, a.seconds, 1 / 250)
            state = {}

            def rio_send(g0):
                goal = state["q"].copy()
                goal[0] = g0
                arm.command_joints(goal, clock.now())
                state["s"] = arm.cycle()  # the node's next cycle sends it

            state["q"] = arm.cycle()["joint_pos"]

            def rio_joint0():
                state["s"] = arm.cycle()
                return float(state["s"]["joint_pos"][0])

            res["rio latency"] = latency(rio_send, rio_joint0)
    finally:
        proc.terminate()
        proc.wait(10)
    if a.json:
        print(json.dumps(res, indent=1))
        return
    print(f"xArm emulator ({a.model}, own process) on {host}; {a.seconds:g} s per row")
    for what in ("max rate", "@250 Hz"):
        s, r = res[f"sdk {what}"], res[f"rio {what}"]
        print(f"  {what:9s} sdk {s['hz']:7.0f} Hz (p99 period {s['period_p99_ms']:5.2f} ms)   rio {r['hz']:7.0f} Hz "
              f"(p99 period {r['period_p99_ms']:5.2f} ms)   rio/sdk {r['hz'] / s['hz']:.2f}")
    s, r = res["sdk latency"], res["rio latency"]
    print(f"  latency   sdk p50 {s['p50_ms']:.1f} ms p99 {s['p99_ms']:.1f} ms   rio p50 {r['p50_ms']:.1f} ms "
          f"p99 {r['p99_ms']:.1f} ms   rio/sdk p50 {r['p50_ms'] / s['p50_ms']:.2f}")


if __name__ == "__main__":
    main()
