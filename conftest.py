"""How the test suite splits over pytest-xdist workers (`-n 2` in pyproject's addopts): which tests must
run on one worker, one after another.

A plugin's tests stay together: its station files name fixed emulator addresses (the UR and xArm
emulators both listen on 127.0.0.2, on overlapping ports 30001-30003, so rio-ur and rio-ufactory are
one unit) and its module fixtures (a recorded episode) are made once. Elsewhere a test file is the
unit. Everything else a test starts is already private to its process: shared memory and run
directories carry a run id, rio-sim worlds a session id, emulators pick a free loopback address, DDS
tests a free domain.

(xdist's own `--dist loadgroup` markers do nothing under pytest 9.2, whose node ids xdist can no longer
suffix, so the units are made here, by a scheduler that splits on them.)
"""

from __future__ import annotations

from typing import Any

#: Plugins whose emulators share fixed addresses: one unit.
_SAME_UNIT = {"rio-ur": "plugins/127.0.0.2", "rio-ufactory": "plugins/127.0.0.2"}


def unit_of(nodeid: str) -> str:
    """The unit of work a test belongs to: its plugin, or its file."""
    path = nodeid.split("::", 1)[0]
    parts = path.split("/")
    if len(parts) > 2 and parts[0] == "plugins":
        return _SAME_UNIT.get(parts[1], f"plugins/{parts[1]}")
    return path


def pytest_xdist_make_scheduler(config: Any, log: Any) -> Any:
    from xdist.scheduler import LoadScopeScheduling

    class ByUnit(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return unit_of(nodeid)

    return ByUnit(config, log)
