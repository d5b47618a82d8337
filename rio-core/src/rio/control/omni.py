"""Omni-wheel kinematics of a holonomic base: body twist <-> wheel speeds.

Each wheel is described by the direction it pushes the body when it spins forward (`angle`, rad, from
the body's x axis toward y) and its distance from the center (`base_radius`, the same for every wheel);
for a wheel mounted at angle phi around the center and rolling tangentially, that direction is
phi + 90 degrees. The contact point of wheel i moves at `cos(a_i) vx + sin(a_i) vy + R wz` along that
direction, and the wheel turns at that speed over its radius. A base of three or more wheels at
distinct angles is holonomic: the body twist is recovered from the wheel speeds by least squares (the
exact inverse for three wheels), which is also the base kind's odometry input.

This is the math of every omni-wheel base (three-wheel kiwi drives such as LeKiwi, four-wheel X drives);
a driver passes its geometry.
"""

from __future__ import annotations

import numpy as np


class OmniKinematics:
    def __init__(self, angles, wheel_radius: float, base_radius: float):
        self.angles = np.asarray(angles, dtype=np.float64).reshape(-1)
        if wheel_radius <= 0 or base_radius <= 0:
            raise ValueError(f"wheel_radius and base_radius must be > 0, got {wheel_radius}, {base_radius}")
        self.wheel_radius, self.base_radius = float(wheel_radius), float(base_radius)
        #: rows: wheel rim speed (m/s) per unit of vx, vy, wz
        self.matrix = np.stack([np.cos(self.angles), np.sin(self.angles),
                                np.full(self.angles.size, self.base_radius)], axis=1)
        if np.linalg.matrix_rank(self.matrix) < 3:
            raise ValueError(f"wheel angles {np.degrees(self.angles).round(1).tolist()} deg do not make a holonomic "
                             "base (need three or more wheels pushing in distinct directions)")
        self._inverse = np.linalg.pinv(self.matrix)

    @classmethod
    def from_degrees(cls, angles_deg, wheel_radius: float, base_radius: float) -> OmniKinematics:
        return cls(np.radians(np.asarray(angles_deg, dtype=np.float64)), wheel_radius, base_radius)

    @property
    def n_wheels(self) -> int:
        return int(self.angles.size)

    def to_wheels(self, twist) -> np.ndarray:
        """Body twist `[vx, vy, wz]` (m/s, rad/s) -> each wheel's angular speed (rad/s)."""
        return self.matrix @ np.asarray(twist, dtype=np.float64).reshape(3) / self.wheel_radius

    def to_body(self, wheel_speeds) -> np.ndarray:
        """Wheel angular speeds (rad/s) -> body twist `[vx, vy, wz]` (least squares over the wheels)."""
        return self._inverse @ (np.asarray(wheel_speeds, dtype=np.float64).reshape(-1) * self.wheel_radius)
