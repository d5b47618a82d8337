"""Shared helpers: software cameras with unique serials (the simulated USB bus is per serial, so tests
never unplug each other's cameras), and `collect` (a fixture): read a node the way the runtime does until enough
frames came out.

Everything waits on outcomes with generous timeouts and never times anything: the suite must hold on
a loaded 2-core machine."""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable
from typing import Any

import pytest

_serials = itertools.count(1)


@pytest.fixture
def serial() -> str:
    """A serial number no other test uses."""
    return f"test-{next(_serials):04d}"


def _collect(node: Any, frames: int, timeout: float = 20.0,
            until: Callable[[dict[str, Any]], bool] | None = None) -> list[dict[str, Any]]:
    """Call `read_state()` at the node's rate until `frames` samples came out (or `until(sample)` held),
    returning them; fails after `timeout` seconds."""
    out: list[dict[str, Any]] = []
    t_end = time.monotonic() + timeout
    while time.monotonic() < t_end:
        s = node.read_state()
        if s is not None:
            out.append(dict(s))
            if until is not None and until(s):
                return out
            if until is None and len(out) >= frames:
                return out
        time.sleep(1.0 / node.rate_hz)
    raise AssertionError(f"{len(out)} samples within {timeout} s (wanted {frames if until is None else 'until'})")


@pytest.fixture
def collect() -> Callable[..., list[dict[str, Any]]]:
    """`collect(node, frames, timeout=20.0, until=None)`: see `_collect`."""
    return _collect
