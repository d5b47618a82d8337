"""Rotations as unit quaternions `[w, x, y, z]` (scalar first, like `rio.interfaces` poses), rotation
vectors (axis * angle, rad) and 3x3 matrices.

Plain numpy on purpose: the control loop, drivers and tests use these on every tick, and they must
not pull in a kinematics library. A quaternion and its negative are the same rotation; functions
that return one pick `w >= 0` so results compare directly.
"""

from __future__ import annotations

import numpy as np

_EPS = 1e-12


def quat_normalize(q) -> np.ndarray:
    q = np.asarray(q, dtype=np.float64)
    n = np.linalg.norm(q)
    if not n > _EPS:
        raise ValueError(f"quaternion {q} has zero norm")
    q = q / n
    return -q if q[0] < 0 else q


def quat_conj(q) -> np.ndarray:
    q = np.asarray(q, dtype=np.float64)
    return np.array([q[0], -q[1], -q[2], -q[3]])


def quat_mul(a, b) -> np.ndarray:
    """Hamilton product `a * b` (apply b, then a)."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ])


def quat_rotate(q, v) -> np.ndarray:
    """Rotate vector(s) v (..., 3) by q."""
    return np.asarray(v, dtype=np.float64) @ quat_to_matrix(q).T


def rotvec_to_quat(rv) -> np.ndarray:
    """Exponential map: rotation vector (rad) -> unit quaternion."""
    rv = np.asarray(rv, dtype=np.float64)
    angle = float(np.linalg.norm(rv))
    if angle < 1e-9:  # second-order expansion keeps tiny rotations exact to float precision
        q = np.array([1.0 - angle * angle / 8.0, *(0.5 * rv)])
        return q / np.linalg.norm(q)
    axis = rv / angle
    return np.array([np.cos(angle / 2), *(np.sin(angle / 2) * axis)])


def quat_to_rotvec(q) -> np.ndarray:
    """Logarithm map: unit quaternion -> rotation vector with angle in [0, pi]."""
    q = quat_normalize(q)
    s = float(np.linalg.norm(q[1:]))
    if s < 1e-9:
        return 2.0 * q[1:]
    angle = 2.0 * np.arctan2(s, q[0])
    return q[1:] / s * angle


def quat_angle(a, b) -> float:
    """Angle (rad, in [0, pi]) of the rotation taking a to b."""
    d = abs(float(np.dot(quat_normalize(a), quat_normalize(b))))
    return 2.0 * float(np.arccos(min(d, 1.0)))


def quat_slerp(a, b, t: float) -> np.ndarray:
    """Spherical interpolation from a (t=0) to b (t=1) along the shorter arc."""
    a, b = quat_normalize(a), quat_normalize(b)
    if np.dot(a, b) < 0:
        b = -b
    rel = quat_mul(quat_conj(a), b)
    return quat_normalize(quat_mul(a, rotvec_to_quat(float(t) * quat_to_rotvec(rel))))


def quat_to_matrix(q) -> np.ndarray:
    w, x, y, z = quat_normalize(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def matrix_to_quat(m) -> np.ndarray:
    """3x3 rotation matrix -> unit quaternion (Shepperd's method: stable for every rotation)."""
    m = np.asarray(m, dtype=np.float64)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = 2.0 * np.sqrt(tr + 1.0)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    return quat_normalize(q)


def euler_to_quat(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Fixed-axis x-y-z (roll about x, then pitch about y, then yaw about z), as URDF `rpy`."""
    qx = rotvec_to_quat([roll, 0.0, 0.0])
    qy = rotvec_to_quat([0.0, pitch, 0.0])
    qz = rotvec_to_quat([0.0, 0.0, yaw])
    return quat_normalize(quat_mul(qz, quat_mul(qy, qx)))


def quat_to_euler(q) -> np.ndarray:
    """`[roll, pitch, yaw]` (fixed-axis x-y-z, the inverse of `euler_to_quat`); pitch in [-pi/2, pi/2].
    At pitch = +-pi/2 (gimbal lock) roll is 0 and yaw carries the whole rotation about z."""
    m = quat_to_matrix(q)
    pitch = float(np.arcsin(np.clip(-m[2, 0], -1.0, 1.0)))
    if abs(m[2, 0]) < 1.0 - 1e-9:
        return np.array([np.arctan2(m[2, 1], m[2, 2]), pitch, np.arctan2(m[1, 0], m[0, 0])])
    return np.array([0.0, pitch, np.arctan2(-m[0, 1], m[1, 1])])
