"""The follower arm node: joint targets in, measured joints out, one bus cycle per tick.

Each tick (the runtime's combined loop: pending requests, then `read_state`): one SYNC READ of the
state block; servo error bits stop the arm (goal = present, then `ServoFault` naming the servo, which
ends the node and reaches every client); then the `JointCommander` gives this cycle's goal
(interpolated, clipped to the calibrated limits, step-limited, held by the watchdog) and one SYNC
WRITE sends it. There is no forward kinematics here, so `eef_pose` is NaN, as the interface asks.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from rio import time as rtime
from rio.interfaces import ArmNode
from rio.node import client_side

from ..connection import ArmConnection
from ..models import ARM_JOINTS
from ..servo_node import ServoNodeMixin

_NAN_POSE = np.full(7, np.nan)


class So100Follower(ServoNodeMixin, ArmNode):
    __api__ = (*ArmNode.__api__, "torque", "joint_limits", "joint_names", "hold")
    role = "follower"

    def __init__(self, port: str, calibration: str = "default", model: str = "so100",
                 joints: list[str] | None = None, rate_hz: float = 100.0, max_step_rad: float = 0.05,
                 watchdog_s: float = 0.5, p_gain: int = 16, i_gain: int = 0, d_gain: int = 32,
                 max_torque: float = 1.0, baudrate: int = 1_000_000, retries: int = 2,
                 disable_torque_on_close: bool = True):
        self.joint_list = list(joints or ARM_JOINTS)
        super().__init__(len(self.joint_list), rate_hz=rate_hz)
        n = self.dof
        self.example_data = {**self.example_data, "holding": True, "torque": True, "load": np.zeros(n),
                             "temperature": np.zeros(n), "voltage": np.zeros(n), "error": np.zeros(n, np.int64)}
        self.conn = ArmConnection(port, model=model, role=self.role, calibration=calibration, baudrate=baudrate,
                                  retries=retries)
        self.max_step, self.watchdog_s = float(max_step_rad), float(watchdog_s)
        self.gains, self.max_torque = (p_gain, i_gain, d_gain), float(max_torque)
        self.disable_torque_on_close = bool(disable_torque_on_close)
        self.group = self.commander = None
        self._torque = False

    # -- lifecycle ---------------------------------------------------------------------------------
    def open(self) -> None:
        self.group = self.conn.open(self.joint_list)
        self.group.configure(*self.gains, torque_limit=self.max_torque)
        self._start()

    # -- loop --------------------------------------------------------------------------------------
    def read_state(self) -> dict[str, Any]:
        s = self._cycle()
        return {"joint_pos": s["joint_pos"], "joint_vel": s["joint_vel"], "eef_pose": _NAN_POSE,
                "holding": self.commander.holding, "torque": self._torque, "load": s["load"],
                "temperature": s["temperature"], "voltage": s["voltage"], "error": s["error"]}

    def command_joints(self, joint_pos: np.ndarray, t_cmd_target: float) -> None:
        if self._torque:
            self.commander.command(joint_pos, t_cmd_target, rtime.now())

    # -- remote API --------------------------------------------------------------------------------
    def hold(self) -> None:
        """Stop where the arm is commanded to be now."""
        self.commander.hold()

    def joint_limits(self) -> list[list[float]]:
        """[[lower...], [upper...]] in rad, from the calibration."""
        lower, upper = self.group.limits_rad()
        return [lower.tolist(), upper.tolist()]

    @client_side
    def joint_names(self) -> list[str]:
        return list(self.joint_list)


class So101Follower(So100Follower):
    def __init__(self, port: str, calibration: str = "default", model: str = "so101", **kwargs: Any):
        super().__init__(port, calibration, model, **kwargs)
