"""`ufactory.robotiq`: a Robotiq 2F-85 / 2F-140 on the xArm's tool RS-485, through the SDK's robotiq
methods (Modbus RTU frames relayed by the controller). For a Robotiq on a USB adapter or a UR arm,
use the `robotiq.*` drivers of rio-robotiq instead.

Robotiq units: position 0 open .. 255 closed, speed and force 0..255. Object detection is the
gripper's own gOBJ flag (fingers stopped by contact).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from ..faults import XArmError
from .base import ToolGripper

_STROKE = {"2f85": 0.085, "2f140": 0.140}
_FORCE_MAX_N = {"2f85": 235.0, "2f140": 125.0}


class XArmRobotiq(ToolGripper):
    class Config(ToolGripper.Config):
        model: Literal["2f85", "2f140"] = Field("2f85", description="Robotiq model (sets the stroke)")
        max_width: float = Field(0.085, gt=0, description="full opening (m); set by the model")
        speed: int = Field(255, ge=0, le=255, description="finger speed, Robotiq units 0..255")

    def setup(self) -> None:
        super().setup()
        self.width = _STROKE[self.config.model]  # the kind clips to [0, width]

    def start_device(self) -> None:
        assert self.ctl is not None
        self.ctl.call("robotiq_reset")
        self.ctl.call("robotiq_set_activate", wait=True, timeout=5)

    def read_device(self) -> tuple[float, bool]:
        assert self.ctl is not None
        self.ctl.call("robotiq_get_status", number_of_registers=3)
        st = self.ctl.api.robotiq_status
        if st.get("gFLT", 0) in (0x08, 0x0A, 0x0B, 0x0C, 0x0D, 0x0E, 0x0F):
            raise XArmError(self.ctl.ip, "robotiq", f"Robotiq fault 0x{st['gFLT']:02X} (see rio-robotiq's README)")
        width = (255 - float(st.get("gPO", 0))) / 255.0 * self.width
        return width, st.get("gOBJ", 0) in (1, 2)

    def send_goal(self, width: float, force: float) -> None:
        assert self.ctl is not None
        pos = int(round(255 * (1.0 - width / self.width)))
        f = 255 if np.isnan(force) else int(np.clip(force / _FORCE_MAX_N[self.config.model] * 255, 0, 255))
        self.ctl.call("robotiq_set_position", pos, speed=self.config.speed, force=f, wait=False)
