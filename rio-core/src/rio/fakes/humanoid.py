"""A test humanoid upper body (model, joint table, home) and the fake humanoids built on it."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio import interfaces as ifc
from rio.fakes.arms import at_home, numbered_joints
from rio.fakes.hands import vec_text


class FakeHumanoid(ifc.HumanoidNode):
    """Humanoid standing still (identity base orientation) whose joints follow their goal."""

    class Config(ifc.HumanoidNode.Config):
        defaults = {"rate_hz": 100.0, "max_step_rad": 0.5}
        dof: int = Field(12, ge=1, le=128, description="number of joints (named joint1..N)")

    def default_joint_names(self) -> list[str]:
        return numbered_joints(self.config.dof)

    def open(self) -> None:
        self.q = at_home(self)

    def read_joints(self) -> dict[str, Any]:
        return {"joint_pos": self.q.copy(), "joint_vel": np.zeros(self.dof),
                "base_quat": np.array([1.0, 0.0, 0.0, 0.0]), "base_ang_vel": np.zeros(3)}

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self.q = np.array(joint_pos, dtype=np.float64)


_X, _Y, _Z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
#: The test humanoid's limbs, root to tip: ((joint, axis, range) at one body..., length of its link). Limbs hang
#: straight down at zero; a negative elbow angle swings the forearm forward. Ranges are the left side's.
_LEG = (((("hip_pitch", _Y, (-1.5, 1.0)), ("hip_roll", _X, (-0.3, 0.5))), 0.40), ((("knee", _Y, (0.0, 2.2)),), 0.40))
_ARM = (((("shoulder_pitch", _Y, (-2.5, 1.5)), ("shoulder_roll", _X, (-0.3, 2.2)), ("shoulder_yaw", _Z, (-2.0, 2.0))),
         0.25),
        ((("elbow", _Y, (-2.5, 0.1)),), 0.22),
        ((("wrist_yaw", _Z, (-2.5, 2.5)), ("wrist_pitch", _Y, (-1.4, 1.4)), ("wrist_roll", _X, (-1.4, 1.4))), 0.05))
_WAIST = ("waist_yaw", _Z, (-1.0, 1.0))
_ARM_HOME = {"shoulder_pitch": -0.3, "shoulder_roll": 0.15, "elbow": -1.4}
_SIDES = (("left", 1.0), ("right", -1.0))


def _limb_joints(side: str, sign: float, limb: Any) -> list[tuple[str, Any, tuple[float, float]]]:
    """(name, axis, range) of one limb's joints; roll ranges mirror on the right (a limb rolls outward on
    both sides), the others are alike."""
    out = []
    for joints, _ in limb:
        for name, ax, (lo, hi) in joints:
            out.append((f"{side}_{name}", ax, (-hi, -lo) if sign < 0 and "roll" in name else (lo, hi)))
    return out


def _upper_body_table() -> list[tuple[str, Any, tuple[float, float]]]:
    legs = [j for s, k in _SIDES for j in _limb_joints(s, k, _LEG)]
    arms = [j for s, k in _SIDES for j in _limb_joints(s, k, _ARM)]
    return [*legs, _WAIST, *arms]  # the model's own order: pelvis's subtree depth first


def upper_body_joints() -> list[str]:
    return [n for n, _, _ in _upper_body_table()]


def upper_body_limits() -> tuple[list[float], list[float]]:
    table = _upper_body_table()
    return [r[0] for _, _, r in table], [r[1] for _, _, r in table]


def upper_body_home() -> list[float]:
    """Elbows bent, forearms forward: both wrists in front of the torso, away from singularities."""
    out = []
    for joint in upper_body_joints():
        side, _, name = joint.partition("_")
        value = _ARM_HOME.get(name, 0.0) if side in ("left", "right") else 0.0
        out.append(0.0 - value if side == "right" and "roll" in name else value)
    return out


def _limb_mjcf(side: str, sign: float, attach: Any, limb: Any, end: str = "") -> str:
    xml, pos, joints = "", attach, iter(_limb_joints(side, sign, limb))
    for body_joints, length in limb:
        xml += f'<body name="{side}_{body_joints[0][0]}_link" pos="{vec_text(pos)}">'
        for _ in body_joints:
            name, ax, (lo, hi) = next(joints)
            xml += f'<joint name="{name}" axis="{vec_text(ax)}" range="{lo} {hi}"/>'
        xml += f'<geom type="capsule" fromto="0 0 0 0 0 {-length}" size="0.03"/>'
        pos = (0.0, 0.0, -length)
    return xml + end.format(side=side, z=pos[2]) + "</body>" * len(limb)


def _upper_body_mjcf() -> str:
    legs = "".join(_limb_mjcf(s, k, (0.0, k * 0.09, -0.05), _LEG) for s, k in _SIDES)
    arms = "".join(_limb_mjcf(s, k, (0.0, k * 0.18, 0.38), _ARM, '<site name="{side}_wrist" pos="0 0 {z}"/>')
                   for s, k in _SIDES)
    name, ax, (lo, hi) = _WAIST
    return ('<mujoco model="rio-test-humanoid"><compiler angle="radian" autolimits="true"/><worldbody>'
            '<body name="pelvis" pos="0 0 0.95"><geom type="box" size="0.08 0.12 0.06"/>'
            f'{legs}<body name="torso" pos="0 0 0.08"><joint name="{name}" axis="{vec_text(ax)}" range="{lo} {hi}"/>'
            f'<geom type="capsule" fromto="0 0 0 0 0 0.35" size="0.1"/>{arms}</body></body></worldbody></mujoco>')


#: A humanoid's upper body on a fixed pelvis: two 3-joint legs (which upper-body IK must leave alone), a
#: waist yaw, and two 7-joint arms with `left_wrist` / `right_wrist` sites.
UPPER_BODY_MJCF = _upper_body_mjcf()


def upper_body_description() -> dict[str, Any]:
    """What a humanoid's `robot_description()` returns (rio.kinematics.multi_frame)."""
    return {"format": "mjcf", "xml": UPPER_BODY_MJCF, "joints": upper_body_joints(),
            "frames": {"left": "left_wrist", "right": "right_wrist"}, "frame_type": "site",
            "home": upper_body_home()}


class FakeModelHumanoid(ifc.HumanoidNode):
    """A humanoid standing still whose joints follow their goal and that ships its model
    (`UPPER_BODY_MJCF`), so its wrists can be teleoperated by IK (needs `rio-core[ik]`)."""

    class Config(ifc.HumanoidNode.Config):
        defaults = {"rate_hz": 100.0, "max_step_rad": 0.5}

    def default_joint_names(self) -> list[str]:
        return upper_body_joints()

    def default_home(self) -> list[float]:
        return upper_body_home()

    def hardware_limits(self) -> tuple[list[float], list[float]]:
        return upper_body_limits()

    def open(self) -> None:  # ready, elbows bent: not a singular pose
        home = self.config.home if self.config.home is not None else upper_body_home()
        self.q = np.asarray(home, dtype=np.float64)

    def read_joints(self) -> dict[str, Any]:
        return {"joint_pos": self.q.copy(), "joint_vel": np.zeros(self.dof),
                "base_quat": np.array([1.0, 0.0, 0.0, 0.0]), "base_ang_vel": np.zeros(3)}

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self.q = np.array(joint_pos, dtype=np.float64)

    def robot_description(self) -> dict[str, Any]:
        return {**upper_body_description(), "joints": list(self.joint_list)}

