"""Build an IK solver from a robot description dict, the form an arm node hands out through its
`robot_description()` API, so a control loop can do IK for any arm without knowing its vendor:

    {"format": "mjcf" | "urdf", "xml": <model text>, "frame": <tool frame name>,
     "frame_type": "site" | "body" (MJCF only), "joints": [<arm joint names, in the arm's order>]}
"""

from __future__ import annotations

from typing import Any

from .base import IKSolver


def solver_from_description(desc: dict[str, Any], **options: Any) -> IKSolver:
    fmt = str(desc.get("format", "")).lower()
    if fmt == "mjcf":
        from .mink_solver import MinkSolver

        return MinkSolver(desc["xml"], desc["frame"], frame_type=desc.get("frame_type", "site"),
                          joints=desc.get("joints"), **options)
    if fmt == "urdf":
        from .pin_solver import PinocchioSolver

        return PinocchioSolver(desc["xml"], desc["frame"], joints=desc.get("joints"), **options)
    raise ValueError(f"unknown robot description format {fmt!r} (expected 'mjcf' or 'urdf')")
