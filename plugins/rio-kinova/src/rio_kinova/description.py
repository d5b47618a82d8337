"""The robot description a Kinova arm hands out (`ArmNode.robot_description()`): the model's MJCF, its tool
frame (the site `tcp`, the flange), its joints in the base's order and Kinova's Home pose. With it RIO's
shared kinematics (`rio.kinematics.solver_from_description`) computes the flange pose from the joints and
solves joint targets for end-effector commands.

With a `tcp_offset` (the tool's centre point from the flange, e.g. a Robotiq 2F-85's fingertips at
0.12 m) the frame is a site `tool` at that offset in the flange frame."""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache
from typing import Any

from rio.control import euler_to_quat
from rio.kinematics import mjcf_description

from .models import get_arm


@cache
def _xml(name: str) -> str:
    return get_arm(name).mjcf_path.read_text(encoding="utf-8")


def description(name: str, tcp_offset: Sequence[float] | None = None) -> dict[str, Any]:
    """RIO's robot description of the Kinova model `name` (a key of `rio_kinova.models.ARMS`);
    `tcp_offset` = [x, y, z (m), roll, pitch, yaw (rad)] from the flange."""
    arm = get_arm(name)
    tool = None
    if tcp_offset is not None and any(tcp_offset):
        tool = [*(float(v) for v in tcp_offset[:3]), *euler_to_quat(*(float(v) for v in tcp_offset[3:6]))]
    return mjcf_description(_xml(arm.name), arm.joint_names, arm.home, tool_pose=tool)
