"""Fixtures for the G1 over real DDS on loopback: each test gets a DDS domain no one else on this machine
uses (a second test run beside this one never hears our robots), and every bridge, driver and tap it
starts is closed when it ends."""

from __future__ import annotations

import pytest

from rio.testing import no_new_threads, started

pytest.importorskip("cyclonedds")
pytest.importorskip("unitree_sdk2py")


@pytest.fixture
def domain_id() -> int:
    from rio_unitree.testing import free_domain_id

    return free_domain_id()


@pytest.fixture
def make_bridge(domain_id):
    """make_bridge(**options) -> a started Bridge on "lo" in this test's domain (the plugin's own model
    unless `model` says otherwise), stopped after the test."""
    pytest.importorskip("mujoco")
    from rio_unitree.bridge import Bridge

    def bridge(model="fallback", **options):
        return Bridge(domain_id=domain_id, interface="lo", model=model, **options)

    with started(bridge) as make:
        yield make


@pytest.fixture(autouse=True)
def no_threads_left():
    """Nothing a test started keeps running after it (bridges, DDS listeners)."""
    with no_new_threads():
        yield
