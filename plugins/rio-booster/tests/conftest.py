"""Fixtures for the T1 driver against the emulated T1 (`rio_booster.emulator`, an SDK-object fake: see its
docstring for why it is not a second DDS participant). Each test gets its own emulator domain, and every
emulated robot it starts is stopped when it ends."""

from __future__ import annotations

import itertools
import threading

import pytest

_domains = itertools.cycle(range(100, 150))


@pytest.fixture
def domain_id() -> int:
    return next(_domains)


@pytest.fixture
def make_robot(domain_id):
    """make_robot(**options) -> a started EmulatedT1 on this test's domain, stopped after the test."""
    from rio_booster.emulator import EmulatedT1

    robots = []

    def make(**options):
        robot = EmulatedT1(domain_id=domain_id, **options)
        robots.append(robot)
        return robot.start()

    yield make
    for r in robots:
        r.stop()


@pytest.fixture(autouse=True)
def no_threads_left():
    """Nothing a test started keeps running after it (emulated robots)."""
    before = set(threading.enumerate())
    yield
    left = [t for t in threading.enumerate() if t not in before and t.is_alive()]
    assert not left, f"threads left running: {left}"
