"""What every gripper on an xArm's tool connector shares: the control box connection of the arm it is
mounted on (one SDK connection per process, see `connection.py`), the held-on-fault behaviour of
`link.py`, and goals sent only when they change.

The tool RS-485 is slow (each exchange is a round trip through the control box, ~5-10 ms) and shared
with the arm's command socket, so a gripper node runs at a modest rate and re-sends a goal only when
it moved by more than `deadband_m` or the force changed: a held gripper costs one read per cycle.
A device writes four hooks: `start_device()`, `enable_device(on)`, `read_device() -> (opening m,
object detected)` and `send_goal(opening m, force N or NaN)`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio.interfaces import GripperNode, NetworkDevice

from ..connection import XArmConnection
from ..faults import XArmFault, XArmLost
from ..link import guarded, hold_faults_and_drops


class ToolGripper(GripperNode):
    class Config(NetworkDevice, GripperNode.Config):
        defaults = {"rate_hz": Field(20.0, le=100)}  # one tool RS-485 read per cycle
        deadband_m: float = Field(0.001, ge=0, description="re-send the goal only when it changed more than this (m)")

    # -- device hooks -------------------------------------------------------------------------------
    def start_device(self) -> None:
        """Once after connecting: baud rate, mode, activation."""

    def enable_device(self, on: bool) -> None:
        """Motor on/off where the device has one."""

    def read_device(self) -> tuple[float, bool]:
        raise NotImplementedError

    def send_goal(self, width: float, force: float) -> None:
        raise NotImplementedError

    # -- shared -------------------------------------------------------------------------------------
    def setup(self) -> None:
        super().setup()
        self.example_data = {**self.example_data, "object_detected": False}
        self.conn: XArmConnection | None = None
        hold_faults_and_drops(self)
        self._sent: tuple[float, float] | None = None
        self._last = (float(self.config.max_width), False)

    def open(self) -> None:
        c = self.config
        self.conn = XArmConnection.acquire(c.ip, connect_timeout_s=c.connect_timeout_s)
        self.start_device()

    def close(self) -> None:
        if self.conn is not None:
            self.conn.release()
            self.conn = None

    def set_enabled(self, enabled: bool) -> None:
        self.enable_device(bool(enabled))
        self._sent = None

    def read_width(self) -> dict[str, Any]:
        if self.link.watch():  # a dropped socket is noticed and retried here
            try:
                self._last = self.read_device()
            except XArmFault as e:
                self.faults.report(e.fault)
            except XArmLost:
                self.link.lost()
        width, obj = self._last
        return {"width": float(width), "object_detected": bool(obj)}

    def write_width(self, width: float, force: float) -> None:
        sent = self._sent
        same_force = sent is not None and (sent[1] == force or (np.isnan(sent[1]) and np.isnan(force)))
        if sent is not None and same_force and abs(width - sent[0]) <= self.config.deadband_m:
            return
        self._sent = (width, force)
        guarded(self, self.send_goal, width, force)

