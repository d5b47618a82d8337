"""The jaw as a `GripperNode`: opening in meters, so any embodiment and policy treat it like every
other gripper.

The jaw servo shares the arm's bus; this node opens the same port (transactions are serialised by
the port lock), owns only the jaw id and maps its calibrated range linearly to 0..`max_width`
(range_min = closed). Its torque is limited (`max_torque`) so holding an object stalls the jaw below
the servo's overload threshold; a real fault still stops the node with the servo named.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from rio import time as rtime
from rio.interfaces import GripperNode

from ..connection import ArmConnection
from ..models import GRIPPER
from ..servo_node import ServoNodeMixin


class So100Gripper(ServoNodeMixin, GripperNode):
    __api__ = (*GripperNode.__api__, "torque")
    role = "follower"

    def __init__(self, port: str, calibration: str = "default", model: str = "so100", joint: str = GRIPPER,
                 max_width: float = 0.06, rate_hz: float = 50.0, max_step_rad: float = 0.06,
                 watchdog_s: float = 0.5, max_torque: float = 0.5, baudrate: int = 1_000_000, retries: int = 2,
                 disable_torque_on_close: bool = True):
        super().__init__(max_width, rate_hz=rate_hz)
        self.example_data = {**self.example_data, "holding": True, "load": 0.0, "temperature": 0.0, "error": 0}
        self.joint = joint
        self.conn = ArmConnection(port, model=model, role=self.role, calibration=calibration, baudrate=baudrate,
                                  retries=retries)
        self.max_step, self.watchdog_s, self.max_torque = float(max_step_rad), float(watchdog_s), float(max_torque)
        self.disable_torque_on_close = bool(disable_torque_on_close)
        self.group = self.commander = self.cal = None
        self._torque = False

    def open(self) -> None:
        self.group = self.conn.open([self.joint])
        self.cal = self.group.cal[0]
        self.group.configure(torque_limit=self.max_torque)
        self._start()

    # -- meters <-> jaw angle ----------------------------------------------------------------------
    def _width(self, steps: float) -> float:
        return self.cal.fraction(steps) * self.width

    def _rad(self, width: float) -> float:
        return self.cal.to_rad(self.cal.from_fraction(width / self.width))

    # -- loop --------------------------------------------------------------------------------------
    def read_state(self) -> dict[str, Any]:
        s = self._cycle()
        return {"position": self._width(s["steps"][0]), "max_width": self.width, "holding": self.commander.holding,
                "load": float(s["load"][0]), "temperature": float(s["temperature"][0]), "error": int(s["error"][0])}

    def command_position(self, position: float, t_cmd_target: float) -> None:
        if self._torque:
            self.commander.command(np.array([self._rad(position)]), t_cmd_target, rtime.now())


class So101Gripper(So100Gripper):
    def __init__(self, port: str, calibration: str = "default", model: str = "so101", **kwargs: Any):
        super().__init__(port, calibration, model, **kwargs)
