"""`ufactory.gripper` / `ufactory.gripper_g2`: the xArm Gripper on the tool RS-485.

G1 takes a position in pulses (0 closed .. 850 open, about 0.1 mm each) and a speed in r/min; it has no
force setting and no object flag, so `object_detected` is inferred the way its own "catch" check does:
closing stopped short of the goal. G2 takes millimetres, mm/s and a force percentage.
"""

from __future__ import annotations

import time

import numpy as np
from pydantic import Field

from .base import ToolGripper

G1_OPEN_PULSES = 850
STALL_S = 0.3  # no motion for this long short of a closing goal: something is between the fingers


class XArmGripper(ToolGripper):
    class Config(ToolGripper.Config):
        defaults = {"max_width": 0.085}
        speed: float = Field(5000, gt=0, le=5000, description="finger speed (G1: r/min of its motor)")
        generation: int = Field(1, ge=1, le=2, description="1: xArm Gripper, 2: xArm Gripper G2")

    def start_device(self) -> None:
        assert self.conn is not None
        if self.config.generation == 1:
            self.conn.call("set_gripper_mode", 0)
            self.conn.call("set_gripper_speed", self.config.speed)
        self._moved = (np.inf, time.monotonic())

    def enable_device(self, on: bool) -> None:
        assert self.conn is not None
        self.conn.call("set_gripper_enable", on)

    def read_device(self) -> tuple[float, bool]:
        assert self.conn is not None
        c = self.config
        if c.generation == 1:
            width = float(self.conn.call("get_gripper_position")) / G1_OPEN_PULSES * c.max_width
        else:
            width = float(self.conn.call("get_gripper_g2_position")) / 1000.0
        now = time.monotonic()
        if abs(width - self._moved[0]) > 0.0005:
            self._moved = (width, now)
        goal = self._sent[0] if self._sent else width
        stalled = now - self._moved[1] > STALL_S
        return width, bool(stalled and goal < width - 0.002)

    def send_goal(self, width: float, force: float) -> None:
        assert self.conn is not None
        c = self.config
        if c.generation == 1:
            self.conn.call("set_gripper_position", round(width / c.max_width * G1_OPEN_PULSES), wait=False)
        else:
            pct = 50 if np.isnan(force) else int(np.clip(force, 1, 100))
            self.conn.call("set_gripper_g2_position", round(width * 1000.0), speed=min(c.speed, 225), force=pct,
                          wait=False)
