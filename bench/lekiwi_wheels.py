"""LeKiwi's wheel commands against the SO-100 arm's, over the same emulated Feetech bus, in the same run.

    uv run python bench/lekiwi_wheels.py [--commands 300] [--rounds 3]

Both drivers run as the runtime runs them (`rio.testing.lifecycle`) on private emulated buses (scservo_sdk
over a pseudo-terminal, emulated STS3215 servos answering from a thread of this process). For each command
the clock starts before the driver's write hook and stops when every servo it drives holds the new goal in
its register (polled under the bus lock every 50 us):

  wheels   `lekiwi.base.write_twist(twist)`: omni kinematics, 3 signed goal speeds, one SYNC WRITE (GOAL_VELOCITY)
  arm      `so100.follower.write_joints(q)`: calibration, 5 goal positions, one SYNC WRITE (GOAL_POSITION)

Then each node's whole `cycle()` (one SYNC READ of the state block, the kind's commander, one SYNC WRITE),
timed alone. Rows alternate wheels/arm in `--rounds` rounds, so a loaded machine slows both alike; the last
lines print the ratios wheels / arm of the medians. Broadcast writes get no answer, so "landed in the
register" is what the servo would act on; a real bus adds wire time (~0.1 ms for these packets at 1 Mbaud).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from rio_so100.feetech import control_table as T
from rio_so100.follower.driver import So100Follower
from rio_so100.lekiwi.wheels import LeKiwiBase

from rio import clock
from rio.testing import lifecycle

POLL_S = 50e-6


def _goal(servo, reg) -> int:
    return T.from_bytes(servo.mem, reg[0], reg[1])


def _landed(bus, expect: dict[int, int], reg) -> bool:
    with bus.lock:
        return all(_goal(bus.servo(sid), reg) == v for sid, v in expect.items())


def wheel_latencies(node: LeKiwiBase, n: int) -> list[float]:
    out = []
    for k in range(n):
        twist = np.array([0.05 + 0.15 * (k % 7) / 7, 0.02 * (k % 3), 0.3 * ((k % 5) - 2) / 2])
        steps = node.wheel_steps(twist)
        expect = {sid: T.encode_sign(int(v), 15) for sid, v in zip(node.ids, steps, strict=True)}
        t0 = time.perf_counter()
        node.write_twist(twist)
        while not _landed(node.emulator, expect, T.GOAL_VELOCITY):
            time.sleep(POLL_S)
        out.append(time.perf_counter() - t0)
    return out


def arm_latencies(node: So100Follower, n: int) -> list[float]:
    out, group = [], node.servos.group
    lower, upper = group.limits_rad()
    for k in range(n):
        q = lower + (upper - lower) * (0.3 + 0.4 * ((k % 7) / 7))
        expect = group.to_steps(q)
        t0 = time.perf_counter()
        node.write_joints(q)
        while not _landed(node.servos.conn.emulator, expect, T.GOAL_POSITION):
            time.sleep(POLL_S)
        out.append(time.perf_counter() - t0)
    return out


def cycle_times(node, n: int, command) -> list[float]:
    out = []
    for _ in range(n):
        command()
        t0 = time.perf_counter()
        node.cycle()
        out.append(time.perf_counter() - t0)
    return out


def row(name: str, times: list[float]) -> float:
    us = np.asarray(times) * 1e6
    med = float(np.median(us))
    print(f"{name:48s} n={us.size:5d}  median {med:7.0f} us  p99 {np.percentile(us, 99):7.0f} us")
    return med


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--commands", type=int, default=300, help="commands per row and round")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    n = args.commands
    res: dict[str, list[float]] = {"wl": [], "al": [], "wc": [], "ac": []}
    with lifecycle(LeKiwiBase(port="emulator", watchdog_s=1e6)) as wheels, \
            lifecycle(So100Follower(port="emulator", watchdog_s=1e6)) as arm:
        q0 = arm.servos.group.read()["joint_pos"]
        for _ in range(args.rounds):
            res["wl"] += wheel_latencies(wheels, n)
            res["al"] += arm_latencies(arm, n)
            res["wc"] += cycle_times(wheels, n, lambda: wheels.command("twist", np.array([0.1, 0.0, 0.2]),
                                                                       clock.now()))
            res["ac"] += cycle_times(arm, n, lambda: arm.command_joints(q0, clock.now()))
    print(f"{args.rounds} rounds of {n}, emulated Feetech buses in this process")
    wl = row("wheel command -> 3 goal speeds in the registers", res["wl"])
    al = row("arm command -> 5 goal positions in the registers", res["al"])
    wc = row("lekiwi.base cycle() (read, commander, write)", res["wc"])
    ac = row("so100.follower cycle() (read, commander, write)", res["ac"])
    print(f"ratio wheels / arm, command latency: {wl / al:.2f}")
    print(f"ratio wheels / arm, whole cycle:     {wc / ac:.2f}")


if __name__ == "__main__":
    main()
