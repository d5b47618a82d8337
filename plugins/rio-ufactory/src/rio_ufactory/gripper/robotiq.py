"""`ufactory.robotiq`: a Robotiq 2F-85 / 2F-140 on the xArm's tool RS-485, through the SDK's robotiq
methods (Modbus RTU frames relayed by the controller). For a Robotiq on a USB adapter or a UR arm,
use the `robotiq.*` drivers of rio-robotiq instead.

What a Robotiq is (strokes, the 0..255 scales, the fault classes) is rio-robotiq's knowledge; this
driver only carries it over the xArm's tool port (`pip install 'rio-ufactory[robotiq]'`). Object
detection is the gripper's own gOBJ flag (fingers stopped by contact).
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from ..faults import XArmError
from .base import ToolGripper


def _robotiq() -> Any:
    try:
        import rio_robotiq.faults as faults
        import rio_robotiq.models as models
    except ImportError as e:
        raise ImportError(f"the xArm's Robotiq driver needs rio-robotiq ({e}): pip install 'rio-ufactory[robotiq]'") \
            from None
    return models, faults


class XArmRobotiq(ToolGripper):
    class Config(ToolGripper.Config):
        defaults = {"max_width": 0.085}  # the 2F-85's; the model sets the stroke the kind clips to
        model: Literal["2f85", "2f140"] = Field("2f85", description="Robotiq model (sets the stroke)")
        speed: int = Field(255, ge=0, le=255, description="finger speed, Robotiq units 0..255")

    def setup(self) -> None:
        super().setup()
        self.robotiq, self.robotiq_faults = _robotiq()  # rio-robotiq's models and fault table
        self.spec = self.robotiq.ROBOTIQ_MODELS[self.config.model]
        self.width = self.spec.stroke  # the kind clips to [0, width]

    def start_device(self) -> None:
        assert self.conn is not None
        self.conn.call("robotiq_reset")
        self.conn.call("robotiq_set_activate", wait=True, timeout=5)

    def read_device(self) -> tuple[float, bool]:
        assert self.conn is not None
        self.conn.call("robotiq_get_status", number_of_registers=3)
        st = self.conn.api.robotiq_status
        code = int(st.get("gFLT", 0))
        if self.robotiq_faults.is_major(code):
            raise XArmError(self.conn.ip, "robotiq", f"{self.spec.label} fault 0x{code:02X}: "
                            f"{self.robotiq_faults.fault_meaning(code)}")
        return self.robotiq.robotiq_width(int(st.get("gPO", 0)), self.spec.stroke), st.get("gOBJ", 0) in (1, 2)

    def send_goal(self, width: float, force: float) -> None:
        assert self.conn is not None
        pos = self.robotiq.robotiq_counts(width, self.spec.stroke)
        f = 255 if np.isnan(force) else self.robotiq.scale_to_byte(force, *self.spec.force_range)
        self.conn.call("robotiq_set_position", pos, speed=self.config.speed, force=f, wait=False)
