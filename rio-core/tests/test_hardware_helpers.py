"""The motions every arm plugin's hardware test makes (`rio.testing.nudge_last_joint`, `cycle_gripper`),
run here on the fake arm and gripper so they are known to work before they meet a robot."""

from __future__ import annotations

import numpy as np

from rio.fakes.arms import FakeArm, FakeGripper
from rio.testing import cycle_gripper, lifecycle, nudge_last_joint


def test_nudge_turns_the_last_joint_and_back():
    with lifecycle(FakeArm(dof=6, max_step_rad=0.05)) as arm:
        q0 = arm.cycle()["joint_pos"].copy()
        nudge_last_joint(arm, rad=0.1, seconds=0.2)
        np.testing.assert_allclose(arm.cycle()["joint_pos"], q0, atol=0.01)


def test_cycle_gripper_reaches_each_opening():
    with lifecycle(FakeGripper()) as grip:
        w = grip.width
        cycle_gripper(grip, (w, 0.3 * w, w), tol=0.003, seconds=0.2)
        assert abs(grip.cycle()["width"] - w) < 0.003
