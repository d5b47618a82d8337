"""The suite's own rules, for every `uv run pytest` from the repository's root.

Hardware tests (marker `hardware`) are deselected unless `-m` names them (`-m hardware`): a `-m` given on the
command line replaces pyproject's, so a `-m 'not hardware'` there would be lost from `-m "not slow"`.

How the suite is split over pytest-xdist workers (`-n auto` in pyproject's addopts: two per core, see
`pytest_xdist_auto_num_workers`; `-n 0` runs it in one process): which tests must run on one worker, one after
another.

The unit of work is a test file: its module- and class-scoped fixtures (an emulator, a recorded episode)
are made once, on one worker. Files that use one fixed machine resource are one unit together
(`SHARED_RESOURCE`). Everything else a test starts is private to its worker already: shared memory and run
directories carry a run id, rio-sim worlds a session id per process tree, emulators draw loopback addresses
and the G1 tests DDS domains from their worker's own share (`rio.machine.parallel`), ports are chosen by the
system (port 0), and `rio new plugin`'s tests install what they generate into an environment of their own.

xdist's own grouping (`--dist loadgroup` with `xdist_group` marks) would say this on the tests, but under
pytest 9.2 it silently does nothing: xdist names a group by rewriting each test's node id (`item._nodeid`),
which pytest 9.2 no longer reads (pytest-dev/pytest-xdist#1386). The scheduler below sees only node ids,
so the shared resources are named here, by file.

Units are handed out in the order the workers collected them, and a worker collects the units holding the
most `slow` tests first, then those with the most tests: a unit of several minutes started last would leave
the other workers idle (seen: the xArm conformance file, 126 tests and 2.5 minutes of waiting on the SDK,
none slow, handed out last and ending the run 80 s after the other workers).
"""

from __future__ import annotations

from collections import Counter
from typing import Any

import pytest

#: the main thread's scheduling policy and priority when the session started
_SCHEDULING = pytest.StashKey[tuple[int, int]]()
#: the handlers of SIGINT and SIGTERM when the session started
_SIGNALS = pytest.StashKey[dict[int, Any]]()

#: Files whose tests use one fixed machine resource, by resource: each group runs on one worker.
SHARED_RESOURCE = {
    # the packaged UR and xArm stations serve their emulators on 127.0.0.2 (both on ports 30001-30003)
    "plugins/rio-ur/tests/test_station.py": "127.0.0.2",
    "plugins/rio-ufactory/tests/test_station.py": "127.0.0.2",
}


def pytest_collection_modifyitems(config: Any, items: list[Any]) -> None:
    if "hardware" not in (config.option.markexpr or ""):  # else -m decides
        hardware = [item for item in items if item.get_closest_marker("hardware") is not None]
        if hardware:
            config.hook.pytest_deselected(items=hardware)
            items[:] = [item for item in items if item.get_closest_marker("hardware") is None]
    if hasattr(config, "workerinput"):  # an xdist worker: the units with the most slow tests first, then the largest
        slow = Counter(unit_of(item.nodeid) for item in items if item.get_closest_marker("slow") is not None)
        size = Counter(unit_of(item.nodeid) for item in items)
        # stable: a unit's tests keep their order
        items.sort(key=lambda item: (-slow[unit_of(item.nodeid)], -size[unit_of(item.nodeid)]))


def pytest_sessionstart(session: Any) -> None:
    import os
    import signal

    session.config.stash[_SCHEDULING] = (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority)
    session.config.stash[_SIGNALS] = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}


@pytest.hookimpl(trylast=True)  # after the test's fixtures are torn down: one may undo what it set
def pytest_runtest_teardown(item: Any) -> None:
    """A test that leaves the test process's main thread on another scheduling policy (SCHED_FIFO) fails here,
    naming itself, and the policy is put back: every thread the process starts later inherits it, and a
    real-time thread that busy-waits on a normal one starves the whole machine (seen in a full xdist run: both
    workers' main threads at SCHED_FIFO 99 after an AV1 recording test (SVT-AV1 as root; rio.recording.video now
    keeps its caller's scheduling), their realsense tests spinning for 45 min at a load of 60). The same for the
    handlers of SIGINT and SIGTERM: an ignored one is inherited by every subprocess the worker starts later, whose
    Ctrl-C (a test's SIGINT) is then lost."""
    import os
    import signal

    if _SCHEDULING not in item.config.stash:  # a nested pytest session (a kit's) that did not start here
        return
    signals = item.config.stash.get(_SIGNALS, {})
    changed = {signal.Signals(sig).name: signal.getsignal(sig) for sig, handler in signals.items()
               if signal.getsignal(sig) != handler}
    for sig, handler in signals.items():
        signal.signal(sig, handler)
    if changed:
        raise AssertionError(f"{item.nodeid} left the test process's signal handlers changed: {changed}; put back")
    policy, priority = item.config.stash[_SCHEDULING]
    now = (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority)
    if now != (policy, priority):
        os.sched_setscheduler(0, policy, os.sched_param(priority))
        raise AssertionError(f"{item.nodeid} left the test process's main thread at scheduling policy {now[0]}, "
                             f"priority {now[1]} (was {policy}, {priority}); put back")


def unit_of(nodeid: str) -> str:
    """The unit of work a test belongs to: its file, or the resource its file shares with others."""
    path = nodeid.split("::", 1)[0]
    return SHARED_RESOURCE.get(path, path)


def pytest_xdist_auto_num_workers(config: Any) -> int:
    """`-n auto`: two workers per core (at most 8). Most of the suite's time is spent waiting, not computing:
    a station runs its seconds in real time, a subprocess starts, an emulator answers. Measured per test on
    this 2-core machine, the CPU a test used (its process and the processes it waited for) was about 40 % of
    its wall time, so one worker per core leaves the cores idle half the time. `PYTEST_XDIST_AUTO_NUM_WORKERS`
    (xdist's own setting) still decides when set; `-n N` as always."""
    import os

    setting = os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS")
    if setting:
        return int(setting)
    return min(2 * len(os.sched_getaffinity(0)), 8)


def pytest_xdist_make_scheduler(config: Any, log: Any) -> Any:
    from xdist.scheduler import LoadScopeScheduling

    missing = [path for path in SHARED_RESOURCE if not (config.rootpath / path).is_file()]
    if missing:
        raise pytest.UsageError(f"conftest.py's SHARED_RESOURCE names files that do not exist: {missing}")
    config.option.loadscopereorder = False  # keep the workers' order (slow units first), not the largest first

    class ByUnit(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return unit_of(nodeid)

    return ByUnit(config, log)
