"""The world bus: how the nodes of one simulated station share one physics world.

One shared-memory block per world, created by the world node (the only process that steps physics)
and attached by the arm, gripper and camera nodes of the same station, whatever middleware runs
them (threads of one process or a process each):

- state, written by the world after every batch of physics steps: `qpos`, `qvel`, `ctrl`, `sensordata`
  (the scene's sensors: each arm's wrist force/torque, `rio_sim.scenes`), simulated time, under a sequence
  counter (odd while a write is in progress) and a checksum of the state
  seeded with the counter (`rio.runtime.slot_check`): a reader accepts its copy only when the checksum of
  the copy matches, which holds on CPUs that reorder memory (ARM) as on x86;
- commands, one slot per actuator: `target`, `t_target` (a `rio.clock.now()` time), a `stamp`
  bumped after both are written, and a check of (target, t_target) seeded with the stamp. Each
  actuator has exactly one writer (the node that owns it: an arm its joints, a gripper its fingers),
  so writers never contend; the world picks a slot up when its stamp changes and its check matches,
  and interpolates towards the target in physics time;
- servo gains, one slot per actuator, written the same way by the actuator's owner: `kp`, `kd` of a
  position servo (a humanoid's joint PD, configured on its node), applied by the world at once;
- the episode, in the header, written by the world when a task starts one (`rio_sim.task`): a counter,
  its start in simulated time and its time limit, so a node that plays the task (the scripted expert)
  knows how long it has.

The block's name joins the user id, a session id that `rio_sim` puts in the environment of the
process that builds the station (inherited by the node processes it spawns), and the world's name,
so two stations running at once on one machine never meet. A block left behind by a world that was
SIGKILLed (its owner pid is gone) is removed by the next world created on the machine, whatever its
name, so crashes do not accumulate in /dev/shm. Shared-memory calls go through `rio.machine.host` (macOS's
short names and missing listing included).
"""

from __future__ import annotations

import mmap
import os

import numpy as np

from rio import clock
from rio.errors import RioError
from rio.machine import host
from rio.runtime import slot_check

from .session import session_id

_MAGIC = 0x52494F53494D  # "RIOSIM"
_VERSION = 4
# int64 header fields (the state's check is a uint64)
_H_MAGIC, _H_VERSION, _H_PID, _H_READY, _H_CLOSED, _H_SEQ, _H_NQ, _H_NV, _H_NU, _H_CHECK = range(10)
# the episode: a counter (bumped last), then its start and time limit (float64 in int64 slots)
_H_EPISODE, _H_EPISODE_T0, _H_TIME_LIMIT = range(10, 13)
# the number of sensor values the state carries
_H_NS = 13
_NHDR = 16
_NAME_BYTES = 128
#: How long a reader waits for a write in progress before calling the writer dead (a preempted writer on
#: a loaded machine can hold the lock for tens of milliseconds).
_LOCKED_S = 1.0


def block_name(world: str) -> str:
    safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in world)[:40]
    return f"rio-sim-{os.getuid()}-{session_id()}-{safe}"


def _size(nq: int, nv: int, nu: int, ns: int = 0) -> int:
    return 8 * _NHDR + _NAME_BYTES + 8 * (2 + nq + nv + nu + ns + 8 * nu)


def _read_header(name: str) -> np.ndarray | None:
    try:
        fd = host.shm_open(name, readonly=True)
    except OSError:
        return None
    try:
        if os.fstat(fd).st_size < 8 * _NHDR:
            return None
        mm = mmap.mmap(fd, 8 * _NHDR, prot=mmap.PROT_READ)
        hdr = np.frombuffer(mm, dtype=np.int64, count=_NHDR).copy()
        del mm
        return hdr
    finally:
        os.close(fd)


def sweep_stale() -> int:
    """Unlink this user's world blocks whose world is gone (closed, or its process died)."""
    prefix, removed = f"rio-sim-{os.getuid()}-", 0
    for name in host.shm_list(prefix):
        hdr = _read_header(name)
        if hdr is None or hdr[_H_MAGIC] != _MAGIC:
            continue  # being created right now, or not ours
        if hdr[_H_CLOSED] or not host.pid_alive(int(hdr[_H_PID])):
            removed += host.shm_unlink(name)
    return removed


class WorldBus:
    """A mapping of one world's block. Use `create` (world node) or `attach` (every other node)."""

    def __init__(self, name: str, fd: int, mm: mmap.mmap, owner: bool):
        self.name, self._fd, self._mm, self.owner = name, fd, mm, owner
        self.hdr = np.frombuffer(mm, dtype=np.int64, count=_NHDR)
        nq, nv, nu, ns = (int(self.hdr[i]) for i in (_H_NQ, _H_NV, _H_NU, _H_NS))
        self.nq, self.nv, self.nu, self.ns = nq, nv, nu, ns
        self._name_buf = np.frombuffer(mm, dtype=np.uint8, count=_NAME_BYTES, offset=8 * _NHDR)
        f = np.frombuffer(mm, dtype=np.float64, offset=8 * _NHDR + _NAME_BYTES)
        i = 0

        def take(n: int) -> np.ndarray:
            nonlocal i
            out = f[i:i + n]
            i += n
            return out

        self._state = f[:2 + nq + nv + nu + ns]  # what one write_state writes, checked as one
        self._times = take(2)             # sim time, wall time of the last write
        self.qpos, self.qvel, self.ctrl, self.sensordata = take(nq), take(nv), take(nu), take(ns)
        self.cmd_target, self.cmd_t, self.cmd_stamp = take(nu), take(nu), take(nu)
        self.cmd_check = take(nu).view(np.uint64)
        self.gain_kp, self.gain_kd, self.gain_stamp = take(nu), take(nu), take(nu)
        self.gain_check = take(nu).view(np.uint64)
        self._hdr_u = self.hdr.view(np.uint64)

    # -- creation / attachment ------------------------------------------------------------------
    @classmethod
    def create(cls, world: str, scene: str, nq: int, nv: int, nu: int, ns: int = 0) -> WorldBus:
        host.require_shared_memory("the sim world bus")
        sweep_stale()
        name = block_name(world)
        size = _size(nq, nv, nu, ns)
        try:
            fd = host.shm_create(name, size)
        except FileExistsError:
            cls._reclaim(name, world)
            fd = host.shm_create(name, size)
        mm = mmap.mmap(fd, size)
        hdr = np.frombuffer(mm, dtype=np.int64, count=_NHDR)
        hdr[_H_NQ], hdr[_H_NV], hdr[_H_NU], hdr[_H_NS] = nq, nv, nu, ns
        hdr[_H_PID], hdr[_H_VERSION] = os.getpid(), _VERSION
        raw = scene.encode()[:_NAME_BYTES - 1]
        np.frombuffer(mm, dtype=np.uint8, count=_NAME_BYTES, offset=8 * _NHDR)[:len(raw)] = list(raw)
        hdr[_H_MAGIC] = _MAGIC  # last: attachers wait for it
        return cls(name, fd, mm, owner=True)

    @staticmethod
    def _reclaim(name: str, world: str) -> None:
        fd = host.shm_open(name)
        try:
            if os.fstat(fd).st_size >= 8 * _NHDR:
                mm = mmap.mmap(fd, 8 * _NHDR)
                hdr = np.frombuffer(mm, dtype=np.int64, count=_NHDR).copy()
                del mm
                if hdr[_H_MAGIC] == _MAGIC and not hdr[_H_CLOSED] and host.pid_alive(int(hdr[_H_PID])):
                    raise RioError(f"sim world '{world}' is already running in this session (pid {hdr[_H_PID]}); "
                                   "give the second station's world another `world` name")
        finally:
            os.close(fd)
        host.shm_unlink(name)

    @classmethod
    def attach(cls, world: str, timeout: float = 60.0) -> WorldBus:
        """Wait (up to `timeout` s) for the world to be created and ready, then map it."""
        name = block_name(world)
        deadline = clock.now() + timeout
        while True:
            try:
                fd = host.shm_open(name)
            except FileNotFoundError:
                fd = None
            if fd is not None:
                size = os.fstat(fd).st_size
                if size >= 8 * _NHDR:
                    probe = mmap.mmap(fd, 8 * _NHDR)
                    hdr = np.frombuffer(probe, dtype=np.int64, count=_NHDR).copy()
                    del probe
                    if (hdr[_H_MAGIC] == _MAGIC and hdr[_H_VERSION] == _VERSION and hdr[_H_READY] and not hdr[_H_CLOSED]
                            and size >= _size(*(int(hdr[i]) for i in (_H_NQ, _H_NV, _H_NU, _H_NS)))):
                        return cls(name, fd, mmap.mmap(fd, size), owner=False)
                os.close(fd)
            if clock.now() > deadline:
                raise RioError(f"no sim world '{world}' came up within {timeout:.0f} s: does the station have a "
                               f"component with driver = \"sim.world\" and world = \"{world}\"?")
            clock.precise_wait(clock.now() + 0.02)

    # -- header ---------------------------------------------------------------------------------
    @property
    def scene(self) -> str:
        raw = bytes(self._name_buf)
        return raw.split(b"\0", 1)[0].decode()

    def mark_ready(self) -> None:
        self.hdr[_H_READY] = 1

    def check_alive(self) -> None:
        """Raise if the world has stopped (its node closed or its process died)."""
        if self.hdr[_H_CLOSED] or not host.pid_alive(int(self.hdr[_H_PID])):
            raise RioError("the sim world stopped (its node closed or its process died)")

    # -- state ----------------------------------------------------------------------------------
    def write_state(self, sim_time: float, qpos, qvel, ctrl, sensordata=None) -> None:
        hdr = self.hdr
        seq = int(hdr[_H_SEQ]) + 2
        hdr[_H_SEQ] = seq - 1  # odd: write in progress
        self.qpos[:], self.qvel[:], self.ctrl[:] = qpos, qvel, ctrl
        if self.ns:
            self.sensordata[:] = sensordata
        self._times[0], self._times[1] = sim_time, clock.now()
        self._hdr_u[_H_CHECK] = slot_check.checksum(seq, self._state)
        hdr[_H_SEQ] = seq

    def read_state(self, out: dict | None = None) -> dict:
        """Consistent copy of {qpos, qvel, ctrl, sim_time, wall_time}, and `sensordata` where `out` has it."""
        out = out if out is not None else {"qpos": np.empty(self.nq), "qvel": np.empty(self.nv),
                                           "ctrl": np.empty(self.nu)}
        hdr = self.hdr
        deadline = None
        for attempt in range(1 << 30):
            seq = int(hdr[_H_SEQ])
            if not seq & 1:
                state = self._state.copy()
                if slot_check.checksum(seq, state) == int(self._hdr_u[_H_CHECK]):
                    nq, nv = self.nq, self.nv
                    out["sim_time"], out["wall_time"] = float(state[0]), float(state[1])
                    out["qpos"][:], out["qvel"][:] = state[2:2 + nq], state[2 + nq:2 + nq + nv]
                    nu = self.nu
                    out["ctrl"][:] = state[2 + nq + nv:2 + nq + nv + nu]
                    if "sensordata" in out:
                        out["sensordata"][:] = state[2 + nq + nv + nu:]
                    return out
            # a write is in progress, or not yet visible here; its writer may be preempted on a busy machine
            if attempt % 16 == 15:
                now = clock.now()
                deadline = deadline or now + _LOCKED_S
                if now > deadline:
                    break
                host.yield_cpu()
        raise RioError(f"sim world state stayed locked for {_LOCKED_S} s (a writer died mid-write?)")

    # -- episode --------------------------------------------------------------------------------
    def write_episode(self, t0_sim: float, time_limit_s: float) -> int:
        """A new episode started at simulated time `t0_sim`, lasting at most `time_limit_s` (0: no limit).
        Returns its number (1, 2, ... on this bus)."""
        f = self.hdr.view(np.float64)
        f[_H_EPISODE_T0], f[_H_TIME_LIMIT] = float(t0_sim), float(time_limit_s)
        self.hdr[_H_EPISODE] += 1  # last: a reader seeing the new number sees its times
        return int(self.hdr[_H_EPISODE])

    def read_episode(self) -> tuple[int, float, float]:
        """(number, start in simulated time, time limit) of the current episode; number 0: none started."""
        f = self.hdr.view(np.float64)
        return int(self.hdr[_H_EPISODE]), float(f[_H_EPISODE_T0]), float(f[_H_TIME_LIMIT])

    # -- commands -------------------------------------------------------------------------------
    @staticmethod
    def _command_check(stamp: float, target: float, t_target: float) -> int:
        return slot_check.checksum(int(stamp), np.array([target, t_target]))

    def _write(self, slots: tuple, actuators: np.ndarray, a, b) -> None:
        first, second, stamps, checks = slots
        first[actuators], second[actuators] = a, b
        for i in np.atleast_1d(actuators):
            stamp = stamps[i] + 1.0
            checks[i] = self._command_check(stamp, first[i], second[i])
            stamps[i] = stamp  # after both values and the check

    def _read(self, slots: tuple, seen: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        first, second, stamp, check = (x.copy() for x in slots)
        for i in np.flatnonzero(stamp != seen):
            if self._command_check(stamp[i], first[i], second[i]) != int(check[i]):
                stamp[i] = seen[i]
        return stamp, first, second

    def command(self, actuators: np.ndarray, targets, t_target: float) -> None:
        """Set targets for actuators this node owns, to be reached at `t_target`."""
        self._write((self.cmd_target, self.cmd_t, self.cmd_stamp, self.cmd_check), actuators, targets, t_target)

    def read_commands(self, seen: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(stamp, target, t_target) of every actuator. An actuator whose new command is not yet fully
        visible here (its check does not match) keeps its `seen` stamp: it is picked up next time."""
        return self._read((self.cmd_target, self.cmd_t, self.cmd_stamp, self.cmd_check), seen)

    def set_gains(self, actuators: np.ndarray, kp, kd) -> None:
        """Servo gains (N m/rad, N m s/rad) of position actuators this node owns."""
        self._write((self.gain_kp, self.gain_kd, self.gain_stamp, self.gain_check), actuators, kp, kd)

    def read_gains(self, seen: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(stamp, kp, kd) of every actuator, picked up like commands (`read_commands`)."""
        return self._read((self.gain_kp, self.gain_kd, self.gain_stamp, self.gain_check), seen)

    # -- teardown -------------------------------------------------------------------------------
    def close(self) -> None:
        if self._mm is None:
            return
        if self.owner:
            self.hdr[_H_CLOSED] = 1
            host.shm_unlink(self.name)
        # numpy views keep the mapping alive; drop ours and let the last view release it
        self.hdr = self._name_buf = self._times = None  # type: ignore[assignment]
        self.qpos = self.qvel = self.ctrl = self.sensordata = self.cmd_target = self.cmd_t = self.cmd_stamp = None  # type: ignore
        self._state = self.cmd_check = self._hdr_u = None  # type: ignore[assignment]
        self.gain_kp = self.gain_kd = self.gain_stamp = self.gain_check = None  # type: ignore[assignment]
        os.close(self._fd)
        self._mm = None
