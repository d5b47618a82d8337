"""Build an IK solver from a robot description dict, the form an arm node hands out through its
`robot_description()` API, so a control loop can do IK for any arm without knowing its vendor:

    {"format": "mjcf" | "urdf", "xml": <model text>, "frame": <tool frame name>,
     "frame_type": "site" | "body" (MJCF only), "joints": [<arm joint names, in the arm's order>]}
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache
from pathlib import Path
from typing import Any

from rio.kinematics.base import IKSolver


def mjcf_description(xml: str, joints: Sequence[str], home: Sequence[float] | None = None, *,
                     site: str = "tcp", tool_pose: Sequence[float] | None = None) -> dict[str, Any]:
    """The description of an arm whose MJCF has a flange site `site`. With `tool_pose` (the tool's centre
    point in the flange frame, `[x, y, z, qw, qx, qy, qz]`, e.g. a controller's TCP offset converted by the
    driver) the frame is a site `tool` added at that pose, so RIO's model and the controller agree on the
    end effector; vendors differ only in how they write the rotation."""
    frame = site
    if tool_pose is not None:
        pos = " ".join(repr(float(v)) for v in tool_pose[:3])
        quat = " ".join(repr(float(v)) for v in tool_pose[3:7])
        start = xml.index(f'<site name="{site}"')
        end = xml.index("/>", start) + 2
        xml, frame = f'{xml[:end]}<site name="tool" pos="{pos}" quat="{quat}"/>{xml[end:]}', "tool"
    desc: dict[str, Any] = {"format": "mjcf", "xml": xml, "frame": frame, "frame_type": "site",
                            "joints": list(joints)}
    if home is not None:
        desc["home"] = list(home)
    return desc


def tool_pose_from_offset(tcp_offset: Sequence[float] | None, rotation: str = "rpy") -> list[float] | None:
    """A controller's TCP offset `[x, y, z (m), a, b, c (rad)]` as `mjcf_description`'s `tool_pose`, or None
    for no offset (absent or all zero). `rotation` says how the vendor writes `a, b, c`: "rpy" (fixed-axis
    roll, pitch, yaw: UFACTORY, Franka, Kinova) or "rotvec" (a rotation vector: Universal Robots)."""
    from rio.control import euler_to_quat, rotvec_to_quat

    if tcp_offset is None or not any(tcp_offset):
        return None
    if rotation not in ("rpy", "rotvec"):
        raise ValueError(f"rotation '{rotation}': write 'rpy' or 'rotvec'")
    rot = [float(v) for v in tcp_offset[3:6]]
    quat = euler_to_quat(*rot) if rotation == "rpy" else rotvec_to_quat(rot)
    return [*(float(v) for v in tcp_offset[:3]), *(float(q) for q in quat)]


@cache
def read_model(path: Path) -> str:
    """A packaged model file's text, read once per process (descriptions are asked for often)."""
    return Path(path).read_text(encoding="utf-8")


def solver_from_description(desc: dict[str, Any], **options: Any) -> IKSolver:
    fmt = str(desc.get("format", "")).lower()
    if fmt == "mjcf":
        from rio.kinematics.mink_solver import MinkSolver

        return MinkSolver(desc["xml"], desc["frame"], frame_type=desc.get("frame_type", "site"),
                          joints=desc.get("joints"), **options)
    if fmt == "urdf":
        from rio.kinematics.pin_solver import PinocchioSolver

        return PinocchioSolver(desc["xml"], desc["frame"], joints=desc.get("joints"), **options)
    raise ValueError(f"unknown robot description format {fmt!r} (expected 'mjcf' or 'urdf')")
