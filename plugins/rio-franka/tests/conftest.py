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
    from rio.testing import skip_tests_without

    skip_tests_without("franky", "franky-control ships wheels for Linux x86-64 only", items, "rio-franka")
