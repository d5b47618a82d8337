"""Fake control boxes (`rio_franka.fake`) on fresh addresses, forgotten after each test."""

from __future__ import annotations

import itertools

import pytest

_N = itertools.count(1)


@pytest.fixture
def fake_ip():
    """A fresh IP whose fake control box is dropped after the test."""
    from rio_franka import fake

    ip = f"10.77.0.{next(_N)}"
    yield ip
    fake.forget(ip)


def pytest_collection_modifyitems(config, items):
    """franky-control ships wheels for Linux x86-64 only (a Jetson or a Mac has none, and the plugin
    does not require it there): its tests skip, saying so, instead of failing on the import."""
    import importlib.util

    if importlib.util.find_spec("franky") is not None:
        return
    skip = pytest.mark.skip(reason="franky-control is not installed (wheels for Linux x86-64 only)")
    for item in items:
        if "rio-franka" in str(item.path):
            item.add_marker(skip)
