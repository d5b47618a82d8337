"""The high-level (joint speed) driver against the fake base through a late driver cycle, in simulated time
(the driver's clock and the fake base's together), so the figures are exact: the base keeps the last joint
speeds until the next command, as a real one does, so a driver cycle that comes late leaves the arm further
along its way; the driver takes up from there instead of pulling the arm back and sending it on again."""

from __future__ import annotations

import math
import types

import numpy as np
import pytest
from rio_kinova.arm.driver import KinovaArm
from rio_kinova.fake import robot as fake_robot

from rio import clock
from rio.testing import lifecycle

IP = "127.0.0.13"  # a base of its own: it is made under the simulated clock
PLAN_ACCEL = 2 * math.pi * 0.3 / 0.7**2  # rad/s^2: the peak of `joint_path`'s raised cosine


@pytest.fixture
def sim_time(monkeypatch):
    now = [1000.0]
    monkeypatch.setattr(clock, "now", lambda: now[0])
    monkeypatch.setattr(fake_robot, "time", types.SimpleNamespace(monotonic=lambda: now[0]))
    return now


def joint_path(sim_time, late: dict[int, float], inside: bool = False) -> tuple[float, float]:
    """A 0.3 rad raised-cosine move of the first joint in 0.7 s and back, commanded at 30 Hz 50 ms ahead,
    driven at 100 Hz with the cycles in `late` taking that long instead (`inside`: the time passes between the
    cycle's read and its write, as when the driver's thread is descheduled mid-cycle); returns the path all
    joints went (rad) and where the first joint ended, from its start."""
    with lifecycle(KinovaArm(backend="fake", model="gen3", ip=IP)) as arm:
        k = 0
        if inside:
            read = arm.read_joints

            def read_then_stall() -> dict:
                sample = read()
                sim_time[0] += late.get(k, 0.0)
                return sample

            arm.read_joints = read_then_stall
        q0 = arm.read_state()["joint_pos"].copy()
        t0 = sim_time[0]

        def plan(t: float) -> np.ndarray:
            x = min(max((t - t0 - 0.1) / 0.7, 0.0), 2.0)
            f = (lambda u: u - math.sin(2 * math.pi * u) / (2 * math.pi))
            q = q0.copy()
            q[0] += 0.3 * (f(min(x, 1.0)) - f(max(x - 1.0, 0.0)))
            return q

        path, q_last, t_cmd = 0.0, q0, t0
        while sim_time[0] < t0 + 2.2:
            while t_cmd <= sim_time[0]:
                arm.command_joints(plan(t_cmd + 0.05), t_cmd + 0.05)
                t_cmd += 1 / 30
            q = arm.cycle()["joint_pos"]
            path += float(np.abs(q - q_last).sum())
            q_last = q
            sim_time[0] += 0.01 if inside else late.get(k, 0.01)
            k += 1
        for _ in range(100):  # settle
            q_last = arm.cycle()["joint_pos"]
            sim_time[0] += 0.01
        return path, float(q_last[0] - q0[0])


@pytest.mark.parametrize("late", [{40: 0.1}, {k: 0.04 for k in range(5, 200, 10)},
                                  {k: 0.3 for k in (20, 40, 60)},
                                  {40: 0.3, 41: 0.001, 42: 0.001, 43: 0.001, 44: 0.001, 45: 0.25, 46: 0.001}],
                         ids=["one cycle 100 ms late at full speed", "every tenth cycle 40 ms late",
                              "three 300 ms stalls", "stalls with bursts of short cycles after them"])
@pytest.mark.parametrize("inside", [False, True], ids=["between cycles", "between a cycle's read and write"])
def test_late_driver_cycles_add_little_travel(sim_time, late, inside):
    """0.627 rad for the 0.6 rad plan on time (the base's lag); before, 0.698 and 0.734 rad with the late
    cycles: the goal, held to max_step after a late cycle, pulled the arm back (and the speed was worked out
    over a cycle taken to be on time, 4x too fast after one 40 ms long). Stalls of 0.3 s (a loaded machine)
    swung the arm: a catch-up step over a 1 ms cycle was sent as a dash the base kept through the next stall,
    and the pull toward the goal, closing the error in less than one stall, overshot it each time."""
    on_time, end = joint_path(sim_time, {})
    late_path, end_late = joint_path(sim_time, late, inside)
    assert abs(end) < 1e-3 and abs(end_late) < 1e-3  # both back where they started
    # a stall of T at the plan's peak acceleration A leaves the arm up to A T^2 / 2 off the plan (the base keeps
    # its speed while the plan turns), there and back: what long stalls may add whatever the driver does
    stalls = sum(PLAN_ACCEL * t**2 for t in late.values() if t >= 0.2)
    assert late_path < on_time + 0.6 * 0.05 + stalls, (late_path, on_time, stalls)
