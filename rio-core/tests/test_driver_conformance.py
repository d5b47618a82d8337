"""Every driver that rio-core ships runs the driver conformance kit of its kind: the fakes behind
`rio.fake_*` and the teleop devices that need no hardware (`teleop.scripted`, and `teleop.keyboard`
on a pseudo-terminal)."""

from __future__ import annotations

import os
from contextlib import contextmanager

from rio.conformance.drivers import (
    ArmConformance,
    CameraConformance,
    GripperConformance,
    HandConformance,
    HumanoidConformance,
    SensorConformance,
    TeleopConformance,
    WrenchConformance,
)

#: The joint ranges of rio.fakes.arms.SIX_DOF_MJCF, as a station would narrow the fake model arm to them.
MODEL_ARM_LIMITS = [(-3.0, 3.0), (-2.0, 2.0), (-2.5, 2.5), (-3.0, 3.0), (-2.0, 2.0), (-3.0, 3.0)]


class TestFakeArm(ArmConformance):
    driver = "rio.fake_arm"
    config = {"dof": 3, "joint_limits": [(-1.5, 1.5), (-1.0, 2.0), (-2.0, 0.5)]}


class TestFakeModelArm(ArmConformance):
    driver = "rio.fake_model_arm"
    config = {"joint_limits": MODEL_ARM_LIMITS}


class TestFakeGripper(GripperConformance):
    driver = "rio.fake_gripper"


class TestFakeCamera(CameraConformance):
    driver = "rio.fake_camera"
    config = {"depth": True, "width": 32, "height": 24}


class TestFakeTeleop(TeleopConformance):
    driver = "rio.fake_teleop"
    config = {"twist": [0.1, 0.0, 0.0, 0.0, 0.0, 0.2], "gripper": 0.5}


class TestFakeHand(HandConformance):
    driver = "rio.fake_hand"
    config = {"dof": 4, "joint_limits": [(0.0, 1.5)] * 4}


class TestFakeHumanoid(HumanoidConformance):
    driver = "rio.fake_humanoid"
    config = {"dof": 6, "joint_limits": [(-1.0, 1.0)] * 6}


class TestFakeSensor(SensorConformance):
    driver = "rio.fake_sensor"


class TestFakeWrench(WrenchConformance):
    driver = "rio.fake_wrench"
    config = {"load": [1.0, -2.0, -9.8, 0.1, 0.0, -0.05], "noise": 0.02}


class TestScriptedTeleop(TeleopConformance):
    driver = "teleop.scripted"


class TestKeyboardTeleop(TeleopConformance):
    """The keyboard reads a terminal: a pseudo-terminal stands in for it."""

    driver = "teleop.keyboard"
    bad_config = {"tty": "/dev/nonexistent-tty"}

    @contextmanager
    def emulator(self):
        master, slave = os.openpty()
        try:
            os.write(master, b"wd ")  # a few key presses waiting in the terminal
            yield {"tty": os.ttyname(slave)}
        finally:
            os.close(slave)
            os.close(master)
