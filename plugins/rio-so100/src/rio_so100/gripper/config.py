"""Station-file fields of the jaw gripper."""

from __future__ import annotations

from typing import Literal

from pydantic import Field
from rio.config import DriverConfig

from ..models import GRIPPER


class GripperConfig(DriverConfig):
    port: str = Field(description='serial port of the arm\'s bus (the same as its follower\'s), or "virtual"')
    calibration: str = Field("default", description="the arm's calibration name (the jaw is one of its joints) "
                                                    "or a .json path")
    model: Literal["so100", "so101"] = "so100"
    joint: str = Field(GRIPPER, description="the jaw's joint name in the calibration")
    max_width: float = Field(0.06, gt=0, description="opening (m) reported at the calibrated open end")
    rate_hz: float = Field(50.0, gt=0, le=500)
    max_step_rad: float = Field(0.06, gt=0, description="largest jaw goal change per cycle (rad)")
    watchdog_s: float = Field(0.5, gt=0)
    max_torque: float = Field(0.5, gt=0, le=1.0, description="torque limit: a firm grasp stays under the overload "
                                                           "threshold instead of tripping it")
    baudrate: int = 1_000_000
    retries: int = Field(2, ge=0, le=10)
    disable_torque_on_close: bool = True


class So101GripperConfig(GripperConfig):
    model: Literal["so100", "so101"] = "so101"
