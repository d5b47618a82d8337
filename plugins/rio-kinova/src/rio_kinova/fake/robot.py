"""A Gen3-like arm for the fake backend: joint positions following kortex's commands with the base's
behaviour as the driver sees it, integrated lazily (each call advances time; no thread).

- high-level joint speeds (`SendJointSpeedsCommand`, deg/s) are followed with the model's speed limits,
  a 10 rad/s^2 acceleration limit and a 15 ms lag; a Cartesian twist is turned into joint speeds through
  the DH Jacobian;
- low-level positions (`BaseCyclic.Refresh`, deg) are followed with a 5 ms lag, speed-limited;
- a limited joint stops at its limit (the base's soft limits);
- `inject_fault(...)` puts the arm in fault: it stops, the arm state notification and an `ACTION_ABORT`
  fire, commands are refused until `ClearFaults()` (an emergency stop: until it is released, too);
- the Robotiq 2F-85's finger position (0 open .. 1 closed) follows its goal at 1.7 /s.

What it leaves out: dynamics under load, the real base's timing and its protocol (see `fake/__init__.py`).
With a `plant` (rio-sim's `WorldArm`), positions go to the simulated arm and are read back from it, and
the 2F-85's goal goes to the world's fingers (`fake/sim.py`), whose opening comes back as its finger
position (a cube between them stops it short of 1). Only a fake that was sent a motion commands the
world's joints: with each node in its own process, the gripper node's session has a fake of its own,
which must not hold the arm where it found it.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from .. import dh
from ..models import ArmModel
from . import messages as pb
from .sim import sim_fingers

ACCEL = 10.0  # rad/s^2
LAG_HIGH, LAG_LOW = 0.015, 0.005  # s
GRIPPER_SPEED = 1.7  # of the full stroke per second
_STEP = 0.002


class FakeServerError(RuntimeError):
    """What the fake base raises where kortex raises `KServerException` (the base refused the call)."""


class FakeLinkError(ConnectionError):
    """What the fake raises where kortex raises `KClientException` (no answer: the link is gone)."""


class FakeRobot:
    def __init__(self, model: ArmModel, plant: Any = None):
        self.model, self.plant = model, plant
        n = model.dof
        self.q = np.array(model.home, dtype=np.float64) if plant is None else plant.joint_pos().copy()
        self.v = np.zeros(n)
        self.speed_cmd = np.zeros(n)
        self.low_target: np.ndarray | None = None
        self.servoing = pb.SINGLE_LEVEL_SERVOING
        self.state = pb.ARMSTATE_SERVOING_READY
        self.fault_detail = ""
        self.estop_held = False
        self.grip, self.grip_goal = 0.0, 0.0
        self.fingers = None if plant is None else sim_fingers(plant, GRIPPER_SPEED * plant.max_width)
        if self.fingers is not None:
            self.grip = self.grip_goal = self._finger_position()
        self.steering = plant is None  # with a plant: set by the first motion command (see advance)
        self.t = time.monotonic()
        self.lock = threading.RLock()
        self.arm_state_callbacks: list[Callable[[Any], None]] = []
        self.action_callbacks: list[Callable[[Any], None]] = []
        self.calls: dict[str, int] = {}
        self.link_up = True  # drop_link() / restore_link(): a cable pulled and plugged back
        self.lo = np.array([lo for lo, _ in model.limits])
        self.hi = np.array([hi for _, hi in model.limits])
        self.vmax = np.array(model.max_joint_speed)

    # -- time -----------------------------------------------------------------------------------------
    def advance(self) -> None:
        with self.lock:
            now = time.monotonic()
            dt_all, self.t = min(now - self.t, 0.5), now
            steps = max(1, math.ceil(dt_all / _STEP))
            for _ in range(steps):
                self._step(dt_all / steps)
            if self.plant is not None:
                self.steering = self.steering or bool(self.speed_cmd.any()) or self.low_target is not None
                if self.steering:
                    self.plant.command_joints(self.q, now + 0.02)
                self._follow_fingers()

    def _follow_fingers(self) -> None:
        """The 2F-85's goal to the world's fingers when it changed; their opening back as its position."""
        f = self.fingers
        width = (1.0 - self.grip_goal) * f.max_width
        if abs(width - f.goal) > 1e-6:
            f.command(width)
        self.grip = self._finger_position()

    def _finger_position(self) -> float:
        """The world's opening as the 2F-85's finger position (0 open .. 1 closed)."""
        return float(np.clip(1.0 - self.fingers.update() / self.fingers.max_width, 0.0, 1.0))

    def _step(self, dt: float) -> None:
        g = float(np.clip((self.grip_goal - self.grip), -GRIPPER_SPEED * dt, GRIPPER_SPEED * dt))
        self.grip += g
        if self.state == pb.ARMSTATE_IN_FAULT:
            self.v[:] = 0.0
            return
        if self.servoing == pb.LOW_LEVEL_SERVOING and self.low_target is not None:
            self.v = np.clip((self.low_target - self.q) / max(LAG_LOW, dt), -self.vmax, self.vmax)
        else:
            want = np.clip(self.speed_cmd, -self.vmax, self.vmax)
            dv = (want - self.v) * (1.0 - math.exp(-dt / LAG_HIGH))
            self.v += np.clip(dv, -ACCEL * dt, ACCEL * dt)
        self.q += self.v * dt
        stop = ((self.q <= self.lo) & (self.v < 0)) | ((self.q >= self.hi) & (self.v > 0))
        self.v[stop] = 0.0  # the base's soft limits: a joint stops at its limit
        self.q = np.clip(self.q, self.lo, self.hi)

    # -- faults ---------------------------------------------------------------------------------------
    def fault(self, detail: str, sub_error: str = "JOINT_FAULT") -> None:
        with self.lock:
            self.state, self.fault_detail = pb.ARMSTATE_IN_FAULT, detail
            self.v[:] = 0.0
            self.speed_cmd[:] = 0.0
            self.low_target = None
        note = pb.Message(active_state=pb.ARMSTATE_IN_FAULT)
        for cb in list(self.arm_state_callbacks):
            cb(note)
        abort = pb.Message(action_event=pb.ACTION_ABORT, abort_details=pb.SubErrorCodes.Value(sub_error))
        for cb in list(self.action_callbacks):
            cb(abort)

    def inject_fault(self, kind: str = "joint_fault") -> None:
        """'joint_fault' (cleared by ClearFaults) or 'emergency_stop' (held until `release_estop()`)."""
        if kind == "emergency_stop":
            self.estop_held = True
            self.fault("emergency stop", "EMERGENCY_STOP_ACTIVATED")
        else:
            self.fault("injected joint fault", "JOINT_FAULT")

    def release_estop(self) -> None:
        self.estop_held = False

    def clear(self) -> None:
        with self.lock:
            if self.estop_held:
                raise FakeServerError("ClearFaults: the emergency stop is still engaged")
            self.state = pb.ARMSTATE_SERVOING_READY
            self.fault_detail = ""
        note = pb.Message(active_state=self.state)
        for cb in list(self.arm_state_callbacks):
            cb(note)

    def drop_link(self) -> None:
        """Every call fails in transport (and a new session cannot connect) until `restore_link()`. The
        base stops the arm when its connection goes quiet (the session's connection inactivity timeout)."""
        with self.lock:
            self.link_up = False
            self.speed_cmd[:] = 0.0
            self.low_target = None

    def restore_link(self) -> None:
        self.link_up = True

    def check_link(self, what: str) -> None:
        if not self.link_up:
            raise FakeLinkError(f"{what}: no answer from the base (link down)")

    def close(self) -> None:
        """The session that owns this fake ended: let go of the simulated arm."""
        if self.plant is not None:
            self.plant.close()

    def check(self, what: str) -> None:
        self.check_link(what)
        self.calls[what] = self.calls.get(what, 0) + 1
        if self.state == pb.ARMSTATE_IN_FAULT:
            raise FakeServerError(f"{what}: the arm is in fault ({self.fault_detail})")

    # -- reads ----------------------------------------------------------------------------------------
    def measured(self) -> tuple[np.ndarray, np.ndarray]:
        if self.plant is not None:
            return self.plant.joint_pos(), self.plant.joint_vel()
        return self.q.copy(), self.v.copy()

    def tool_pose(self, q: np.ndarray) -> list[float]:
        from ..pose import from_matrix

        return from_matrix(dh.fk(self.model.dh, q, self.model.dh_base))

    def twist_to_speeds(self, twist: np.ndarray) -> np.ndarray:
        """Joint speeds (rad/s) for a base-frame twist [v (m/s), w (rad/s)]: the DH Jacobian's damped
        least squares, as the base's own Cartesian control would move the joints."""
        q, eps, n = self.q, 1e-6, self.model.dof
        t0 = dh.fk(self.model.dh, q, self.model.dh_base)
        jac = np.zeros((6, n))
        for i in range(n):
            dq = q.copy()
            dq[i] += eps
            t1 = dh.fk(self.model.dh, dq, self.model.dh_base)
            jac[:3, i] = (t1[:3, 3] - t0[:3, 3]) / eps
            dr = t1[:3, :3] @ t0[:3, :3].T
            jac[3:, i] = np.array([dr[2, 1] - dr[1, 2], dr[0, 2] - dr[2, 0], dr[1, 0] - dr[0, 1]]) / (2 * eps)
        return jac.T @ np.linalg.solve(jac @ jac.T + 1e-4 * np.eye(6), twist)
