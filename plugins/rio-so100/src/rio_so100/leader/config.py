"""Station-file fields of the leader arm."""

from __future__ import annotations

from typing import Literal

from pydantic import Field
from rio.config import DriverConfig

from ..models import ARM_JOINTS, GRIPPER


class LeaderConfig(DriverConfig):
    port: str = Field(description='serial port of the leader arm\'s bus, or "virtual"')
    calibration: str = Field("default", description="calibration name (in $XDG_CONFIG_HOME/rio/calibration/"
                                                    "<model>-leader/) or a .json path")
    model: Literal["so100", "so101"] = "so100"
    joints: list[str] = Field(default_factory=lambda: list(ARM_JOINTS), description="arm joints, in order")
    gripper: str | None = Field(GRIPPER, description="the jaw joint (its opening is published as `gripper`), "
                                                     "or none")
    rate_hz: float = Field(100.0, gt=0, le=500)
    baudrate: int = 1_000_000
    retries: int = Field(2, ge=0, le=10)
    virtual_motion: Literal["none", "wave"] = Field("none", description='with port = "virtual": a scripted hand '
                                                                       'moving the arm ("wave")')


class So101LeaderConfig(LeaderConfig):
    model: Literal["so100", "so101"] = "so101"
