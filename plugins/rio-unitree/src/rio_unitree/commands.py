"""The three commands the G1 driver puts on the wire: a position goal (stiff), damping (kp = 0), and
the arm_sdk variant of the goal carrying its weight. Kept apart from the node so what reaches the
motors is one small, testable function of the goal and the measured state.

At the wire, whatever the commander already did, each goal is clipped again to the joint limits, and
(with `torque_limit`) to the band around the measured position in which `kp * error + |tau|` stays
within the motor's effort limit: a goal the motor could not reach at full torque anyway is not stored
as a wound-up spring that would snap the joint when the obstacle (or a hand) lets go.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .g1 import JOINTS, NUM_SLOTS, WEIGHT_SLOT, Joint
from .wire import LowCmd

MODE_PR = 0  # ankles commanded as pitch/roll joints (the URDF's), not as the A/B motor pair
ENABLE = 1  # motor_cmd[i].mode: 1 drives the motor, 0 leaves it off


class Commands:
    def __init__(self, joints: Sequence[Joint], kp: Sequence[float], kd: Sequence[float], damping: Sequence[float],
                 lower: np.ndarray, upper: np.ndarray, torque_limit: bool = True, dof: int = 29):
        self.slots = np.array([j.slot for j in joints], dtype=np.intp)
        self.kp, self.kd = np.asarray(kp, np.float64), np.asarray(kd, np.float64)
        self.damping_kd = np.asarray(damping, np.float64)
        self.effort = np.array([j.effort for j in joints], np.float64)
        self.lower, self.upper = np.asarray(lower, np.float64), np.asarray(upper, np.float64)
        self.torque_limit = torque_limit
        # slots of the robot's joints this node does not drive: damped in whole-body commands
        present = {j.slot for j in JOINTS if dof == 29 or j.slot not in (13, 14, 20, 21, 27, 28)}
        others = sorted(present - set(self.slots.tolist()))
        self.other_slots = np.array(others, dtype=np.intp)
        self.other_damping = np.array([next(j.damping for j in JOINTS if j.slot == s) for s in others], np.float64)

    def wire_q(self, goal: np.ndarray, measured: np.ndarray) -> np.ndarray:
        q = np.clip(goal, self.lower, self.upper)
        if self.torque_limit:
            band = np.where(self.kp > 0, self.effort / np.maximum(self.kp, 1e-9), np.inf)
            q = np.clip(q, measured - band, measured + band)
        return q

    def position(self, goal: np.ndarray, measured: np.ndarray, mode_machine: int,
                 weight: float | None = None) -> LowCmd:
        """Stiff goal, at rest (dq* = 0, tau = 0). `weight` given: an rt/arm_sdk message (only this node's
        joints, weight in slot 29); otherwise a whole-body rt/lowcmd (other joints of the robot damped).

        No velocity feed-forward: the robot holds a command until the next one, and a held dq* keeps
        pushing the joint (to kd/kp * dq* past its goal) when the stream stalls; without it a stall is a
        stop. A moving goal is followed kd/kp * speed behind (0.02 rad at 1 rad/s with the defaults)."""
        cmd = LowCmd(mode_pr=MODE_PR, mode_machine=mode_machine)
        s = self.slots
        cmd.mode[s] = ENABLE
        cmd.q[s] = self.wire_q(goal, measured)
        cmd.kp[s], cmd.kd[s] = self.kp, self.kd
        if weight is None:
            self._damp_others(cmd)
        else:
            cmd.q[WEIGHT_SLOT] = float(np.clip(weight, 0.0, 1.0))
        return cmd

    def damping(self, mode_machine: int) -> LowCmd:
        """Every joint soft: kp = 0, kd = its damping, no torque."""
        cmd = LowCmd(mode_pr=MODE_PR, mode_machine=mode_machine)
        cmd.mode[self.slots] = ENABLE
        cmd.kd[self.slots] = self.damping_kd
        self._damp_others(cmd)
        return cmd

    def _damp_others(self, cmd: LowCmd) -> None:
        if self.other_slots.size:
            cmd.mode[self.other_slots] = ENABLE
            cmd.kd[self.other_slots] = self.other_damping


def is_damping(cmd: LowCmd, slots: Sequence[int] = tuple(range(29))) -> bool:
    """Whether `cmd` asks no stiffness and no torque of `slots` (what a soft stop looks like)."""
    s = np.asarray(slots)
    return bool(np.all(cmd.kp[s] == 0) and np.all(cmd.tau[s] == 0) and np.all(cmd.kd[s] >= 0))


__all__ = ["Commands", "is_damping", "MODE_PR", "ENABLE", "NUM_SLOTS"]
