"""Control utilities shared by drivers, teleoperation and policy deployment (numpy only).

- `rotations`, `se3`: quaternions (wxyz), rotation vectors, 7-vector poses, twists.
- `filters`: low-pass, One Euro, pose filter.
- `interpolators`: timed targets -> smooth values at the driver's rate.
- `teleop`: teleop modes, speed limits, twist -> end-effector target (or a mobile base's twist), buttons.
- `commander`, `twist_commander`: the safety between commands and hardware (joints and poses; a mobile
  base's body twist: speed and acceleration limits, stop watchdog).
- `omni`, `odometry`: omni-wheel kinematics (body twist <-> wheel speeds) and planar odometry (exact arcs).
"""

from rio.control.filters import LowPassFilter, OneEuroFilter, PoseFilter
from rio.control.interpolators import LinearInterpolator, PoseInterpolator, Waypoints
from rio.control.rotations import (
    euler_to_quat,
    matrix_to_quat,
    quat_angle,
    quat_conj,
    quat_mul,
    quat_normalize,
    quat_rotate,
    quat_slerp,
    quat_to_euler,
    quat_to_matrix,
    quat_to_rotvec,
    rotvec_to_quat,
)
from rio.control.se3 import (
    IDENTITY,
    apply_twist,
    as_pose,
    matrix_to_pose,
    pose_error,
    pose_interp,
    pose_inv,
    pose_mul,
    pose_to_matrix,
    twist_between,
)
from rio.control.teleop import (
    BUTTON_DISCARD,
    BUTTON_DONE,
    BUTTON_KEEP,
    BUTTON_MODE,
    ButtonEdges,
    ModeSwitch,
    TeleopMode,
    episode_verdict,
    gripper_opening,
    limit_twist,
    make_teleop_eef_cmd,
    mask_twist,
)

__all__ = [
    "LowPassFilter", "OneEuroFilter", "PoseFilter", "LinearInterpolator", "PoseInterpolator", "Waypoints",
    "euler_to_quat", "matrix_to_quat", "quat_angle", "quat_conj", "quat_mul", "quat_normalize", "quat_rotate",
    "quat_slerp", "quat_to_euler", "quat_to_matrix", "quat_to_rotvec", "rotvec_to_quat",
    "IDENTITY", "apply_twist", "as_pose", "matrix_to_pose", "pose_error", "pose_interp", "pose_inv", "pose_mul",
    "pose_to_matrix", "twist_between",
    "BUTTON_DISCARD", "BUTTON_DONE", "BUTTON_KEEP", "BUTTON_MODE", "ButtonEdges", "ModeSwitch", "TeleopMode",
    "episode_verdict", "gripper_opening", "limit_twist", "make_teleop_eef_cmd", "mask_twist",
]
