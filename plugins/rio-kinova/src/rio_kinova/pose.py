"""Kinova poses `[x, y, z (m), theta_x, theta_y, theta_z (deg)]` to and from RIO's `[x, y, z (m), qw, qx, qy, qz]`.

The base reports and takes tool orientations as Euler angles in degrees, R = Rz(theta_z) Ry(theta_y)
Rx(theta_x) (fixed-axis x-y-z), which is core's `euler_to_quat` / `quat_to_euler` after the unit change."""

from __future__ import annotations

import math

import numpy as np

from rio.control import euler_to_quat, matrix_to_quat, quat_to_euler


def from_kinova(p) -> np.ndarray:
    p = np.asarray(p, dtype=np.float64)
    return np.concatenate([p[:3], euler_to_quat(*np.radians(p[3:6]))])


def to_kinova(pose) -> list[float]:
    pose = np.asarray(pose, dtype=np.float64)
    return [*pose[:3].tolist(), *np.degrees(quat_to_euler(pose[3:7])).tolist()]


def from_matrix(t: np.ndarray) -> list[float]:
    """A 4x4 transform as a Kinova pose (what the fake base reports from the DH model)."""
    q = matrix_to_quat(t[:3, :3])
    return [*t[:3, 3].tolist(), *(math.degrees(a) for a in quat_to_euler(q))]
