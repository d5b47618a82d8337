"""The robot description a UR arm hands out (`ArmNode.robot_description()`): the model's MJCF (written
from its DH table), its tool frame (the site `tcp` at the flange, or a site `tool` at the station's
`tcp_offset`), its joints in the controller's order and its home pose. RIO's shared kinematics
(`rio.kinematics.solver_from_description`) computes the eef from it and solves IK for `eef_control = "ik"`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rio.control import rotvec_to_quat

from .mjcf import arm_mjcf
from .models import get_arm

_TCP_SITE = '<site name="tcp" size="0.005"/>'


def description(name: str, tcp_offset: Sequence[float] | None = None) -> dict[str, Any]:
    """RIO's robot description of UR model `name`; `tcp_offset` = [x, y, z (m), rx, ry, rz (rotation
    vector, rad)] from the flange, as the teach pendant's TCP setting writes it."""
    arm = get_arm(name)
    xml, frame = arm_mjcf(arm), "tcp"
    if tcp_offset is not None and any(tcp_offset):
        x, y, z = (float(v) for v in tcp_offset[:3])
        q = rotvec_to_quat(tcp_offset[3:])
        tool = f'<site name="tool" pos="{x!r} {y!r} {z!r}" quat="{" ".join(repr(float(v)) for v in q)}"/>'
        xml, frame = xml.replace(_TCP_SITE, _TCP_SITE + tool), "tool"
    return {"format": "mjcf", "xml": xml, "frame": frame, "frame_type": "site",
            "joints": arm.joint_names, "home": list(arm.home)}
