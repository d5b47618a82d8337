"""Rigid transforms as 7-vectors `[x, y, z, qw, qx, qy, qz]` (meters, unit quaternion), the pose
layout of every RIO arm, plus 4x4 matrices and twists `[vx, vy, vz, wx, wy, wz]` (m/s, rad/s).

Twists used by teleoperation are expressed in the robot's base frame and applied about the current
end-effector position: translating moves the tool point, rotating turns the tool about itself (what
a person holding a SpaceMouse expects), not about the base origin.
"""

from __future__ import annotations

import numpy as np

from rio.control.rotations import (
    matrix_to_quat,
    quat_angle,
    quat_conj,
    quat_mul,
    quat_normalize,
    quat_rotate,
    quat_slerp,
    quat_to_matrix,
    quat_to_rotvec,
    rotvec_to_quat,
)

IDENTITY = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])


def as_pose(p) -> np.ndarray:
    """Validate and normalize a 7-vector pose (copy)."""
    p = np.asarray(p, dtype=np.float64).reshape(-1)
    if p.shape != (7,):
        raise ValueError(f"a pose has 7 values [x, y, z, qw, qx, qy, qz], got {p.size}")
    return np.concatenate([p[:3], quat_normalize(p[3:])])


def pose_to_matrix(p) -> np.ndarray:
    p = as_pose(p)
    t = np.eye(4)
    t[:3, :3] = quat_to_matrix(p[3:])
    t[:3, 3] = p[:3]
    return t


def matrix_to_pose(t) -> np.ndarray:
    t = np.asarray(t, dtype=np.float64)
    return np.concatenate([t[:3, 3], matrix_to_quat(t[:3, :3])])


def pose_mul(a, b) -> np.ndarray:
    """Compose: `a * b` (b expressed in a's frame)."""
    a, b = as_pose(a), as_pose(b)
    return np.concatenate([a[:3] + quat_rotate(a[3:], b[:3]), quat_normalize(quat_mul(a[3:], b[3:]))])


def pose_inv(a) -> np.ndarray:
    a = as_pose(a)
    qi = quat_conj(a[3:])
    return np.concatenate([-quat_rotate(qi, a[:3]), qi])


def pose_error(a, b) -> tuple[float, float]:
    """(position distance m, rotation angle rad) between two poses."""
    a, b = as_pose(a), as_pose(b)
    return float(np.linalg.norm(a[:3] - b[:3])), quat_angle(a[3:], b[3:])


def pose_interp(a, b, t: float) -> np.ndarray:
    """Straight line in position, slerp in orientation; t in [0, 1]."""
    a, b = as_pose(a), as_pose(b)
    return np.concatenate([a[:3] + float(t) * (b[:3] - a[:3]), quat_slerp(a[3:], b[3:], t)])


def apply_twist(pose, twist, dt: float) -> np.ndarray:
    """Move `pose` by `twist` (base frame; rotation about the tool point) for `dt` seconds."""
    p = as_pose(pose)
    tw = np.asarray(twist, dtype=np.float64).reshape(6)
    q = quat_normalize(quat_mul(rotvec_to_quat(tw[3:] * dt), p[3:]))
    return np.concatenate([p[:3] + tw[:3] * dt, q])


def twist_between(a, b, dt: float) -> np.ndarray:
    """The twist that `apply_twist` needs to take pose a to pose b in dt seconds."""
    a, b = as_pose(a), as_pose(b)
    rot = quat_to_rotvec(quat_mul(b[3:], quat_conj(a[3:])))
    return np.concatenate([(b[:3] - a[:3]) / dt, rot / dt])
