"""The high-level driver (joint speeds, or twists with `eef_control = "native"`) against the fake base through a
late driver cycle, in simulated time (the driver's clock and the fake base's together), so the figures are
exact: the base keeps the last speeds until the next command, as a real one does, so a driver cycle that comes
late leaves the arm further along its way; the driver takes up from there instead of pulling the arm back and
sending it on again."""

from __future__ import annotations

import math
import types

import numpy as np
import pytest
from rio_kinova.arm.driver import KinovaArm
from rio_kinova.fake import robot as fake_robot

from rio import clock
from rio.control import quat_angle, quat_mul, rotvec_to_quat
from rio.testing import lifecycle

IP = "127.0.0.13"  # a base of its own: it is made under the simulated clock
PLAN_ACCEL = 2 * math.pi / 0.7**2  # per unit of amplitude: the peak acceleration of `raised_cosine`


@pytest.fixture
def sim_time(monkeypatch):
    now = [1000.0]
    monkeypatch.setattr(clock, "now", lambda: now[0])
    monkeypatch.setattr(fake_robot, "time", types.SimpleNamespace(monotonic=lambda: now[0]))
    return now


def raised_cosine(t0: float, amplitude: float):
    """0 -> `amplitude` in 0.7 s from t0 + 0.1 and back, along a raised cosine (peak acceleration `PLAN_ACCEL`
    per unit of amplitude)."""
    f = (lambda u: u - math.sin(2 * math.pi * u) / (2 * math.pi))

    def at(t: float) -> float:
        x = min(max((t - t0 - 0.1) / 0.7, 0.0), 2.0)
        return amplitude * (f(min(x, 1.0)) - f(max(x - 1.0, 0.0)))
    return at


def drive(sim_time, late: dict[int, float], inside: bool, plan, **config) -> list[dict]:
    """Command `plan(arm, t0)`'s targets (`command(t) -> None`) at 30 Hz 50 ms ahead and run the driver at 100 Hz,
    the cycles in `late` taking that long instead (`inside`: the time passes between the cycle's read and its
    write, as when the driver's thread is descheduled mid-cycle); then let it settle. Returns every sample."""
    with lifecycle(KinovaArm(backend="fake", model="gen3", ip=IP, **config)) as arm:
        k = 0
        if inside:
            read = arm.read_joints

            def read_then_stall() -> dict:
                sample = read()
                sim_time[0] += late.get(k, 0.0)
                return sample

            arm.read_joints = read_then_stall
        t0 = sim_time[0]
        command, samples, t_cmd = plan(arm, t0), [arm.read_state()], t0
        while sim_time[0] < t0 + 2.2:
            while t_cmd <= sim_time[0]:
                command(t_cmd + 0.05)
                t_cmd += 1 / 30
            samples.append(arm.cycle())
            sim_time[0] += 0.01 if inside else late.get(k, 0.01)
            k += 1
        for _ in range(100):  # settle
            samples.append(arm.cycle())
            sim_time[0] += 0.01
        return samples


def joint_path(sim_time, late: dict[int, float], inside: bool = False) -> tuple[float, float]:
    """A 0.3 rad move of the first joint and back (joint speeds); returns the path all joints went (rad) and
    where the first joint ended, from its start."""
    def plan(arm, t0):
        q0, move = arm.read_state()["joint_pos"].copy(), raised_cosine(t0, 0.3)
        return lambda t: arm.command_joints(q0 + np.eye(len(q0))[0] * move(t), t)

    q = np.array([s["joint_pos"] for s in drive(sim_time, late, inside, plan)])
    return float(np.abs(np.diff(q, axis=0)).sum()), float(q[-1, 0] - q[0, 0])


def tool_path(sim_time, late: dict[int, float], inside: bool = False) -> tuple[float, float, float]:
    """A 0.1 m move along x turning 0.3 rad about z, and back, by the base's twists (`eef_control = "native"`);
    returns the tool's path (m), its turning (rad) and how far it ended from its start (m + rad)."""
    def plan(arm, t0):
        p0, move, turn = arm.read_state()["eef_pose"].copy(), raised_cosine(t0, 0.1), raised_cosine(t0, 0.3)
        return lambda t: arm.command_eef(np.concatenate([p0[:3] + [move(t), 0.0, 0.0],
                                                         quat_mul(rotvec_to_quat([0.0, 0.0, turn(t)]), p0[3:])]), t)

    p = np.array([s["eef_pose"] for s in drive(sim_time, late, inside, plan, eef_control="native")])
    turning = sum(quat_angle(a[3:], b[3:]) for a, b in zip(p[:-1], p[1:], strict=True))
    return (float(np.linalg.norm(np.diff(p[:, :3], axis=0), axis=1).sum()), turning,
            float(np.linalg.norm(p[-1, :3] - p[0, :3])) + quat_angle(p[-1, 3:], p[0, 3:]))


LATE = pytest.mark.parametrize("late", [{40: 0.1}, {k: 0.04 for k in range(5, 200, 10)},
                                        {k: 0.3 for k in (20, 40, 60)},
                                        {40: 0.3, 41: 0.001, 42: 0.001, 43: 0.001, 44: 0.001, 45: 0.25, 46: 0.001}],
                               ids=["one cycle 100 ms late at full speed", "every tenth cycle 40 ms late",
                                    "three 300 ms stalls", "stalls with bursts of short cycles after them"])
INSIDE = pytest.mark.parametrize("inside", [False, True], ids=["between cycles", "between a cycle's read and write"])


def stalls(late: dict[int, float]) -> float:
    """A stall of T at the plan's peak acceleration A leaves the arm up to A T^2 / 2 off the plan (the base keeps
    its speed while the plan turns), there and back: what long stalls may add whatever the driver does (per unit
    of the plan's amplitude)."""
    return sum(PLAN_ACCEL * t**2 for t in late.values() if t >= 0.2)


@LATE
@INSIDE
def test_late_driver_cycles_add_little_travel(sim_time, late, inside):
    """0.627 rad for the 0.6 rad plan on time (the base's lag); before, 0.698 and 0.734 rad with the late
    cycles: the goal, held to max_step after a late cycle, pulled the arm back (and the speed was worked out
    over a cycle taken to be on time, 4x too fast after one 40 ms long). Stalls of 0.3 s (a loaded machine)
    swung the arm: a catch-up step over a 1 ms cycle was sent as a dash the base kept through the next stall,
    and the pull toward the goal, closing the error in less than one stall, overshot it each time."""
    on_time, end = joint_path(sim_time, {})
    late_path, end_late = joint_path(sim_time, late, inside)
    assert abs(end) < 1e-3 and abs(end_late) < 1e-3  # both back where they started
    assert late_path < on_time + 0.6 * 0.05 + 0.3 * stalls(late), (late_path, on_time)


@LATE
@INSIDE
def test_late_driver_cycles_add_little_tool_travel_with_twists(sim_time, late, inside):
    """The same for the base's Cartesian control (`eef_control = "native"`, a twist per cycle), which the base
    also keeps until the next command. Before, a twist was a pull of gain 8 toward the goal and nothing else:
    three 300 ms stalls swung the tool through 0.59-0.61 m and 1.17-1.22 rad for a 0.2 m, 0.6 rad plan. Now, as
    with joint speeds, the goal's step of travel over the cycle gap plus a pull that gives way to slow cycles,
    from where the late cycle brought the tool: 0.37-0.38 m and 0.63 rad."""
    on_time, on_time_turn, end = tool_path(sim_time, {})
    late_path, late_turn, end_late = tool_path(sim_time, late, inside)
    assert end < 1e-3 and end_late < 1e-3  # both back where they started
    assert abs(on_time - 0.2) < 0.2 * 0.05 and abs(on_time_turn - 0.6) < 0.6 * 0.1  # on time: the plan
    assert late_path < on_time + 0.2 * 0.1 + 0.1 * stalls(late), (late_path, on_time)
    assert late_turn < on_time_turn + 0.6 * 0.05 + 0.3 * stalls(late), (late_turn, on_time_turn)
