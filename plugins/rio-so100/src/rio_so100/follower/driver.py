"""`so100.follower` / `so101.follower`: the arm joints of an SO-arm on its Feetech bus.

Hardware logic only; the arm kind (`rio.interfaces.ArmNode`) runs the cycle and the safety. Each tick
is one SYNC READ of the state block (servo error bits stop the arm: goal = present, then `ServoFault`
naming the servo, which ends the node and reaches every client) and one SYNC WRITE of the goal the
joint commander allows (interpolated, clipped to the calibrated limits, step-limited, held by the
watchdog). The SO-arm has no model here, so `eef_pose` is NaN unless a robot description is added.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio.interfaces import ArmNode

from ..models import ARM_JOINTS
from ..servo_node import ServoConfig, Servos


class So100Follower(ArmNode):
    class Config(ServoConfig, ArmNode.Config):
        defaults = {"rate_hz": Field(100.0, le=500)}  # bus cycles per second: one sync read + one write each
        p_gain: int = Field(16, ge=0, le=255, description="servo P gain (16 instead of the factory 32: less shaking)")
        i_gain: int = Field(0, ge=0, le=255)
        d_gain: int = Field(32, ge=0, le=255)
        max_torque: float = Field(1.0, gt=0, le=1.0, description="output torque limit, fraction of the maximum")

    def default_joint_names(self) -> list[str]:
        return list(ARM_JOINTS)

    def setup(self) -> None:
        super().setup()
        self.servos = Servos(self.config, "follower")
        n = self.dof
        self.example_data = {**self.example_data, "load": np.zeros(n), "temperature": np.zeros(n),
                             "voltage": np.zeros(n), "error": np.zeros(n, np.int64)}

    def open(self) -> None:
        c = self.config
        self.servos.open(self.joint_list).configure(c.p_gain, c.i_gain, c.d_gain, torque_limit=c.max_torque)

    def close(self) -> None:
        self.servos.close()

    def hardware_limits(self) -> Any:
        return self.servos.group.limits_rad()

    def set_enabled(self, enabled: bool) -> None:
        self.servos.group.set_torque(bool(enabled))  # on holds the present position: nothing jumps

    def read_joints(self) -> dict[str, Any]:
        s = self.servos.read(hold=self.enabled)
        return {"joint_pos": s["joint_pos"], "joint_vel": s["joint_vel"], "load": s["load"],
                "temperature": s["temperature"], "voltage": s["voltage"], "error": s["error"]}

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self.servos.group.write_rad(joint_pos)
