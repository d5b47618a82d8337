"""A five-finger test hand (model, joint table, keypoints) and the fake hands built on it."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio import interfaces as ifc
from rio.fakes.arms import at_home, numbered_joints


class FakeHand(ifc.HandNode):
    """Hand whose joints follow their goal."""

    class Config(ifc.HandNode.Config):
        defaults = {"max_step_rad": 0.5}
        dof: int = Field(6, ge=1, le=64, description="number of joints (named joint1..N)")

    def default_joint_names(self) -> list[str]:
        return numbered_joints(self.config.dof)

    def open(self) -> None:
        self.q = at_home(self)

    def read_joints(self) -> dict[str, Any]:
        return {"joint_pos": self.q.copy()}

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self.q = np.array(joint_pos, dtype=np.float64)


# -- Fakes with kinematic models (retargeting: rio.kinematics.hand_retarget, multi_frame) ----------
# Plain capsules, no meshes. The models are written from small tables so the left hand is the right
# one mirrored by construction, and the node's joint names and limits come from the same tables.

def vec_text(v: Any) -> str:
    return " ".join(f"{float(x):.6g}" for x in v)


#: Fingers of the test hand: name, knuckle (x, y) in the palm frame, phalanx lengths (proximal,
#: intermediate, distal to the tip), about 1.1 times an adult's hand.
_FINGERS = (("index", (0.095, -0.026), (0.044, 0.026, 0.022)),
            ("middle", (0.100, 0.0), (0.049, 0.030, 0.023)),
            ("ring", (0.094, 0.021), (0.046, 0.028, 0.023)),
            ("pinky", (0.085, 0.040), (0.036, 0.020, 0.021)))
_FINGER_RANGES = {"abd": (-0.35, 0.35), "mcp": (-0.3, 1.57), "pip": (0.0, 1.9), "dip": (0.0, 1.4)}
_THUMB_CMC = (0.028, -0.020, 0.012)
_THUMB_LENGTHS = (0.048, 0.035, 0.030)  # metacarpal, proximal, distal to the tip
_THUMB_RANGES = {"cmc_abd": (-0.5, 0.8), "cmc_flex": (-0.3, 1.2), "mcp": (-0.2, 1.0), "ip": (-0.3, 1.4)}


def _thumb_axes() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The thumb's rest direction (forward, toward the radial side, a little palmar), its abduction axis
    (the palm normal made perpendicular to it) and its flexion axis (turning it toward the palm)."""
    d = np.array([0.75, -0.55, 0.30])
    d /= np.linalg.norm(d)
    abd = np.array([0.0, 0.0, 1.0]) - d[2] * d
    abd /= np.linalg.norm(abd)
    return d, abd, np.cross(d, abd)


def five_finger_hand_joints() -> list[str]:
    return [*(f"thumb_{j}" for j in _THUMB_RANGES), *(f"{f}_{j}" for f, _, _ in _FINGERS for j in _FINGER_RANGES)]


def five_finger_hand_limits() -> tuple[list[float], list[float]]:
    ranges = [*_THUMB_RANGES.values(), *(r for _ in _FINGERS for r in _FINGER_RANGES.values())]
    return [lo for lo, _ in ranges], [hi for _, hi in ranges]


def five_finger_hand_mjcf(side: str = "right") -> str:
    """A 20-joint five-finger hand, written in RIO's palm frame (x wrist to middle knuckle, z out of the
    palm, y = z x x) and mounted at an arbitrary pose, so users of the model must go through its `palm`
    site. The left hand mirrors the right across the palm's xz plane: positions flip y, joint axes
    (pseudo-vectors) flip x and z, so a joint's positive direction means the same motion on both."""
    if side not in ("right", "left"):
        raise ValueError(f"side {side!r}: write 'right' or 'left'")
    left = side == "left"
    flip_pos = np.array([1.0, -1.0, 1.0]) if left else np.ones(3)
    flip_axis = np.array([-1.0, 1.0, -1.0]) if left else np.ones(3)

    def pos(v: Any) -> str:
        return vec_text(flip_pos * np.asarray(v, dtype=np.float64))

    def axis(v: Any) -> str:
        return vec_text(flip_axis * np.asarray(v, dtype=np.float64))

    def joint(name: str, ax: Any, rng: tuple[float, float]) -> str:
        return f'<joint name="{name}" axis="{axis(ax)}" range="{rng[0]} {rng[1]}"/>'

    def capsule(length: float, d: Any = (1.0, 0.0, 0.0), r: float = 0.009) -> str:
        return f'<geom type="capsule" fromto="0 0 0 {pos(length * np.asarray(d))}" size="{r}"/>'

    flex = (0.0, -1.0, 0.0)  # turns x toward +z: the fingers curl toward the palm
    fingers = []
    for name, (kx, ky), (l1, l2, l3) in _FINGERS:
        r = _FINGER_RANGES
        fingers.append(
            f'<site name="{name}_knuckle" pos="{pos((kx, ky, 0.0))}" size="0.004"/>'
            f'<body name="{name}_proximal" pos="{pos((kx, ky, 0.0))}">'
            f'{joint(f"{name}_abd", (0, 0, 1), r["abd"])}{joint(f"{name}_mcp", flex, r["mcp"])}{capsule(l1)}'
            f'<body name="{name}_intermediate" pos="{pos((l1, 0, 0))}">{joint(f"{name}_pip", flex, r["pip"])}'
            f'{capsule(l2)}<site name="{name}_middle" size="0.004"/>'
            f'<body name="{name}_distal" pos="{pos((l2, 0, 0))}">{joint(f"{name}_dip", flex, r["dip"])}'
            f'{capsule(l3, r=0.008)}<site name="{name}_distal" size="0.004"/>'
            f'<site name="{name}_tip" pos="{pos((l3, 0, 0))}" size="0.004"/></body></body></body>')
    d, abd, tflex = _thumb_axes()
    (t1, t2, t3), r = _THUMB_LENGTHS, _THUMB_RANGES
    thumb = (f'<body name="thumb_metacarpal" pos="{pos(_THUMB_CMC)}">'
             f'{joint("thumb_cmc_abd", abd, r["cmc_abd"])}{joint("thumb_cmc_flex", tflex, r["cmc_flex"])}'
             f'{capsule(t1, d, 0.011)}<body name="thumb_proximal" pos="{pos(t1 * d)}">'
             f'{joint("thumb_mcp", tflex, r["mcp"])}{capsule(t2, d, 0.010)}<site name="thumb_knuckle" size="0.004"/>'
             f'<body name="thumb_distal" pos="{pos(t2 * d)}">{joint("thumb_ip", tflex, r["ip"])}'
             f'{capsule(t3, d)}<site name="thumb_distal" size="0.004"/>'
             f'<site name="thumb_tip" pos="{pos(t3 * d)}" size="0.004"/></body></body></body>')
    return (f'<mujoco model="rio-test-hand-{side}"><compiler angle="radian" autolimits="true"/><worldbody>'
            # the mount: fingers along world +y, palm facing world +x (any pose would do)
            f'<body name="hand" pos="0.01 -0.02 0.05" quat="0.5 0.5 0.5 0.5">'
            f'<geom type="box" pos="{pos((0.05, 0.006, 0.0))}" size="0.05 0.045 0.012"/>'
            f'<site name="palm" size="0.005"/>{thumb}{"".join(fingers)}</body></worldbody></mujoco>')


def five_finger_hand_keypoints() -> dict[str, str]:
    """HAND_JOINTS name -> site of the test hand: every joint a finger has past its metacarpal."""
    out = {"thumb-phalanx-proximal": "thumb_knuckle", "thumb-phalanx-distal": "thumb_distal",
           "thumb-tip": "thumb_tip"}
    for name, _, _ in _FINGERS:
        human = f"{name}-finger"
        out.update({f"{human}-phalanx-proximal": f"{name}_knuckle", f"{human}-phalanx-intermediate": f"{name}_middle",
                    f"{human}-phalanx-distal": f"{name}_distal", f"{human}-tip": f"{name}_tip"})
    return out


def five_finger_hand_description(side: str = "right") -> dict[str, Any]:
    """What a dexterous hand's `robot_description()` returns (rio.kinematics.hand_retarget)."""
    return {"format": "mjcf", "xml": five_finger_hand_mjcf(side), "joints": five_finger_hand_joints(),
            "keypoints": five_finger_hand_keypoints(), "palm": "palm", "side": side}


#: The right test hand (`five_finger_hand_mjcf("left")` is its mirror image).
FIVE_FINGER_HAND_MJCF = five_finger_hand_mjcf("right")


class FakeModelHand(ifc.HandNode):
    """A 20-joint five-finger hand that ships its model, so tracked human hands can be retargeted onto
    it (needs `rio-core[ik]`); its joints follow their goal."""

    class Config(ifc.HandNode.Config):
        defaults = {"max_step_rad": 0.5}
        side: Literal["right", "left"] = Field("right", description="which hand")

    def default_joint_names(self) -> list[str]:
        return five_finger_hand_joints()

    def hardware_limits(self) -> tuple[list[float], list[float]]:
        return five_finger_hand_limits()

    def open(self) -> None:
        self.q = at_home(self)

    def read_joints(self) -> dict[str, Any]:
        return {"joint_pos": self.q.copy()}

    def write_joints(self, joint_pos: np.ndarray) -> None:
        self.q = np.array(joint_pos, dtype=np.float64)

    def robot_description(self) -> dict[str, Any]:
        return {**five_finger_hand_description(self.config.side), "joints": list(self.joint_list)}

