"""Shared fixtures for rio-core tests."""

from __future__ import annotations

import os

import pytest

MIDDLEWARES = ["thread", "shm", "zmq", "zenoh", "portal"]


def _is_resource_tracker(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return b"multiprocessing.resource_tracker" in f.read()
    except OSError:
        return False


def child_pids() -> set[int]:
    """Live (non-zombie) direct children of this process, read from /proc. Python's own
    multiprocessing resource tracker (one per program, started by the first spawn) is not a node."""
    me, out = os.getpid(), set()
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                stat = f.read()
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()
        if int(fields[1]) == me and fields[0] != "Z" and not _is_resource_tracker(int(entry)):
            out.add(int(entry))
    return out


def shm_entries() -> set[str]:
    return set(os.listdir("/dev/shm")) if os.path.isdir("/dev/shm") else set()


@pytest.fixture(params=MIDDLEWARES)
def mw(request: pytest.FixtureRequest) -> str:
    return request.param
