"""The robot description a Franka arm hands out (`ArmNode.robot_description()`): the model's MJCF,
its tool frame (the site `tcp`, libfranka's flange frame F), its joints in libfranka's order and the
ready pose. With it RIO's shared kinematics (`rio.kinematics.solver_from_description`)
computes the flange pose from the joints and solves joint targets for end-effector commands.

With a `tcp_offset` (the tool's centre point from the flange, e.g. `models.HAND_TCP` for the Franka
Hand) the frame is a site `tool` at that offset in the flange frame; the driver converts its
Cartesian targets with the same offset, so RIO's model and the robot agree on the eef."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rio.kinematics import mjcf_description, read_model, tool_pose_from_offset

from .models import get_arm


def description(name: str, tcp_offset: Sequence[float] | None = None) -> dict[str, Any]:
    """RIO's robot description of the Franka model `name` (a key of `rio_franka.models.ARMS`);
    `tcp_offset` = [x, y, z (m), roll, pitch, yaw (rad)] from the flange."""
    arm = get_arm(name)
    return mjcf_description(read_model(arm.mjcf_path), arm.joint_names, arm.home,
                            tool_pose=tool_pose_from_offset(tcp_offset, "rpy"))
