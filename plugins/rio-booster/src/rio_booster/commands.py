"""What the T1 driver puts on `rt/joint_ctrl`: a stiff position goal or damping (kp = 0), first as plain arrays
(one small, testable function of the goal and the measured state), then as the SDK's `LowCmd`.

At the wire, whatever the commander already did, each goal is clipped again to the joint limits and (with
`torque_limit`) to the band around the measured position in which kp * error stays within the motor's
effort limit. Joints of the robot the node does not drive are held stiff where they were when the node
was enabled (in custom mode every motor is ours: a joint left out would otherwise go limp).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .t1 import JOINTS, NUM_JOINTS, Joint


@dataclass
class Frame:
    """One command for all 23 motors, in the SDK's JointIndex order."""

    q: np.ndarray
    dq: np.ndarray
    tau: np.ndarray
    kp: np.ndarray
    kd: np.ndarray

    def is_damping(self) -> bool:
        return bool(np.all(self.kp == 0) and np.all(self.tau == 0) and np.all(self.kd >= 0))


class Commands:
    def __init__(self, joints: Sequence[Joint], kp: Sequence[float], kd: Sequence[float], damping: Sequence[float],
                 lower: np.ndarray, upper: np.ndarray, torque_limit: bool = True):
        self.idx = np.array([j.index for j in joints], dtype=np.intp)
        self.kp, self.kd = np.asarray(kp, np.float64), np.asarray(kd, np.float64)
        self.effort = np.array([j.effort for j in joints], np.float64)
        self.lower, self.upper = np.asarray(lower, np.float64), np.asarray(upper, np.float64)
        self.torque_limit = torque_limit
        self.all_kp = np.array([j.kp for j in JOINTS])
        self.all_kd = np.array([j.kd for j in JOINTS])
        self.all_damping = np.array([j.damping for j in JOINTS])
        self.all_damping[self.idx] = np.asarray(damping, np.float64)
        self.others = np.setdiff1d(np.arange(NUM_JOINTS), self.idx)
        self.others_q = np.zeros(NUM_JOINTS)

    def hold_others_at(self, q_all: np.ndarray) -> None:
        """Where the joints this node does not drive are held (the measured pose at enable)."""
        self.others_q = np.asarray(q_all, np.float64).copy()

    def wire_q(self, goal: np.ndarray, measured: np.ndarray) -> np.ndarray:
        q = np.clip(goal, self.lower, self.upper)
        if self.torque_limit:
            band = np.where(self.kp > 0, self.effort / np.maximum(self.kp, 1e-9), np.inf)
            q = np.clip(q, measured - band, measured + band)
        return q

    def position(self, goal: np.ndarray, measured: np.ndarray) -> Frame:
        """Stiff goal, at rest (dq* = 0, no feed-forward torque: a stalled stream is a stop, not a push)."""
        f = Frame(q=self.others_q.copy(), dq=np.zeros(NUM_JOINTS), tau=np.zeros(NUM_JOINTS),
                  kp=self.all_kp.copy(), kd=self.all_kd.copy())
        f.q[self.idx] = self.wire_q(goal, measured)
        f.kp[self.idx], f.kd[self.idx] = self.kp, self.kd
        return f

    def damping(self) -> Frame:
        """Every motor soft: kp = 0, kd = its damping, no torque."""
        z = np.zeros(NUM_JOINTS)
        return Frame(q=z.copy(), dq=z.copy(), tau=z.copy(), kp=z.copy(), kd=self.all_damping.copy())


def to_low_cmd(sdk: Any, frame: Frame, motor_mode: int = 0) -> Any:
    """The frame as the SDK's `LowCmd` (SERIAL: joint space, ankles as pitch/roll), weight 1 on every motor."""
    cmd = sdk.LowCmd()
    cmd.cmd_type = sdk.LowCmdType.SERIAL
    cmd.resize_motor_cmd(NUM_JOINTS)
    for i, m in enumerate(cmd.motor_cmd):
        m.mode = motor_mode
        m.q, m.dq, m.tau = float(frame.q[i]), float(frame.dq[i]), float(frame.tau[i])
        m.kp, m.kd = float(frame.kp[i]), float(frame.kd[i])
        m.weight = 1.0
    return cmd


def from_low_cmd(cmd: Any) -> tuple[Frame, bool]:
    """A `LowCmd` (the SDK's or the emulator's) back as a frame, and whether it was SERIAL."""
    motors = list(cmd.motor_cmd)
    n = len(motors)
    get = lambda name: np.array([float(getattr(m, name)) for m in motors]) if n else np.zeros(0)  # noqa: E731
    serial = int(cmd.cmd_type) == 1
    return Frame(q=get("q"), dq=get("dq"), tau=get("tau"), kp=get("kp"), kd=get("kd")), serial
