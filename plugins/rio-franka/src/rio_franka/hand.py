"""`franka.hand`: the Franka Hand through franky's `Gripper` (its own TCP connection to the control box).

The hand runs its own speed-limited finger motion and takes one command at a time (each franky
command preempts the running one), so the node sends the kind's per-cycle goal only when it changed
by more than `deadband_m` or the force changed: a held hand gets no commands, a moving one one per
cycle (raise `max_step_m` for fewer, larger steps). Closing with a
force is a `grasp(width, speed, force, epsilon_inner, epsilon_outer)`: libfranka reports an object as
grasped when the fingers stop within [width - epsilon_inner, width + epsilon_outer], so the default
`epsilon_outer` counts any object narrower than the opening; opening (or no force) is a `move`.
`object_detected` is franky's `is_grasped` when the fingers also stopped short of the grasp's goal: the
kind sends step-limited goals, and a grasp whose fingers simply reached an intermediate goal (a late cycle
on a busy machine lets them) is one libfranka calls grasped although nothing is between the fingers.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio.interfaces import FaultHolder, GripperNode, LinkSupervisor

from .backend import connect_gripper
from .link import FrankaConfig, FrankaConnection


class FrankaHand(GripperNode):
    class Config(FrankaConfig, GripperNode.Config):
        # one width read per cycle; the Franka Hand opens 80 mm; it grasps with 20 N when closing (0 or None:
        # plain moves)
        defaults = {"rate_hz": Field(20.0, le=100), "max_width": 0.08, "force": 20.0}
        speed: float = Field(0.1, gt=0, le=0.2, description="finger speed (m/s)")
        epsilon_inner: float = Field(0.005, ge=0, description="grasped if the fingers stop at most this much "
                                                              "inside the goal (m)")
        epsilon_outer: float = Field(0.08, ge=0, description="grasped if the fingers stop at most this much "
                                                             "outside the goal (m)")
        deadband_m: float = Field(0.001, ge=0, description="send a new goal only when it moved more than this (m)")

    def setup(self) -> None:
        super().setup()
        self.example_data = {**self.example_data, "object_detected": False}
        self.conn = FrankaConnection(self, lambda: connect_gripper(self.config.ip, self.config.backend))
        self.faults = FaultHolder(self, f"Franka at {self.config.ip}")
        self.link = LinkSupervisor(self.faults, up=lambda: self.conn.handle is not None, reconnect=self.conn.retry)
        self._sent: tuple[float, float] | None = None
        self._grasp_goal: float | None = None  # the goal of the running grasp; None while moving
        self._last = (float(self.config.max_width), False)

    def open(self) -> None:
        self.conn.open(self.config.connect_timeout_s)

    def close(self) -> None:
        self.conn.close()

    def set_enabled(self, enabled: bool) -> None:
        self._sent = None

    def read_width(self) -> dict[str, Any]:
        self.link.watch()  # retries a dropped link
        hand = self.conn.handle
        if hand is not None:
            # one GripperState: width and is_grasped of the same moment (two property reads are two
            # reads of the gripper, which a busy machine can put far apart)
            got = self.conn.call(lambda: (lambda st: (float(st.width), bool(st.is_grasped)))(hand.state))
            if got is not None:
                width, grasped = got
                goal = self._grasp_goal
                self._last = (width, grasped and goal is not None and width > goal + self.config.deadband_m)
        width, obj = self._last
        return {"width": width, "object_detected": obj}

    def write_width(self, width: float, force: float) -> None:
        goal = float(width)  # the kind's goal this cycle (clipped, step-limited, held by the watchdog)
        sent = self._sent
        same_force = sent is not None and (sent[1] == force or (np.isnan(sent[1]) and np.isnan(force)))
        unchanged = sent is not None and same_force and abs(goal - sent[0]) <= self.config.deadband_m
        if self.conn.handle is None or unchanged:
            return
        self._sent = (goal, force)
        c, hand = self.config, self.conn.handle
        closing = goal < self._last[0] - c.deadband_m
        if closing and np.isfinite(force) and force > 0:
            self._grasp_goal = goal
            self.conn.call(hand.grasp_async, goal, c.speed, force, c.epsilon_inner, c.epsilon_outer)
        else:
            self._grasp_goal = None
            self.conn.call(hand.move_async, goal, c.speed)
