"""The Unitree G1 of rio-sim: what its drivers and scenes need to know about `assets/g1.xml` (29 DoF) and
`assets/g1_hands.xml` (with Dex3-1 hands); a scene turns the asset's torque motors into the joint servos
a teleoperated G1 runs (`rio_sim.humanoid_models.to_servos`, with the gains below). Both files are
generated from Unitree's URDF (see their header and `tools/g1_from_urdf.py`); joint and actuator names
and order are a contract shared with Unitree's SDK.

Servo gains (kp N m/rad, kd N m s/rad) are Unitree's own for upper-body teleoperation (xr_teleoperate's G1
arm controller): 300/3 on the hips, knees and waist (the joints it holds "locked"), 80/3 on the shoulders
and elbows (its "weak" 25 N m motors) and the ankles (it lists the ankle pitch as weak; the roll shares
its pair of 5020 motors), 40/1.5 on the wrists; the Dex3-1 fingers 1.5/0.2 (its hand controller). That
controller also sends each arm joint's gravity torque as a feed-forward; a mounted G1 here gets the same
from MuJoCo (`gravcomp` routed through the actuators, so it counts against their effort limits), for every
joint, so the held pose does not sag. A free-floating G1 gets none: gravity is its locomotion policy's
business.
"""

from __future__ import annotations

from functools import cache

from .robots import ASSETS

ASSET, HANDS_ASSET = "g1.xml", "g1_hands.xml"
#: The root body, on `FREE_JOINT` when the scene does not mount it.
BASE, FREE_JOINT = "pelvis", "floating_base_joint"

_LEG = ("hip_pitch", "hip_roll", "hip_yaw", "knee", "ankle_pitch", "ankle_roll")
_ARM = ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow", "wrist_roll", "wrist_pitch", "wrist_yaw")
#: Unitree's motor order (LowCmd/LowState indices 0-28).
JOINTS: tuple[str, ...] = (
    *(f"left_{j}_joint" for j in _LEG), *(f"right_{j}_joint" for j in _LEG),
    "waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint",
    *(f"left_{j}_joint" for j in _ARM), *(f"right_{j}_joint" for j in _ARM),
)
#: Each Dex3-1's motor order (HandCmd indices 0-6, as Unitree's xr_teleoperate numbers them).
HAND_JOINTS: dict[str, tuple[str, ...]] = {
    side: tuple(f"{side}_hand_{j}_joint" for j in order)
    for side, order in (("left", ("thumb_0", "thumb_1", "thumb_2", "middle_0", "middle_1", "index_0", "index_1")),
                        ("right", ("thumb_0", "thumb_1", "thumb_2", "index_0", "index_1", "middle_0", "middle_1")))
}

#: (kp, kd) per joint group; see the module docstring.
GAINS: dict[str, tuple[float, float]] = {"legs": (300.0, 3.0), "ankles": (80.0, 3.0), "waist": (300.0, 3.0),
                                         "arms": (80.0, 3.0), "wrists": (40.0, 1.5), "hands": (1.5, 0.2)}


def group(joint: str) -> str:
    """The gain group of a joint: legs, ankles, waist, arms, wrists or hands."""
    for key, name in (("_hand_", "hands"), ("ankle", "ankles"), ("waist", "waist"), ("wrist", "wrists"),
                      ("hip", "legs"), ("knee", "legs")):
        if key in joint:
            return name
    return "arms"


#: Home: knees a little bent (Unitree's standing pose), upper arms a little out and forearms forward and
#: a little down, so both wrists are in front of the torso, over the table, away from singularities.
_HOME = {"hip_pitch": -0.1, "knee": 0.3, "ankle_pitch": -0.2, "shoulder_roll": 0.15, "elbow": 0.2}
#: Pelvis height (m above the floor) at home with both soles on the floor (tests check it).
STANDING_HEIGHT = 0.785


def home() -> list[float]:
    """The home pose, in `JOINTS` order (rad); a roll is mirrored on the right (positive rolls the left
    limb outward)."""
    out = []
    for joint in JOINTS:
        side, _, name = joint.removesuffix("_joint").partition("_")
        value = _HOME.get(name, 0.0)
        out.append(0.0 - value if side == "right" and "roll" in name else value)
    return out


#: The wrists' tool frames (sites), as `robot_description()` names them.
FRAMES = {"left": "left_wrist", "right": "right_wrist"}
#: Nothing more for the wrists' IK: 7-DoF arms hold the hands' orientation too.
IK: dict[str, float] = {}


def keypoints(side: str) -> dict[str, str]:
    """HAND_JOINTS name (rio.interfaces.teleop) -> site of a Dex3-1: its three fingers' tips, the joints
    between them and the two finger knuckles (on the palm)."""
    return {"thumb-phalanx-proximal": f"{side}_thumb_mcp", "thumb-phalanx-distal": f"{side}_thumb_ip",
            "thumb-tip": f"{side}_thumb_tip",
            **{f"{f}-finger-{part}": f"{side}_{f}_{site}" for f in ("index", "middle")
               for part, site in (("phalanx-proximal", "knuckle"), ("phalanx-intermediate", "pip"), ("tip", "tip"))}}


@cache
def asset_text(hands: bool = False) -> str:
    return (ASSETS / (HANDS_ASSET if hands else ASSET)).read_text(encoding="utf-8")


@cache
def hand_xml(side: str) -> str:
    """One Dex3-1 as a model of its own (its palm at the root): what retargeting solves on, seven joints
    instead of the whole body's. Cut from `g1_hands.xml`, whose bodies the generator writes one per line."""
    text = asset_text(hands=True)
    start = text.index(f'<body name="{side}_hand_palm_link"')
    indent = text[text.rindex("\n", 0, start) + 1:start]
    end = text.index(f"\n{indent}</body>", start) + len(indent) + 8
    defaults = text[text.index("  <default>"):text.index("  <worldbody>")]
    return (f'<mujoco model="dex3_{side}">\n  <compiler angle="radian" autolimits="true"/>\n{defaults}'
            f'  <worldbody>\n{indent}{text[start:end]}\n  </worldbody>\n</mujoco>\n')
