"""How well a UR follows a slow stream of timestamped targets: through RIO's arm node (the kind's
commander interpolates the 10 Hz targets to the 500 Hz servoJ stream a UR expects) versus the same
10 Hz targets sent straight as servoJ (what a policy loop without an interpolator does). Against the
controller emulator in its own process (servoJ semantics: newest target wins, smoothed over
`lookahead_time`, see rio_ur.emulator.robot), measured through the real ur-rtde receive interface.

    python plugins/rio-ur/bench/servo_tracking.py [--seconds 8] [--json]

The path: joints 1 and 2 swing 0.2 rad about home at 0.25 Hz (peak 0.31 rad/s). Each 100 ms a target
is sent for 100 ms ahead. Reported per mode, after a 1 s start:
  error      |measured - ideal| of the worst joint (mrad), p50 / p99, where ideal is the path itself
  error*     the same after removing the best constant lag (0-300 ms): the shape, not the delay
  jitter     |measured joint velocity - ideal velocity| (rad/s), p50 / p99: how steppy the motion is
The ratio line is direct / RIO (> 1: RIO tracks better). Timing on a loaded machine is noisy; compare
runs of the same machine only.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

AMP, FREQ, TARGET_HZ = 0.2, 0.25, 10.0


def path(home: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    q, qd = home.copy(), np.zeros(6)
    w = 2 * np.pi * FREQ
    for j in (0, 1):
        q[j] += AMP * np.sin(w * t)
        qd[j] = AMP * w * np.cos(w * t)
    return q, qd


def stats(ts, qs, qds, home) -> dict:
    ts, qs, qds = np.asarray(ts), np.asarray(qs), np.asarray(qds)
    keep = ts > 1.0
    ts, qs, qds = ts[keep], qs[keep], qds[keep]
    ideal = np.array([path(home, t)[0] for t in ts])
    ideal_v = np.array([path(home, t)[1] for t in ts])
    err = np.abs(qs - ideal).max(axis=1) * 1e3
    best = min(np.arange(0.0, 0.301, 0.005),
               key=lambda lag: np.median(np.abs(qs - np.array([path(home, t - lag)[0] for t in ts])).max(axis=1)))
    err_lag = np.abs(qs - np.array([path(home, t - best)[0] for t in ts])).max(axis=1) * 1e3
    jit = np.abs(qds - ideal_v).max(axis=1)
    p = lambda a, k: float(np.percentile(a, k))  # noqa: E731
    return {"error_p50_mrad": p(err, 50), "error_p99_mrad": p(err, 99), "lag_ms": float(best * 1e3),
            "error_lagged_p50_mrad": p(err_lag, 50), "error_lagged_p99_mrad": p(err_lag, 99),
            "jitter_p50_rad_s": p(jit, 50), "jitter_p99_rad_s": p(jit, 99), "samples": int(len(ts))}


def run(emu, seconds: float, through_rio: bool) -> dict:
    from rio_ur.arm.driver import URArm
    from rio_ur.control import EmulatedControl
    from rtde_receive import RTDEReceiveInterface

    from rio import clock
    from rio.conformance.driving import Loop
    from rio.testing import lifecycle

    emu.inject("reset")
    home = np.asarray(emu.state()["q"])
    recv = RTDEReceiveInterface(emu.host)
    ts, qs, qds = [], [], []
    try:
        if through_rio:
            with lifecycle(URArm(**emu.driver_fields, model="ur5e")) as arm:
                loop, t0, next_target = Loop(arm), clock.now(), 0.0
                while (t := clock.now() - t0) < seconds:
                    if t >= next_target:
                        arm.command_joints(path(home, next_target + 0.1)[0], t0 + next_target + 0.1)
                        next_target += 1 / TARGET_HZ
                    loop.tick()
                    ts.append(clock.now() - t0)
                    qs.append(recv.getActualQ())
                    qds.append(recv.getActualQd())
        else:
            ctl = EmulatedControl(emu.host)
            try:
                t0, next_target, period = clock.now(), 0.0, 1 / 500
                t_next = t0
                while (t := clock.now() - t0) < seconds:
                    if t >= next_target:
                        ctl.servoJ(path(home, next_target + 0.1)[0].tolist(), 0, 0, 0.002, 0.1, 300)
                        next_target += 1 / TARGET_HZ
                    ts.append(t)
                    qs.append(recv.getActualQ())
                    qds.append(recv.getActualQd())
                    t_next += period
                    time.sleep(max(0.0, t_next - clock.now()))
            finally:
                ctl.disconnect()
    finally:
        recv.disconnect()
    return stats(ts, qs, qds, home)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=8.0)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    from rio_ur.emulator.process import EmulatorProcess

    with EmulatorProcess("ur5e") as emu:
        res = {"rio (500 Hz interpolated)": run(emu, a.seconds, True),
               "direct (10 Hz servoJ)": run(emu, a.seconds, False)}
    r, d = res["rio (500 Hz interpolated)"], res["direct (10 Hz servoJ)"]
    res["ratio direct/rio"] = {k: d[k] / r[k] for k in r if k.startswith(("error", "jitter")) and r[k] > 0}
    if a.json:
        print(json.dumps(res, indent=1))
        return
    for name, row in res.items():
        print(f"{name:28s} " + "  ".join(f"{k}={v:.3g}" for k, v in row.items()))


if __name__ == "__main__":
    main()
