"""`ufactory.bio_gripper`: the UFACTORY BIO Gripper G2 on the tool RS-485.

Its position is the jaw distance in millimetres (71 closed .. 150 open); RIO's opening is measured from
closed, so 0 .. 0.079 m. The gripper reports a "catch" state when its fingers stopped on an object.
"""

from __future__ import annotations

import numpy as np
from pydantic import Field

from .base import ToolGripper

CLOSED_MM, OPEN_MM = 71.0, 150.0
CATCH = 2  # status & 0x03


class BioGripper(ToolGripper):
    class Config(ToolGripper.Config):
        defaults = {"max_width": (OPEN_MM - CLOSED_MM) / 1000.0}
        speed: int = Field(2000, ge=500, le=4500, description="finger speed (pulses/s)")

    def enable_device(self, on: bool) -> None:
        assert self.conn is not None
        self.conn.call("set_bio_gripper_enable", on, wait=True, timeout=3)

    def read_device(self) -> tuple[float, bool]:
        assert self.conn is not None
        mm = float(self.conn.call("get_bio_gripper_g2_position"))
        status = int(self.conn.call("get_bio_gripper_status"))
        return max(mm - CLOSED_MM, 0.0) / 1000.0, (status & 0x03) == CATCH

    def send_goal(self, width: float, force: float) -> None:
        assert self.conn is not None
        pct = 100 if np.isnan(force) else int(np.clip(force, 1, 100))
        self.conn.call("set_bio_gripper_g2_position", CLOSED_MM + width * 1000.0, speed=self.config.speed,
                      force=pct, wait=False)
