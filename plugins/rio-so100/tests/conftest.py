"""Shared fixtures: every test gets its own config directory (calibrations never touch the user's),
and emulated buses that are always closed."""

from __future__ import annotations

import pytest
from rio_so100.calibration import default_calibration, save_calibration
from rio_so100.emulator import FeetechBusEmulator


@pytest.fixture(autouse=True)
def config_home(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "config"))
    return tmp_path / "config"


@pytest.fixture
def vbus():
    """Six emulated servos (ids 1-6) on a pty, all at mid-turn."""
    with FeetechBusEmulator() as bus:
        yield bus


@pytest.fixture
def make_vbus():
    buses = []

    def make(**kwargs):
        buses.append(FeetechBusEmulator(**kwargs))
        return buses[-1]

    yield make
    for b in buses:
        b.close()


@pytest.fixture
def calibrated():
    """Save the default calibration of an arm under a name, as `rio so100 calibrate` would."""
    def save(name: str = "default", device: str = "follower", model: str = "so100"):
        return save_calibration(default_calibration(model, device, name))
    return save
