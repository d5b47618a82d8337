"""The MJCF of each UR model, written from its DH table (`models.py`): one body per DH link, each
joint about its body's z axis, the flange as the site `tcp`. Simple capsules stand in for the links
(the model is for kinematics and a sim's collisions, not looks).

`arm_mjcf(model)` is the arm alone (what `robot_description()` hands out); `tool_xml` puts a tool
(e.g. rio-sim's parallel gripper) inside the flange body.
"""

from __future__ import annotations

import math

from .models import JOINT_NAMES, URModel

_RADIUS = (0.06, 0.055, 0.045, 0.04, 0.04, 0.035)


def _quat_x(alpha: float) -> str:
    return f"{math.cos(alpha / 2)!r} {math.sin(alpha / 2)!r} 0 0"


def arm_body(model: URModel, tool_xml: str = "", cls: str = "") -> str:
    """The nested bodies of the arm (base first), `tool_xml` inside the last link at the flange."""
    childclass = f' childclass="{cls}"' if cls else ""
    lines = [f'<body name="base"{childclass}>',
             '<geom name="base" type="cylinder" size="0.075 0.04" pos="0 0 0.04"/>']
    closing = ["</body>"]
    prev_a, prev_d, prev_alpha = 0.0, 0.0, 0.0
    for i, (a, d, alpha) in enumerate(zip(model.a, model.d, model.alpha, strict=True)):
        lo, hi = model.limits[i]
        pos = f"{prev_a!r} 0 {prev_d!r}"
        lines.append(f'<body name="link{i + 1}" pos="{pos}" quat="{_quat_x(prev_alpha)}">')
        lines.append(f'<joint name="{JOINT_NAMES[i]}" axis="0 0 1" range="{lo!r} {hi!r}"/>')
        # the link runs from this joint (origin) to the next one: along z by d, then along x by a
        r = _RADIUS[i]
        if d:
            lines.append(f'<geom type="capsule" fromto="0 0 0 0 0 {d!r}" size="{r}"/>')
        if a:
            lines.append(f'<geom type="capsule" fromto="0 0 {d!r} {a!r} 0 {d!r}" size="{r}"/>')
        prev_a, prev_d, prev_alpha = a, d, alpha
        closing.append("</body>")
    # the flange frame: the last DH transform, inside link6
    lines.append(f'<body name="flange" pos="{prev_a!r} 0 {prev_d!r}" quat="{_quat_x(prev_alpha)}">')
    lines.append('<site name="tcp" size="0.005"/>')
    lines.append(tool_xml)
    lines.append("</body>")
    return "\n".join(lines + closing)


def arm_mjcf(model: URModel) -> str:
    """A complete MJCF of the arm alone (no actuators: a kinematic model)."""
    return (f'<mujoco model="{model.name}">\n<compiler angle="radian" autolimits="true"/>\n'
            f'<default><geom contype="0" conaffinity="0" rgba="0.6 0.65 0.7 1"/></default>\n'
            f"<worldbody>\n{arm_body(model)}\n</worldbody>\n</mujoco>\n")
