"""Station-file fields of the follower arm (the node's constructor arguments)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field
from rio.config import DriverConfig

from ..models import ARM_JOINTS


class FollowerConfig(DriverConfig):
    port: str = Field(description='serial port of the arm\'s bus (e.g. /dev/ttyACM0), or "virtual" for an '
                                  'emulated arm')
    calibration: str = Field("default", description="calibration name (in $XDG_CONFIG_HOME/rio/calibration/"
                                                    "<model>-follower/) or a .json path")
    model: Literal["so100", "so101"] = "so100"
    joints: list[str] = Field(default_factory=lambda: list(ARM_JOINTS),
                              description="joints this node drives, in command order")
    rate_hz: float = Field(100.0, gt=0, le=500, description="bus cycles per second (one sync read + one sync write)")
    max_step_rad: float = Field(0.05, gt=0, description="largest goal change per cycle (rad)")
    watchdog_s: float = Field(0.5, gt=0, description="hold position when no command came for this long (s)")
    p_gain: int = Field(16, ge=0, le=255, description="servo P gain (16 instead of the factory 32: less shaking)")
    i_gain: int = Field(0, ge=0, le=255)
    d_gain: int = Field(32, ge=0, le=255)
    max_torque: float = Field(1.0, gt=0, le=1.0, description="output torque limit, fraction of the servo's maximum")
    baudrate: int = 1_000_000
    retries: int = Field(2, ge=0, le=10, description="retries of a failed exchange before it is an error")
    disable_torque_on_close: bool = Field(True, description="release the arm when the node stops (it will sag)")


class So101FollowerConfig(FollowerConfig):
    model: Literal["so100", "so101"] = "so101"
