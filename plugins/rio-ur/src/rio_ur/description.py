"""The robot description a UR arm hands out (`ArmNode.robot_description()`): the model's MJCF (written
from its DH table), its tool frame (the site `tcp` at the flange, or a site `tool` at the station's
`tcp_offset`), its joints in the controller's order and its home pose. RIO's shared kinematics
(`rio.kinematics.solver_from_description`) computes the eef from it and solves IK for `eef_control = "ik"`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rio.kinematics import mjcf_description, tool_pose_from_offset

from .mjcf import arm_mjcf
from .models import get_arm


def description(name: str, tcp_offset: Sequence[float] | None = None) -> dict[str, Any]:
    """RIO's robot description of UR model `name`; `tcp_offset` = [x, y, z (m), rx, ry, rz (rotation
    vector, rad)] from the flange, as the teach pendant's TCP setting writes it."""
    arm = get_arm(name)
    return mjcf_description(arm_mjcf(arm), arm.joint_names, arm.home,
                            tool_pose=tool_pose_from_offset(tcp_offset, "rotvec"))
