"""`so100.gripper` / `so101.gripper`: an SO-arm's jaw servo as a gripper node of its own, so any
embodiment and policy treat it like every other gripper (opening in meters).

The jaw shares the arm's bus; this node opens the same port (transactions are serialised by the port
lock), owns only the jaw id and maps its calibrated range linearly to 0..`max_width` (range_min =
closed). Its torque is limited (`max_torque`) so holding an object stalls the jaw below the servo's
overload threshold; a real fault still stops the node with the servo named.
"""

from __future__ import annotations

from typing import Any

from pydantic import Field

from rio.interfaces import GripperNode

from ..models import GRIPPER
from ..servo_node import ServoConfig, Servos


class So100Gripper(GripperNode):
    class Config(ServoConfig, GripperNode.Config):
        defaults = {"max_width": 0.06, "max_step_m": 0.003}  # the opening at the calibrated open end
        joint: str = Field(GRIPPER, description="the jaw's joint name in the calibration")
        max_torque: float = Field(0.5, gt=0, le=1.0, description="torque limit: a firm grasp stays under the "
                                                               "overload threshold instead of tripping it")

    def setup(self) -> None:
        super().setup()
        self.servos = Servos(self.config, "follower")  # the jaw is calibrated with the follower arm
        self.example_data = {**self.example_data, "load": 0.0, "temperature": 0.0, "error": 0}

    def open(self) -> None:
        group = self.servos.open([self.config.joint])
        self.cal = group.cal[0]
        group.configure(torque_limit=self.config.max_torque)

    def close(self) -> None:
        self.servos.close()

    def set_enabled(self, enabled: bool) -> None:
        self.servos.group.set_torque(bool(enabled))  # on holds the present position: nothing jumps

    def read_width(self) -> dict[str, Any]:
        s = self.servos.read(hold=self.enabled)
        return {"width": self.cal.fraction(s["steps"][0]) * self.width, "load": float(s["load"][0]),
                "temperature": float(s["temperature"][0]), "error": int(s["error"][0])}

    def write_width(self, width: float, force: float) -> None:
        self.servos.group.write_rad([self.cal.to_rad(self.cal.from_fraction(width / self.width))])
