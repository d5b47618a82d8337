"""Numbered machine-wide resources (loopback addresses, DDS domains) shared out between test processes that
run side by side: pytest-xdist's workers.

A helper that probes for a free resource (`rio.emulation.free_loopback`, `rio_unitree.testing.free_domain_id`)
sees only one that is in use already. Two workers probing at the same moment find the same free one, and the
second to bind it fails (or, for a DDS domain, hears the other's robot). Each worker draws from a share of
its own instead: xdist tells a worker its number in PYTEST_XDIST_WORKER ("gw0", "gw1", ...) and the number
of workers in PYTEST_XDIST_WORKER_COUNT, and the processes a test starts inherit both. Outside xdist the
share is the whole range. Another test run on the same machine is still told apart by probing.
"""

from __future__ import annotations

import os


def worker_share(lo: int, hi: int) -> range:
    """This process's part of `lo`..`hi` (inclusive): the whole range outside pytest-xdist, else the
    worker's own slice, disjoint from every other worker's (a range too small to split is not split)."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    try:
        index, count = int(worker.removeprefix("gw")), int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", ""))
    except ValueError:
        return range(lo, hi + 1)
    size = (hi - lo + 1) // count if count > 0 else 0
    if count < 2 or size < 1 or not 0 <= index < count:
        return range(lo, hi + 1)
    return range(lo + index * size, lo + (index + 1) * size)
