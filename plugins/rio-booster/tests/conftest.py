"""Fixtures for the T1 driver against the emulated T1 (`rio_booster.emulator`, an SDK-object fake: see its
docstring for why it is not a second DDS participant). Each test gets its own emulator domain, and every
emulated robot it starts is stopped when it ends."""

from __future__ import annotations

import itertools

import pytest

from rio.testing import no_new_threads, started

_domains = itertools.cycle(range(100, 150))


@pytest.fixture
def domain_id() -> int:
    return next(_domains)


@pytest.fixture
def make_robot(domain_id):
    """make_robot(**options) -> a started EmulatedT1 on this test's domain, stopped after the test."""
    from rio_booster.emulator import EmulatedT1

    with started(lambda **options: EmulatedT1(domain_id=domain_id, **options)) as make:
        yield make


@pytest.fixture(autouse=True)
def no_threads_left():
    """Nothing a test started keeps running after it (emulated robots)."""
    with no_new_threads():
        yield
