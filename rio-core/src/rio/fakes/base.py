"""A fake omni-wheel base: the `rio.fake_base` driver.

Its wheels turn at once at the speeds the kind's commander writes (no slip, no motor lag), so what a test
sees is exactly the kind's safety (speed and acceleration limits, the stop watchdog) and its odometry;
`frozen` makes it ignore commands, as a base with its motors off would, so a workflow's checks can be
seen to fail.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.interfaces.base import OmniBaseNode


class FakeBase(OmniBaseNode):
    class Config(OmniBaseNode.Config):
        frozen: bool = Field(False, description="ignore every command (motors off)")

    def open(self) -> None:
        self.pos, self.vel = np.zeros(self.n_wheels), np.zeros(self.n_wheels)
        self._t = clock.now()
        #: every twist written, for tests
        self.written: list[np.ndarray] = []

    def read_wheels(self) -> dict[str, Any]:
        t = clock.now()
        self.pos = self.pos + self.vel * max(t - self._t, 0.0)
        self._t = t
        return {"wheel_pos": self.pos.copy(), "wheel_vel": self.vel.copy()}

    def write_twist(self, twist: np.ndarray) -> None:
        self.written.append(np.array(twist, dtype=np.float64))
        if not self.config.frozen:
            self.read_wheels()  # the wheels turned at the old speed until now
            self.vel = self.kinematics.to_wheels(twist)

    def set_enabled(self, enabled: bool) -> None:
        if not enabled:
            self.read_wheels()
            self.vel = np.zeros(self.n_wheels)  # torque off: a fake base on carpet rolls to a stop at once

