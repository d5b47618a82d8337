"""Fixtures: UR controller emulators, each in a process of its own on a fresh loopback address
(ur-rtde's blocking calls hold Python's GIL, so an in-process emulator could not answer them).

Starting a process costs about a second on a loaded machine, so a test module shares one emulator,
reset to a freshly booted controller at home (`inject reset`) before each test; a test that needs
its own (another model, the URCap socket) asks `make_emulator`."""

from __future__ import annotations

import pytest


@pytest.fixture
def make_emulator():
    """make_emulator(model="ur5e") -> a ready `EmulatorProcess`; stopped after the test."""
    from rio_ur.emulator.process import EmulatorProcess

    emus = []

    def make(model: str = "ur5e", **options):
        emu = EmulatorProcess(model, **options)
        emus.append(emu)
        return emu.wait_ready()

    yield make
    for emu in emus:
        emu.stop()


@pytest.fixture(scope="module")
def shared_emulator():
    from rio_ur.emulator.process import EmulatorProcess

    with EmulatorProcess("ur5e") as emu:
        yield emu


@pytest.fixture
def emulator(shared_emulator):
    """The module's UR5e emulator, reset: safety normal, running, at home, slider 100 %, no program."""
    shared_emulator.inject("reset")
    return shared_emulator


def pytest_collection_modifyitems(config, items):
    from rio.testing import skip_tests_without

    skip_tests_without("rtde_control", "ur-rtde ships wheels for Linux x86-64 and Windows only; elsewhere "
                       "`pip install ur-rtde` builds it (CMake, Boost)", items, "rio-ur")
