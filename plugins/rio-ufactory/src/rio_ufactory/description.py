"""The robot description a UFACTORY arm hands out (`ArmNode.robot_description()`): the model's MJCF,
its tool frame (the site `tcp`, the flange with a zero TCP offset), its joints in the controller's
order and its home pose. With it RIO's shared kinematics (`rio.kinematics.solver_from_description`)
computes the flange pose from the joints and solves joint targets for end-effector commands.

With a `tcp_offset` (the tool's centre point from the flange, as set on the controller) the frame is a
site `tool` at that offset in the flange frame, so RIO's model and the controller agree on the eef."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rio.kinematics import mjcf_description, read_model, tool_pose_from_offset

from .models import get_arm


def description(name: str, tcp_offset: Sequence[float] | None = None) -> dict[str, Any]:
    """RIO's robot description of the UFACTORY model `name` (a key of `rio_ufactory.models.ARMS`);
    `tcp_offset` = [x, y, z (m), roll, pitch, yaw (rad)] from the flange."""
    arm = get_arm(name)
    return mjcf_description(read_model(arm.mjcf_path), arm.joint_names, arm.home,
                            tool_pose=tool_pose_from_offset(tcp_offset, "rpy"))
