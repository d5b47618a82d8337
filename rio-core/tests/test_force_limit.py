"""The force limit: an arm whose wrench crosses its station's limit holds where it is (the commander's
`guard`), counts and logs the crossing by node name, follows only commands that back it off while the
wrench stays over, and zeroes its wrench at enable. The arm here is RIO's fake arm pressing its tool
against a virtual wall: a spring of 1000 N/m below z = -0.02 m (joint 3 carries the tool 0.1 m per rad
along z), so every figure is exact."""

from __future__ import annotations

import logging

import numpy as np
import pytest
from pydantic import ValidationError

from rio import clock
from rio.control.commander import JointCommander
from rio.control.force_limit import ForceLimit
from rio.fakes.arms import FakeArm
from rio.testing import lifecycle

WALL_Z, STIFFNESS, TOOL_WEIGHT = -0.02, 1000.0, [0.0, 0.0, -3.0, 0.0, 0.01, 0.0]


class WallArm(FakeArm):
    """The fake arm with a wrist sensor: its tool's weight, plus the wall's push once the tool is below it."""

    def read_wrench(self):
        w = np.array(TOOL_WEIGHT)
        w[2] += STIFFNESS * max(WALL_Z - self.pose[2], 0.0)
        return w


def run(arm: WallArm, cycles: int) -> list[dict]:
    return [arm.cycle() for _ in range(cycles)]


def test_the_limit_checks_magnitudes_and_ignores_what_is_unset_or_nan():
    limit = ForceLimit(force_n=10.0)
    assert limit.exceeded([6, 8, 0, 0, 0, 0]) is None  # |f| = 10
    assert limit.exceeded([6, 8, 1, 50, 0, 0]) == "force 10.0 N > 10 N"
    assert ForceLimit(torque_nm=1.0).exceeded([99, 0, 0, 0, 0.8, 0.7]) == "torque 1.06 N m > 1 N m"
    assert limit.exceeded([np.nan] * 6) is None


def test_a_crossing_holds_where_the_arm_is_and_counts_once(caplog):
    c = JointCommander([-5.0], [5.0], max_step=0.1, watchdog_s=10.0, start=[0.0])
    c.owner, c.force_limit = "node 'arm'", ForceLimit(force_n=10.0)
    now = clock.now()
    c.command([2.0], now, now)
    assert not c.guard([0.0] * 6, [0.0], now)
    assert c.step(now)[0] == pytest.approx(0.1)
    with caplog.at_level(logging.WARNING, logger="rio.control"):
        assert c.guard([0, 0, 12.0, 0, 0, 0], [0.08], now)  # it measures itself a little behind its goal
        assert c.step(now)[0] == pytest.approx(0.08) and c.holding  # held where it is, the move dropped
        assert c.guard([0, 0, 12.0, 0, 0, 0], [0.08], now) and c.step(now)[0] == pytest.approx(0.08)
    assert c.force_holds == 1 and caplog.text.count("node 'arm': force 12.0 N > 10 N") == 1
    c.command([3.0], now, now)  # pushing on while over the limit: goes nowhere
    assert c.guard([0, 0, 12.0, 0, 0, 0], [0.08], now) and c.step(now)[0] == pytest.approx(0.08)
    c.command([-1.0], now, now)  # backing off toward where it was within the limit (0.0): followed
    assert c.guard([0, 0, 12.0, 0, 0, 0], [0.08], now) and c.step(now)[0] == pytest.approx(-0.02)
    assert not c.guard([0.0] * 6, [-0.02], now)  # back under: a new crossing would count again
    c.command([3.0], now, now)
    assert c.step(now)[0] == pytest.approx(0.08)
    assert c.guard([0, 0, 11.0, 0, 0, 0], [0.08], now) and c.force_holds == 2


def test_an_arm_pressed_into_a_wall_stops_at_the_limit_and_can_back_off():
    arm = WallArm(dof=3, force_limit={"force_n": 15.0}, max_step_rad=0.02)
    with lifecycle(arm):
        s = run(arm, 1)[0]
        assert np.allclose(s["ext_wrench"], 0.0) and s["force_holds"] == 0  # the tool's weight is the zero
        arm.command_joints(np.array([0.0, 0.0, -2.0]), clock.now())  # the tool 20 cm down: 18 cm into the wall
        samples = run(arm, 100)
        z = np.array([s["eef_pose"][2] for s in samples])
        f = np.array([s["ext_wrench"][2] for s in samples])
        assert samples[-1]["force_holds"] == 1
        # held on the first cycle over 15 N: one step (2 mm) past 15 mm into the wall at most, never further
        assert z.min() >= WALL_Z - 0.015 - 0.002 - 1e-9 and f.max() <= 17.0 + 1e-6
        assert samples[-1]["holding"]
        arm.command_joints(np.array([0.0, 0.0, 0.0]), clock.now())  # back up: followed
        s = run(arm, 100)[-1]
    assert s["eef_pose"][2] == pytest.approx(0.0) and s["ext_wrench"][2] == pytest.approx(0.0)
    assert s["force_holds"] == 1


def test_without_a_limit_it_pushes_through():
    arm = WallArm(dof=3, max_step_rad=0.02)
    with lifecycle(arm):
        arm.command_joints(np.array([0.0, 0.0, -2.0]), clock.now())
        s = run(arm, 150)[-1]
    assert s["eef_pose"][2] == pytest.approx(-0.2) and "force_holds" not in s and "ext_wrench" not in s


def test_end_effector_streaming_is_held_too():
    arm = WallArm(dof=3, force_limit={"force_n": 15.0})
    with lifecycle(arm):
        start = run(arm, 1)[0]["eef_pose"].copy()
        target = start.copy()
        target[2] = -0.2
        arm.command_eef(target, clock.now())  # at once: the tool goes at max_tool_step_m (5 cm) per cycle
        samples = run(arm, 60)
    assert samples[-1]["force_holds"] == 1
    assert min(s["eef_pose"][2] for s in samples) >= WALL_Z - 0.015 - 0.05 - 1e-9  # one tool step past


def test_config_needs_a_limit_and_a_wrench_source():
    with pytest.raises(ValidationError, match="set force_n, torque_nm or both"):
        WallArm(force_limit={})
    with pytest.raises(ValueError, match="FakeArm has no wrench source"):
        FakeArm(force_limit={"force_n": 10.0})
