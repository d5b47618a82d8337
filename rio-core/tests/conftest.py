"""Shared fixtures for rio-core tests. The process helpers live in the shipped conformance kit
(`rio.conformance.process`) and are re-exported here for the test modules that import them."""

from __future__ import annotations

import pytest
from rio.conformance.process import _is_resource_tracker, child_pids, shm_entries

MIDDLEWARES = ["thread", "shm", "zmq", "zenoh", "portal"]

__all__ = ["MIDDLEWARES", "child_pids", "shm_entries", "_is_resource_tracker"]


@pytest.fixture(params=MIDDLEWARES)
def mw(request: pytest.FixtureRequest) -> str:
    return request.param
