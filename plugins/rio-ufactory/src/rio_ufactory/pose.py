"""xArm poses `[x, y, z (mm), roll, pitch, yaw (rad)]` to and from RIO's `[x, y, z (m), qw, qx, qy, qz]`.

The controller's roll/pitch/yaw is R = Rz(yaw) Ry(pitch) Rx(roll) (fixed-axis x-y-z, tool pointing down
is roll = pi), core's `euler_to_quat` / `quat_to_euler`; with `axis_angle` the orientation is a rotation
vector `[rx, ry, rz]` (rad) instead, as the SDK's `*_aa` calls send it."""

from __future__ import annotations

import numpy as np

from rio.control import euler_to_quat, quat_to_euler, quat_to_rotvec, rotvec_to_quat


def from_xarm(p, axis_angle: bool = False) -> np.ndarray:
    p = np.asarray(p, dtype=np.float64)
    q = rotvec_to_quat(p[3:6]) if axis_angle else euler_to_quat(*p[3:6])
    return np.concatenate([p[:3] / 1000.0, q])


def to_xarm(pose, axis_angle: bool = False) -> list[float]:
    pose = np.asarray(pose, dtype=np.float64)
    rot = quat_to_rotvec(pose[3:7]) if axis_angle else quat_to_euler(pose[3:7])
    return [*(pose[:3] * 1000.0).tolist(), *rot.tolist()]
