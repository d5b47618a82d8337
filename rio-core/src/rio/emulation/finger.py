"""A parallel gripper's fingers for emulators: they travel toward the goal at the commanded speed and
stop where an object is, which is how real grippers report "object detected"."""

from __future__ import annotations

import time
from collections.abc import Callable


class FingerModel:
    """Opening in meters (0 = closed). `object_width` (m) places an object between the fingers: closing
    stops there and `object_detected` turns true, as a gripper's current-based detection does."""

    def __init__(self, max_width: float, speed: float = 0.1, clock: Callable[[], float] = time.monotonic):
        self.max_width = float(max_width)
        self.position = self.goal = float(max_width)
        self.speed = float(speed)  # m/s
        self.force = 0.0  # N, as commanded (reported back, not simulated)
        self.object_width: float | None = None
        self.clock = clock
        self._t = clock()

    def command(self, goal: float, speed: float | None = None, force: float | None = None) -> None:
        self.update()
        self.goal = min(max(float(goal), 0.0), self.max_width)
        if speed is not None:
            self.speed = max(float(speed), 1e-6)
        if force is not None:
            self.force = float(force)

    def update(self) -> float:
        """Bring the fingers up to now; returns the opening."""
        t = self.clock()
        dt, self._t = max(t - self._t, 0.0), t
        step = self.speed * dt
        delta = self.goal - self.position
        self.position += max(-step, min(step, delta))
        if self.object_width is not None and self.goal < self.object_width <= self.position + step + 1e-9:
            self.position = max(self.position, self.object_width)
        return self.position

    @property
    def moving(self) -> bool:
        self.update()
        return abs(self.goal - self.position) > 1e-5 and not self.object_detected

    @property
    def object_detected(self) -> bool:
        """Closing stopped on an object (opening outside the goal, at the object's width)."""
        return (self.object_width is not None and self.goal < self.object_width
                and abs(self.position - self.object_width) < 1e-6)
