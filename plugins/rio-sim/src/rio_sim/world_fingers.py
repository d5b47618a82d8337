"""The fingers of a running world's arm as a `rio.emulation.FingerModel`, for device emulators whose
gripper is simulated (the xArm and UR emulators with a sim backend): commands become width targets at
the commanded speed, the opening is read back, and closing that stalls short of its goal is an object."""

from __future__ import annotations

import time

from rio import clock
from rio.emulation import FingerModel

#: A width target reaches the world at least this far ahead (s).
LEAD_S = 0.02


class SimFingers(FingerModel):
    """A `FingerModel` whose fingers are the world's: commands become width targets at the commanded
    speed, the opening is read back; closing that stalls short of the goal is an object."""

    def __init__(self, world_arm, speed: float = 0.1):
        self.arm = world_arm
        super().__init__(world_arm.max_width, speed=speed)
        self._last = (time.monotonic(), self.arm.finger_width())
        self.position = self.goal = self._last[1]
        self._t_arrive = 0.0
        self._speed_seen = 0.0

    def command(self, goal: float, speed: float | None = None, force: float | None = None) -> None:
        super().command(goal, speed, force)
        width = self.arm.finger_width()
        travel = abs(self.goal - width) / max(self.speed, 1e-6)
        self._t_arrive = time.monotonic() + travel
        self.arm.command_width(self.goal, clock.now() + max(travel, LEAD_S))

    def update(self) -> float:
        now, width = time.monotonic(), self.arm.finger_width()
        t0, w0 = self._last
        if now - t0 > 0.05:
            self._speed_seen = abs(width - w0) / (now - t0)
            self._last = (now, width)
        self.position = width
        return width

    @property
    def moving(self) -> bool:
        self.update()
        return abs(self.goal - self.position) > 1e-3 and not self.object_detected

    @property
    def object_detected(self) -> bool:
        self.update()
        stalled = time.monotonic() > self._t_arrive + 0.1 and self._speed_seen < 0.002
        return self.goal < self.position - 2e-3 and stalled
