"""Fixtures for the G1 over real DDS on loopback: each test gets a DDS domain no one else on this machine
uses (a second test run beside this one never hears our robots), and every bridge, driver and tap it
starts is closed when it ends."""

from __future__ import annotations

import threading

import pytest

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

    bridges = []

    def make(**options):
        options.setdefault("model", "fallback")
        bridge = Bridge(domain_id=domain_id, interface="lo", **options)
        bridges.append(bridge)
        return bridge.start()

    yield make
    for b in bridges:
        b.stop()


@pytest.fixture(autouse=True)
def no_threads_left():
    """Nothing a test started keeps running after it (bridges, DDS listeners)."""
    before = set(threading.enumerate())
    yield
    left = [t for t in threading.enumerate() if t not in before and t.is_alive()]
    assert not left, f"threads left running: {left}"
