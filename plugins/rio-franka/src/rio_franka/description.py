"""The robot description a Franka arm hands out (`ArmNode.robot_description()`): the model's MJCF,
its tool frame (the site `tcp`, libfranka's flange frame F), its joints in libfranka's order and the
ready pose. With it RIO's shared kinematics (`rio.kinematics.solver_from_description`)
computes the flange pose from the joints and solves joint targets for end-effector commands.

With a `tcp_offset` (the tool's centre point from the flange, e.g. `models.HAND_TCP` for the Franka
Hand) the frame is a site `tool` at that offset in the flange frame; the driver converts its
Cartesian targets with the same offset, so RIO's model and the robot agree on the eef."""

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
    """RIO's robot description of the Franka model `name` (a key of `rio_franka.models.ARMS`);
    `tcp_offset` = [x, y, z (m), roll, pitch, yaw (rad)] from the flange."""
    arm = get_arm(name)
    tool = None
    if tcp_offset is not None and any(tcp_offset):
        tool = [*(float(v) for v in tcp_offset[:3]), *euler_to_quat(*(float(v) for v in tcp_offset[3:6]))]
    return mjcf_description(_xml(arm.name), arm.joint_names, arm.home, tool_pose=tool)
