"""The UR driver passes the arm conformance kit: the real ur-rtde (RTDE receive) against the emulator,
with the control path faked (`control = "emulator"`: ur-rtde's control script cannot be emulated, see
rio_ur.control). One emulator process serves the whole class, reset to a freshly booted controller
at home before each case (a process per case would double the run time)."""

from __future__ import annotations

from contextlib import contextmanager

import pytest
from rio_ur.emulator.process import EmulatorProcess

from rio.conformance.drivers import ArmConformance


@pytest.fixture(scope="class")
def one_emulator_per_class(request):
    with EmulatorProcess("ur5e") as emu:
        request.cls._emu = emu
        yield
    request.cls._emu = None


@pytest.mark.usefixtures("one_emulator_per_class")
class TestUR5e(ArmConformance):
    driver = "ur.ur5e"
    bad_config = {"ip": "127.0.0.1", "connect_timeout_s": 0.0}  # emulators never listen on .1
    _emu: EmulatorProcess | None = None

    @contextmanager
    def emulator(self):
        assert self._emu is not None
        self._emu.inject("reset")
        yield self._emu.driver_fields
