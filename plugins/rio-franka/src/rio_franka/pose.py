"""The tool frame RIO speaks and the end-effector frame libfranka speaks.

libfranka reports and takes poses of its EE frame (`O_T_EE`), which is the flange (`F`) moved by the
end effector configured in Desk (`F_T_EE`, e.g. the Franka Hand's TCP). RIO's eef is the flange moved
by the station's `tcp_offset` (the frame of `robot_description()`), whatever Desk says: the state's
`F_T_EE` converts both ways, so a Desk setting never shifts RIO's poses. Poses are RIO's
`[x, y, z, qw, qx, qy, qz]`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rio.control import euler_to_quat, matrix_to_pose, pose_inv, pose_mul

_IDENTITY = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])


def offset_pose(tcp_offset: Sequence[float] | None) -> np.ndarray:
    """[x, y, z, roll, pitch, yaw] from the flange -> a pose (identity for None)."""
    if tcp_offset is None:
        return _IDENTITY.copy()
    x, y, z, r, p, yaw = (float(v) for v in tcp_offset)
    return np.array([x, y, z, *euler_to_quat(r, p, yaw)])


def as_pose(transform) -> np.ndarray:
    """A franky `Affine` (or libfranka's column-major 16 numbers) as a pose."""
    m = transform.matrix if hasattr(transform, "matrix") else np.asarray(transform, float).reshape(4, 4, order="F")
    return matrix_to_pose(np.asarray(m, dtype=np.float64))


def tool_pose(o_t_ee, f_t_ee, offset: np.ndarray) -> np.ndarray:
    """RIO's eef from the state: O_T_EE * EE_T_F * offset."""
    return pose_mul(pose_mul(as_pose(o_t_ee), pose_inv(as_pose(f_t_ee))), offset)


def ee_target(tool: np.ndarray, f_t_ee, offset: np.ndarray) -> np.ndarray:
    """libfranka's EE target for a RIO eef target: tool * offset^-1 * F_T_EE."""
    return pose_mul(pose_mul(tool, pose_inv(offset)), as_pose(f_t_ee))


def to_affine(pose: np.ndarray):
    """A pose as franky's `Affine` (translation, quaternion x, y, z, w)."""
    import franky

    return franky.Affine(np.asarray(pose[:3], float), np.array([pose[4], pose[5], pose[6], pose[3]], float))
