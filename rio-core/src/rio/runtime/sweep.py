"""Remove what dead runs left behind: run directories and shared-memory segments of a `ServerManager`
that was SIGKILLed (or lost power, or was killed by the OOM killer) before it could clean up.

Everything a run makes is named by its run id (8 hex digits): its run directory `rio-<run id>-*`
(sockets, FIFOs, the `station.json` manifest), its segments `rio_<run id>_<8 hex>_d` / `_r`, and its
liveness marker `rio_<run id>_p<pid>[_n<pid namespace>]`, an empty shared-memory object beside the
segments that names the manager's process. A run is *live* while a pid recorded for it (the marker's,
the manifest's) is alive, or while its run directory has no manifest yet and is younger than
`GRACE_S`; it is *dead* when every pid recorded for it is dead; with no record at all it is
*unknown*, and its segments are swept only once older than `GRACE_S`. Only live runs are spared;
a pid recorded in another pid namespace (a container sharing /dev/shm) always counts as live.

The race with a manager starting at the same moment: a `ServerManager` creates its marker, then its
run directory, then writes the manifest, and only then creates segments; it removes them in the
reverse order. A sweep lists the segments first and only then looks for the records of their runs,
so any segment it saw was created after its run's marker and manifest were in place, and a listing
begun after that finds them: a live run's segment is never taken for a dead one. A starting run's
directory is spared by the grace period until its manifest appears.
"""

from __future__ import annotations

import json
import logging
import os
import re
import shutil
import tempfile
import time
from dataclasses import dataclass, field

from rio.machine import host

log = logging.getLogger("rio.runtime.sweep")

#: How long a run directory without a manifest, or a segment no run claims, is assumed to be starting.
GRACE_S = 60.0
#: The manifest in a run directory (re-exported by `rio.runtime.manager` as MANIFEST).
MANIFEST = "station.json"

_RUN_DIR = re.compile(r"^rio-([0-9a-f]{8})-")
_SEGMENT = re.compile(r"^rio_([0-9a-f]{8})_[0-9a-f]{8}_[dr]$")
_MARKER = re.compile(r"^rio_([0-9a-f]{8})_p(\d+)(?:_n(\d+))?$")


@dataclass
class Swept:
    """What one sweep removed."""

    #: Run ids whose leftovers were removed.
    runs: set[str] = field(default_factory=set)
    #: Run directories removed (paths).
    dirs: list[str] = field(default_factory=list)
    #: Shared-memory segments removed (names; liveness markers not listed).
    segments: list[str] = field(default_factory=list)
    #: Bytes of shared memory freed.
    nbytes: int = 0

    def __bool__(self) -> bool:
        return bool(self.runs)

    def summary(self) -> str:
        return (f"swept the leftovers of {len(self.runs)} dead run(s): {len(self.segments)} shared-memory "
                f"segment(s), {self.nbytes / 1e6:.1f} MB, {len(self.dirs)} run directory(ies)")


# -- the liveness marker ------------------------------------------------------------------------------
def marker_name(run_id: str, pid: int | None = None) -> str:
    pid = os.getpid() if pid is None else pid
    ns = host.pid_namespace()
    return f"rio_{run_id}_p{pid}" + (f"_n{ns}" if ns else "")


def mark_run(run_id: str) -> str | None:
    """Create this process's liveness marker for `run_id`, before anything else of the run exists;
    None where there is no shared memory (nothing there to sweep, then)."""
    if not host.has_shared_memory():
        return None
    name = marker_name(run_id)
    os.close(host.shm_create(name, 8))
    return name


def unmark_run(name: str | None) -> None:
    """Remove a marker made by `mark_run`: the last thing a run removes."""
    if name:
        host.shm_unlink(name)


# -- what is alive ------------------------------------------------------------------------------------
def _bases() -> list[str]:
    """Where run directories may be: `host.run_dir_base()`, and the temp directory and /tmp it chooses
    between (a process with a deep TMPDIR puts them in /tmp)."""
    out: list[str] = []
    for base in (host.run_dir_base(), tempfile.gettempdir(), "/tmp"):
        if os.path.isdir(base) and os.path.realpath(base) not in {os.path.realpath(b) for b in out}:
            out.append(base)
    return out


def _pid_says_alive(pid: int, ns: str | None) -> bool:
    """Is the run recorded with this pid alive? A pid of another pid namespace cannot be checked from
    here: assume it is."""
    if ns and ns != host.pid_namespace():
        return True
    return host.pid_alive(pid)


def _manifest_pid(path: str) -> tuple[int, str | None] | None:
    """The pid (and pid namespace) a run directory's manifest records; None if it has none (yet)."""
    try:
        with open(os.path.join(path, MANIFEST)) as f:
            m = json.load(f)
        return int(m["pid"]), (str(m["pidns"]) if m.get("pidns") else None)
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _own(st: os.stat_result | None) -> bool:
    return st is not None and (not hasattr(os, "getuid") or st.st_uid == os.getuid())


class _Runs:
    """Which run ids are live, and which are known dead, from the markers and the run directories. Built
    *after* the segments to judge were listed (see the module docstring)."""

    def __init__(self, bases: list[str], grace_s: float, now: float):
        self.live: set[str] = set()
        self.recorded: set[str] = set()
        self.dirs: list[tuple[str, str]] = []  # (run id, path) of this user's run directories
        for name in host.shm_list("rio_"):
            m = _MARKER.match(name)
            if m:
                self._record(m.group(1), _pid_says_alive(int(m.group(2)), m.group(3)))
        for base in bases:
            try:
                entries = os.listdir(base)
            except OSError:
                continue
            for entry in entries:
                m = _RUN_DIR.match(entry)
                path = os.path.join(base, entry)
                if not m or os.path.islink(path) or not os.path.isdir(path):
                    continue
                try:
                    st = os.stat(path)
                except OSError:
                    continue  # removed meanwhile
                run_id = m.group(1)
                if not _own(st):
                    self.live.add(run_id)  # another user's: not ours to judge (nor to remove)
                    continue
                self.dirs.append((run_id, path))
                rec = _manifest_pid(path)
                if rec is not None:
                    self._record(run_id, _pid_says_alive(*rec))
                elif now - st.st_mtime < grace_s:
                    self.live.add(run_id)  # starting: its manifest is not written yet

    def _record(self, run_id: str, alive: bool) -> None:
        self.recorded.add(run_id)
        if alive:
            self.live.add(run_id)

    def dead(self, run_id: str) -> bool:
        return run_id in self.recorded and run_id not in self.live


# -- the sweep ----------------------------------------------------------------------------------------
def _segments(names: set[str]) -> dict[str, list[str]]:
    """Segment and marker names by run id (other objects in /dev/shm are not RIO runs')."""
    out: dict[str, list[str]] = {}
    for name in sorted(names):
        m = _SEGMENT.match(name) or _MARKER.match(name)
        if m:
            out.setdefault(m.group(1), []).append(name)
    return out


def _unlink(name: str) -> bool:
    try:
        return host.shm_unlink(name)
    except OSError:  # another user's object, or /dev/shm gone
        return False


def sweep_dead_runs(grace_s: float = GRACE_S, bases: list[str] | None = None) -> Swept:
    """Remove the run directories and shared-memory segments of this user's dead runs (see the module
    docstring for what counts as dead), and return what was removed. Never touches a live run's.
    `ServerManager` calls this when it starts; call it yourself after a crash to free the memory at once.
    `bases`: where to look for run directories (default: wherever this or another RIO process puts them)."""
    swept, now = Swept(), time.time()
    by_run = _segments(host.shm_list("rio_"))  # first: see the module docstring
    runs = _Runs(_bases() if bases is None else bases, grace_s, now)
    for run_id, names in by_run.items():
        if run_id in runs.live:
            continue
        for name in names:
            st = host.shm_stat(name)
            if not _own(st):
                continue
            assert st is not None  # _own says so
            if not runs.dead(run_id) and now - st.st_mtime < grace_s:
                continue  # no record of its run at all: perhaps an older RIO's, starting elsewhere
            size = host.shm_size(name)
            if _unlink(name):
                swept.runs.add(run_id)
                if not _MARKER.match(name):  # a marker holds 8 bytes: not worth reporting
                    swept.segments.append(name)
                    swept.nbytes += size
    for run_id, path in runs.dirs:
        if run_id not in runs.live:
            shutil.rmtree(path, ignore_errors=True)
            if not os.path.exists(path):
                swept.dirs.append(path)
                swept.runs.add(run_id)
    return swept


__all__ = ["GRACE_S", "Swept", "sweep_dead_runs", "mark_run", "unmark_run", "marker_name"]
