"""What RIO knows about each Franka arm: joint limits, the ready pose, the kinematic model (MJCF in
`assets/`, written for RIO from Franka's published Denavit-Hartenberg table) and joint names.

One table shared by the driver (limits, home, robot description), the fake robot (its speed limits)
and the tests (the DH chain the MJCF is checked against). FR3 and Panda share their kinematics and
differ in joint ranges and speeds (Franka's "Robot and interface specifications" pages).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

ASSETS = Path(__file__).parent / "assets"

#: Franka's DH parameters (Craig's modified convention): per joint (a_{i-1} m, d_i m, alpha_{i-1} rad),
#: then the flange (a, d, alpha) with no joint. The same for FR3 and Panda.
DH: tuple[tuple[float, float, float], ...] = (
    (0.0, 0.333, 0.0), (0.0, 0.0, -math.pi / 2), (0.0, 0.316, math.pi / 2), (0.0825, 0.0, math.pi / 2),
    (-0.0825, 0.384, -math.pi / 2), (0.0, 0.0, math.pi / 2), (0.088, 0.0, math.pi / 2))
FLANGE = (0.0, 0.107, 0.0)

#: Franka's ready pose (rad): the hand pointing down in front of the base.
READY = (0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4)

#: What an arm node on a Franka control box starts from (a station may set others): goals handed to franky 100 times a
#: second (libfranka interpolates at 1 kHz, the most a node may hand it); 0.02 rad per cycle is 2 rad/s.
NODE_DEFAULTS = {"rate_hz": 100.0, "max_step_rad": 0.02, "max_tool_step_m": 0.005, "max_tool_step_rad": 0.02}
MAX_RATE_HZ = 1000.0

#: The Franka Hand's TCP from the flange: 0.1034 m out, turned -45 deg about z (x along the fingers' travel).
HAND_TCP = (0.0, 0.0, 0.1034, 0.0, 0.0, -math.pi / 4)


@dataclass(frozen=True)
class ArmModel:
    name: str
    label: str
    #: Joint limits (rad) from Franka's published robot specifications.
    limits: tuple[tuple[float, float], ...]
    #: Joint speed limits (rad/s), same source.
    max_joint_speed: tuple[float, ...]
    mjcf: str
    home: tuple[float, ...] = READY
    #: Franka's published reach (m, 855 mm for both) and the shoulder's height above the base (m, DH d1):
    #: the workspace box of an arm installed without IK (`rio.kinematics.reach.reach_box_from_table`).
    reach: float = 0.855
    shoulder_height: float = 0.333

    @property
    def joint_names(self) -> list[str]:
        return [f"{self.name}_joint{i}" for i in range(1, 8)]

    @property
    def mjcf_path(self) -> Path:
        return ASSETS / self.mjcf


ARMS: dict[str, ArmModel] = {
    "fr3": ArmModel(
        "fr3", "Franka Research 3",
        ((-2.7437, 2.7437), (-1.7837, 1.7837), (-2.9007, 2.9007), (-3.0421, -0.1518), (-2.8065, 2.8065),
         (0.5445, 4.5169), (-3.0159, 3.0159)),
        (2.62, 2.62, 2.62, 2.62, 5.26, 4.18, 5.26), "fr3.xml"),
    "panda": ArmModel(
        "panda", "Franka Emika Panda",
        ((-2.8973, 2.8973), (-1.7628, 1.7628), (-2.8973, 2.8973), (-3.0718, -0.0698), (-2.8973, 2.8973),
         (-0.0175, 3.7525), (-2.8973, 2.8973)),
        (2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61), "panda.xml"),
}


def get_arm(name: str) -> ArmModel:
    if name not in ARMS:
        raise KeyError(f"unknown Franka model '{name}'; known: {', '.join(ARMS)}")
    return ARMS[name]
