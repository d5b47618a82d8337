"""The GELLO leader passes the teleop driver conformance kit against an emulated GELLO on a pty (the
emulator hook), calibrated as `rio gello calibrate` would leave it."""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from dataclasses import replace

from rio_teleop.gello.calibration import save_calibration
from rio_teleop.gello.emulator import GelloEmulator

from rio.conformance.drivers import TeleopConformance


class OnGelloEmulator:
    layout = "xarm7"
    bad_config = {"port": "/dev/nonexistent-tty"}

    @contextmanager
    def emulator(self):
        saved = os.environ.get("XDG_CONFIG_HOME")
        with tempfile.TemporaryDirectory(prefix="rio-kit-config-") as config_home:
            os.environ["XDG_CONFIG_HOME"] = config_home
            try:
                with GelloEmulator(self.layout) as g:
                    g.wave()
                    save_calibration(replace(g.mounting, name="default"))
                    yield {"port": g.port}
            finally:
                if saved is None:
                    os.environ.pop("XDG_CONFIG_HOME", None)
                else:
                    os.environ["XDG_CONFIG_HOME"] = saved


class TestGelloXarm7(OnGelloEmulator, TeleopConformance):
    driver = "rio_teleop.gello.driver:GelloLeader"
    config = {"layout": "xarm7"}


class TestGelloUr5e(OnGelloEmulator, TeleopConformance):
    driver = "rio_teleop.gello.driver:GelloLeader"
    config = {"layout": "ur5e"}
    layout = "ur5e"
