"""What every gripper on an xArm's tool connector shares: the controller connection of the arm it is
mounted on (one SDK connection per process, see `controller.py`), the held-on-fault behaviour of
`link.py`, and goals sent only when they change.

The tool RS-485 is slow (each exchange is a round trip through the controller, ~5-10 ms) and shared
with the arm's command socket, so a gripper node runs at a modest rate and re-sends a goal only when
it moved by more than `deadband_m` or the force changed: a held gripper costs one read per cycle.
A device writes four hooks: `start_device()`, `enable_device(on)`, `read_device() -> (opening m,
object detected)` and `send_goal(opening m, force N or NaN)`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio.interfaces import FAULT_KEYS, GripperNode

from ..faults import XArmFault, XArmLost
from ..link import ControllerLink, LinkConfig


class ToolGripper(ControllerLink, GripperNode):
    class Config(LinkConfig, GripperNode.Config):
        rate_hz: float = Field(20.0, gt=0, le=100, description="cycles per second (one tool RS-485 read each)")
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
        self.example_data = {**self.example_data, **FAULT_KEYS, "object_detected": False}
        self._sent: tuple[float, float] | None = None
        self._last = (float(self.config.max_width), False)

    def open(self) -> None:
        self.open_controller()
        self.start_device()

    def set_enabled(self, enabled: bool) -> None:
        self.enable_device(bool(enabled))
        self._sent = None

    def read_width(self) -> dict[str, Any]:
        status = self.link_status()
        if status["connected"]:
            try:
                self._last = self.read_device()
            except XArmFault as e:
                self.on_fault(e.fault)
                status["fault_code"] = e.fault.code
            except XArmLost:
                self.on_lost()
                status["connected"] = False
        width, obj = self._last
        return {"position": float(width), "object_detected": bool(obj), **status}

    def write_width(self, width: float, force: float) -> None:
        sent = self._sent
        same_force = sent is not None and (sent[1] == force or (np.isnan(sent[1]) and np.isnan(force)))
        if sent is not None and same_force and abs(width - sent[0]) <= self.config.deadband_m:
            return
        self._sent = (width, force)
        self.guarded(self.send_goal, width, force)

