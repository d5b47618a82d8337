"""What a run leaves behind on this machine: child processes and /dev/shm entries.

Plain functions over /proc and /dev/shm (standard library only), used by the conformance kits to
check that stopping, crashing or failing to start leaves nothing behind, and usable the same way in
a plugin's own tests: snapshot before, compare after.
"""

from __future__ import annotations

import os
from typing import Any

from rio.machine import host


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
    """Names of POSIX shared-memory objects (/dev/shm on Linux; RIO's marker registry on macOS and
    under RIO_HOST_FALLBACK: see `rio.machine.host`)."""
    return host.shm_list()


def assert_no_shm_left(mgr: Any, before: set[str]) -> None:
    """No new /dev/shm entry of `mgr` (a ServerManager) remains. Entries are attributed by the
    manager's run id, because other programs on the machine may create and remove their own
    segments meanwhile."""
    ours = {e for e in shm_entries() - before if mgr.run_id in e}
    assert not ours, f"/dev/shm entries left behind: {ours}"


__all__ = ["child_pids", "shm_entries", "assert_no_shm_left"]
