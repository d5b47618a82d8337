"""The world bus: checked state and command slots (a half-visible write is never accepted),
single-writer command slots, and life-cycle rules (a second live world of one name is refused; a
dead one's block is reclaimed)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from rio_sim.bus import WorldBus, block_name

from rio.errors import RioError
from rio.machine import host

# creates a world block and dies without closing it (SIGKILL), as a crashed world process would
_KILLED_WORLD = """
import os
from rio_sim.bus import WorldBus
bus = WorldBus.create("t-killed", "so100", 3, 2, 2)
bus.mark_ready()
print(os.getpid(), flush=True)
os.kill(os.getpid(), 9)
"""


def _exists(world: str) -> bool:
    return block_name(world) in host.shm_list()


def test_state_and_commands_round_trip_between_owner_and_attacher():
    w = WorldBus.create("t-roundtrip", "so100", 4, 3, 2)
    try:
        w.mark_ready()
        a = WorldBus.attach("t-roundtrip", timeout=2)
        assert a.scene == "so100" and (a.nq, a.nv, a.nu) == (4, 3, 2)
        w.write_state(1.5, [1, 2, 3, 4], [5, 6, 7], [8, 9])
        s = a.read_state()
        assert s["sim_time"] == 1.5 and s["qpos"].tolist() == [1, 2, 3, 4] and s["ctrl"].tolist() == [8, 9]
        a.command(np.array([1]), [0.7], 12.0)
        stamp, target, t = w.read_commands(np.zeros(2))
        assert stamp.tolist() == [0, 1] and target[1] == 0.7 and t[1] == 12.0
        a.close()
    finally:
        w.close()
    with pytest.raises(RioError, match="no sim world"):
        WorldBus.attach("t-roundtrip", timeout=0.1)


def test_a_second_live_world_is_refused_and_attachers_see_it_stop():
    w = WorldBus.create("t-dup", "so100", 1, 1, 1)
    w.mark_ready()
    a = WorldBus.attach("t-dup", timeout=2)
    try:
        with pytest.raises(RioError, match="already running"):
            WorldBus.create("t-dup", "so100", 1, 1, 1)
    finally:
        w.close()
    with pytest.raises(RioError, match="stopped"):
        a.check_alive()
    a.close()


def test_block_of_a_killed_world_is_reclaimed():
    run = subprocess.run([sys.executable, "-c", _KILLED_WORLD], capture_output=True, text=True, timeout=60)
    pid = int(run.stdout.split()[0])  # same RIO_SIM_SESSION: inherited from this process
    assert run.returncode == -9 and _exists("t-killed")
    w = WorldBus.create("t-killed", "xarm7", 2, 2, 2)  # no error: the dead owner's block is replaced
    assert int(w.hdr[2]) == os.getpid() != pid
    w.close()
    assert not _exists("t-killed")


def test_any_new_world_sweeps_blocks_of_dead_worlds():
    run = subprocess.run([sys.executable, "-c", _KILLED_WORLD], capture_output=True, text=True, timeout=60)
    assert run.returncode == -9 and _exists("t-killed")
    w = WorldBus.create("t-other-name", "so100", 1, 1, 1)
    assert not _exists("t-killed")
    w.close()


def test_a_write_not_yet_fully_visible_is_never_accepted():
    """What a reader on a CPU that reorders memory (ARM) can see: the counter or stamp of a write
    whose data has not arrived yet. Made here by changing the data under an unchanged check."""
    w = WorldBus.create("t-order", "so100", 2, 2, 2)
    try:
        w.mark_ready()
        a = WorldBus.attach("t-order", timeout=2)
        a.command(np.array([0, 1]), [0.5, 0.6], 3.0)
        seen = np.zeros(2)
        a.cmd_target[1] = 9.0  # actuator 1's new stamp is visible, its target is not the one checked
        stamp, target, _ = w.read_commands(seen)
        assert stamp.tolist() == [1, 0] and target[0] == 0.5  # actuator 1 waits for its next read
        a.command(np.array([1]), [0.7], 4.0)
        assert w.read_commands(seen)[0].tolist() == [1, 2]

        w.write_state(2.0, [1, 2], [3, 4], [5, 6])
        assert a.read_state()["qpos"].tolist() == [1, 2]
        w.qpos[0] = 7.0  # data changed under an even counter: the check no longer matches
        with pytest.raises(RioError, match="stayed locked"):
            a.read_state()
        a.close()
    finally:
        w.close()
