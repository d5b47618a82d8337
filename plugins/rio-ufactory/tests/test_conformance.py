"""Every rio-ufactory driver passes the conformance kit of its kind, through the unmodified xArm SDK
against the controller emulator (the emulator hook starts one on a fresh loopback address)."""

from __future__ import annotations

from contextlib import contextmanager

import pytest
from rio_ufactory.emulator import XArmEmulator
from rio_ufactory.loopback import PORT_502_HINT, can_listen_on_502, free_loopback

from rio.conformance.drivers import ArmConformance, GripperConformance


class OnEmulator:
    model = "xarm7"
    tool: str | None = "xarm"
    bad_config = {"ip": "127.0.0.1", "connect_timeout_s": 0.0}  # emulators never listen on .1

    @contextmanager
    def emulator(self):
        if not can_listen_on_502():
            pytest.skip(PORT_502_HINT)
        with XArmEmulator(self.model, host=free_loopback(), gripper=self.tool) as emu:
            yield emu.driver_fields


class TestXArm5(OnEmulator, ArmConformance):
    driver = "ufactory.xarm5"
    model = "xarm5"


class TestXArm6(OnEmulator, ArmConformance):
    driver = "ufactory.xarm6"
    model = "xarm6"


class TestXArm7(OnEmulator, ArmConformance):
    driver = "ufactory.xarm7"


class TestXArm850(OnEmulator, ArmConformance):
    driver = "ufactory.xarm850"
    model = "xarm850"


class TestLite6(OnEmulator, ArmConformance):
    driver = "ufactory.lite6"
    model, tool = "lite6", "lite6"


class TestXArmGripper(OnEmulator, GripperConformance):
    driver = "ufactory.gripper"


class TestXArmGripperG2(OnEmulator, GripperConformance):
    driver = "ufactory.gripper_g2"
    tool = "xarm_g2"


class TestBioGripper(OnEmulator, GripperConformance):
    driver = "ufactory.bio_gripper"
    tool = "bio"


class TestRobotiqOnTheTool(OnEmulator, GripperConformance):
    driver = "ufactory.robotiq"
    tool = "robotiq"


class TestLite6Gripper(OnEmulator, GripperConformance):
    driver = "ufactory.lite6_gripper"
    model, tool = "lite6", "lite6"


class TestVacuum(OnEmulator, GripperConformance):
    driver = "ufactory.vacuum"
    model, tool = "lite6", "lite6"
