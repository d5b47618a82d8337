"""The SO-100 drivers pass the driver conformance kit of their kind, each against an emulated Feetech
bus on a pseudo-terminal (the emulator hook), calibrated as `rio so100 calibrate` would leave it."""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager

from rio_so100.calibration import default_calibration, save_calibration
from rio_so100.emulator import FeetechBusEmulator

from rio.conformance.drivers import ArmConformance, GripperConformance, TeleopConformance


class OnBusEmulator:
    """Emulator hook: six emulated servos on a pty, and a saved default calibration of this device in a
    private config directory (the user's calibrations are never read or written)."""

    device = "follower"
    bad_config = {"port": "/dev/nonexistent-tty"}

    @contextmanager
    def emulator(self):
        saved = os.environ.get("XDG_CONFIG_HOME")
        with tempfile.TemporaryDirectory(prefix="rio-kit-config-") as config_home:
            os.environ["XDG_CONFIG_HOME"] = config_home
            try:
                save_calibration(default_calibration("so100", self.device, "default"))
                with FeetechBusEmulator() as bus:
                    yield {"port": bus.port}
            finally:
                if saved is None:
                    os.environ.pop("XDG_CONFIG_HOME", None)
                else:
                    os.environ["XDG_CONFIG_HOME"] = saved


class TestSo100Follower(OnBusEmulator, ArmConformance):
    driver = "so100.follower"


class TestSo100Gripper(OnBusEmulator, GripperConformance):
    driver = "so100.gripper"


class TestSo100Leader(OnBusEmulator, TeleopConformance):
    driver = "so100.leader"
    device = "leader"
