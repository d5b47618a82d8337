"""Writes the MJCF models in `assets/` from Kinova's DH tables (`dh.py`): one body per joint, placed at
the DH frame before it, turning about its own z axis; the next body at Rz(offset) Tz(d) Tx(a) Rx(alpha).
Capsules between joint origins (no meshes), position actuators, and the site `tcp` at the last DH frame
(the flange, z out of it). Run `python -m rio_kinova.mjcf` after changing a table; a test checks the
shipped files are what this writes and that MuJoCo's kinematics equal `dh.fk`. `arm_body` (the bodies
alone, a gripper inside the flange) also wrote rio-sim's `assets/gen3.xml`, once.
"""

from __future__ import annotations

import math

import numpy as np

from .dh import DH
from .models import ARMS, ArmModel

_F = "{:.6g}"


def _vec(v) -> str:
    return " ".join(_F.format(0.0 if abs(x) < 1e-12 else float(x)) for x in v)


def _quat(offset: float, alpha: float) -> np.ndarray:
    qz = np.array([math.cos(offset / 2), 0.0, 0.0, math.sin(offset / 2)])
    qx = np.array([math.cos(alpha / 2), math.sin(alpha / 2), 0.0, 0.0])
    w1, x1, y1, z1 = qz
    w2, x2, y2, z2 = qx
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def _placement(p: DH) -> str:
    pos = (p.a * math.cos(p.offset), p.a * math.sin(p.offset), p.d)
    return f'pos="{_vec(pos)}" quat="{_vec(_quat(p.offset, p.alpha))}"'


def _range(lo: float, hi: float) -> str:
    return "" if math.isinf(lo) else f' range="{lo:.6f} {hi:.6f}"'


def arm_body(arm: ArmModel, depth: int = 2, tool: tuple[str, ...] = (), continuous_range: float | None = None,
             link_attrs: str = "") -> list[str]:
    """The arm's bodies as MJCF lines, from `<body name="base">` (indented `depth` levels, class `arm.name`)
    to the flange, whose site "tcp" is followed by the `tool` lines (a gripper). Continuous joints get
    `range="-r r"` with `continuous_range` (a simulator's hard stop; None: unlimited, as in `assets/`);
    `link_attrs` goes on every moving body (e.g. ' gravcomp="1"'). Shared by `render` and by the arms
    other packages write from Kinova's tables (rio-sim's gen3.xml), so both have these kinematics."""
    radius = 0.03 if arm.name == "gen3_lite" else 0.04
    lines = [f'{"  " * depth}<body name="base" childclass="{arm.name}">',
             f'{"  " * (depth + 1)}<geom name="base" type="cylinder" size="0.045 0.05" pos="0 0 0.05"/>']
    first = depth + 1
    if arm.dh_base is not None:
        lines.append(f'{"  " * first}<body name="dh_base" {_placement(arm.dh_base)}>')
        first += 1
    lines.append(f'{"  " * first}<body name="link_1"{link_attrs}>')
    for i, (p, name, (lo, hi)) in enumerate(zip(arm.dh, arm.joint_names, arm.limits, strict=True)):
        inner = "  " * (first + i + 1)
        cont = math.isinf(lo) and continuous_range is not None
        span = f' range="{-continuous_range:.6f} {continuous_range:.6f}"' if cont else _range(lo, hi)
        lines.append(f'{inner}<joint name="{name}" axis="0 0 1"{span}/>')
        lines.append(f'{inner}<geom type="sphere" size="{radius * 1.1:.3g}"/>')
        end = (p.a * math.cos(p.offset), p.a * math.sin(p.offset), p.d)
        if np.linalg.norm(end) > 1e-3:
            lines.append(f'{inner}<geom type="capsule" fromto="0 0 0 {_vec(end)}" size="{radius}"/>')
        child = f"link_{i + 2}" if i + 1 < arm.dof else "flange"
        lines.append(f'{inner}<body name="{child}" {_placement(p)}{link_attrs}>')
    pad = "  " * (first + arm.dof + 1)
    lines.append(f'{pad}<site name="tcp" size="0.01" rgba="1 0.3 0.3 0.6" group="4"/>')
    lines += [pad + t for t in tool]
    lines += ["  " * k + "</body>" for k in range(first + arm.dof, depth - 1, -1)]
    return lines


def render(arm: ArmModel) -> str:
    lines = [f"<!-- Kinova {arm.label}, arm only, written by rio_kinova.mjcf from Kinova's published DH table",
             "     (rio_kinova.dh). Joints turn about their body's z axis, 0 rad at the arm's zero; continuous",
             "     joints are unlimited. The site \"tcp\" is the flange frame (z out of it). Do not edit: regenerate",
             "     with `python -m rio_kinova.mjcf`. -->",
             f'<mujoco model="{arm.name}">',
             '  <compiler angle="radian" autolimits="true"/>',
             '  <option timestep="0.002" integrator="implicitfast"/>',
             "  <default>",
             f'    <default class="{arm.name}">',
             '      <joint damping="5" armature="0.1"/>',
             '      <position kp="800" dampratio="1" forcerange="-100 100"/>',
             '      <geom contype="2" conaffinity="1" density="800" rgba="0.3 0.3 0.32 1"/>',
             "    </default>",
             "  </default>",
             "  <worldbody>",
             *arm_body(arm),
             "  </worldbody>",
             "  <actuator>"]
    for name, (lo, hi) in zip(arm.joint_names, arm.limits, strict=True):
        ctrl = "" if math.isinf(lo) else f' ctrlrange="{lo:.6f} {hi:.6f}"'
        lines.append(f'    <position name="{name}" joint="{name}" class="{arm.name}"{ctrl}/>')
    lines += ["  </actuator>", "</mujoco>", ""]
    return "\n".join(lines)


def main() -> None:
    for arm in ARMS.values():
        arm.mjcf_path.write_text(render(arm), encoding="utf-8")
        print(f"wrote {arm.mjcf_path}")


if __name__ == "__main__":
    main()
