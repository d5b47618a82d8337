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
from rio.control.omni import OmniKinematics
from rio.interfaces.base import BaseNode


class FakeBase(BaseNode):
    class Config(BaseNode.Config):
        wheel_angles_deg: list[float] = Field([150.0, -90.0, 30.0], min_length=3,
                                              description="direction each wheel pushes the body (deg from x)")
        wheel_radius: float = Field(0.05, gt=0, description="wheel radius (m)")
        base_radius: float = Field(0.125, gt=0, description="wheel distance from the center (m)")
        frozen: bool = Field(False, description="ignore every command (motors off)")

    def default_wheel_names(self) -> list[str]:
        return [f"wheel{i + 1}" for i in range(len(self.config.wheel_angles_deg))]

    def setup(self) -> None:
        super().setup()
        c = self.config
        self.kinematics = OmniKinematics.from_degrees(c.wheel_angles_deg, c.wheel_radius, c.base_radius)
        if self.kinematics.n_wheels != self.n_wheels:
            raise ValueError(f"node '{self.name}': {self.n_wheels} wheel_names for {self.kinematics.n_wheels} "
                             "wheel_angles_deg")

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

    def body_twist_of(self, wheel_vel: np.ndarray) -> np.ndarray:
        return self.kinematics.to_body(wheel_vel)
