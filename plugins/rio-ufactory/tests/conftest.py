"""Fixtures for the xArm controller emulator: emulators on fresh loopback addresses (each needs the
controller's own ports, 502 and 30001-30003), and SDK connections to them, always disconnected and
stopped after the test."""

from __future__ import annotations

import pytest
from rio_ufactory.loopback import PORT_502_HINT, can_listen_on_502, free_loopback


@pytest.fixture
def make_emulator():
    """make_emulator(model="xarm7", **options) -> a started XArmEmulator on a fresh address."""
    from rio_ufactory.emulator import XArmEmulator

    emus = []

    if not can_listen_on_502():
        pytest.skip(PORT_502_HINT)

    def make(model: str = "xarm7", **options):
        emu = XArmEmulator(model, host=free_loopback(), **options)
        emus.append(emu)
        return emu.start()

    yield make
    for emu in emus:
        emu.stop()


@pytest.fixture
def emulator(make_emulator):
    """A started xArm 7 emulator with the xArm Gripper."""
    return make_emulator()


@pytest.fixture
def connect(make_emulator):
    """connect(emu, **kwargs) -> XArmAPI connected to it (radians, real-time report unless told)."""
    from xarm.wrapper import XArmAPI

    arms = []

    def conn(emu, **kwargs):
        kwargs.setdefault("is_radian", True)
        kwargs.setdefault("report_type", "real")
        arm = XArmAPI(emu.host, **kwargs)
        arms.append(arm)
        return arm

    yield conn
    for arm in arms:
        arm.disconnect()
