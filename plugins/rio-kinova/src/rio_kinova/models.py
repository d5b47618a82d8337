"""What RIO knows about each Kinova arm: joint count, joint limits, Kinova's "Home" pose, speed limits and
the kinematic model (DH table in `dh.py`, MJCF in `assets/` written from it).

One table shared by the driver (limits, home, unwrapping of continuous joints, robot description) and the
fake backend (which arm to move, how fast).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from . import dh

#: kortex_api is not on PyPI: where to get it (named by `rio doctor` and by the error of a missing import).
WHEEL = "kortex_api-2.6.0.post3-py3-none-any.whl"
INSTALL = (f"download {WHEEL} from https://github.com/Kinovarobotics/kortex/releases (Kinova's kortex "
           f"release assets), then: pip install ./{WHEEL} 'protobuf==3.20.0'")

ASSETS = Path(__file__).parent / "assets"
INF = math.inf

#: What an arm node on a Kinova base starts from (a station may set others): 100 cycles a second (1000 in
#: low-level mode, the most the base takes); 0.01 rad per cycle is 1 rad/s.
NODE_DEFAULTS = {"rate_hz": 100.0, "max_step_rad": 0.01}
MAX_RATE_HZ = 1000.0


def _deg(*pairs: float | None) -> tuple[tuple[float, float], ...]:
    """Symmetric limits from degrees; None = a continuous joint (no limit: Kinova's actuators turn freely)."""
    return tuple((-INF, INF) if p is None else (-math.radians(p), math.radians(p)) for p in pairs)


@dataclass(frozen=True)
class ArmModel:
    name: str
    label: str
    #: Joint limits (rad), from the user guide; (-inf, inf) for continuous joints.
    limits: tuple[tuple[float, float], ...]
    #: Kinova's "Home" pose (rad), the web app's and the kortex examples' ready pose (the Gen3's and the lite's
    #: agree with ros_kortex's MoveIt "home" states, except the lite's joint 6 there, 2.67 rad, which is beyond
    #: its own URDF's 2.59 rad limit: 0 here).
    home: tuple[float, ...]
    dh: tuple[dh.DH, ...]
    dh_base: dh.DH | None
    mjcf: str
    #: Largest joint speed the base accepts in high-level joint speed mode (rad/s), per joint.
    max_joint_speed: tuple[float, ...]
    #: Kinova's published reach (m) and the shoulder's height above the base (m, the DH table's first two
    #: offsets): the workspace box of an arm installed without IK (`rio.kinematics.reach.reach_box_from_table`).
    reach: float
    shoulder_height: float

    @property
    def dof(self) -> int:
        return len(self.limits)

    @property
    def joint_names(self) -> list[str]:
        return [f"joint_{i}" for i in range(1, self.dof + 1)]

    @property
    def continuous(self) -> tuple[bool, ...]:
        return tuple(math.isinf(lo) for lo, _ in self.limits)

    @property
    def mjcf_path(self) -> Path:
        return ASSETS / self.mjcf


_LARGE, _SMALL = math.radians(79.64), math.radians(69.91)  # Gen3 actuator speed limits (user guide)
_LITE = math.radians(49.0)  # Gen3 lite, all joints

ARMS: dict[str, ArmModel] = {
    "gen3": ArmModel(
        "gen3", "Gen3 7-DOF", _deg(None, 128.9, None, 147.8, None, 120.3, None),
        home=tuple(math.radians(a) for a in (0.0, 15.0, 180.0, -130.0, 0.0, 55.0, 90.0)),
        dh=dh.GEN3_7DOF, dh_base=dh.GEN3_7DOF_BASE, mjcf="gen3.xml",
        max_joint_speed=(_LARGE,) * 4 + (_SMALL,) * 3, reach=0.902, shoulder_height=0.1564 + 0.1284),
    "gen3_6dof": ArmModel(
        "gen3_6dof", "Gen3 6-DOF", _deg(None, 128.9, 147.8, None, 120.3, None),
        home=tuple(math.radians(a) for a in (0.0, 15.0, -130.0, 0.0, 55.0, 90.0)),
        dh=dh.GEN3_6DOF, dh_base=dh.GEN3_7DOF_BASE, mjcf="gen3_6dof.xml",
        max_joint_speed=(_LARGE,) * 3 + (_SMALL,) * 3, reach=0.891, shoulder_height=0.1564 + 0.1284),
    "gen3_lite": ArmModel(
        "gen3_lite", "Gen3 lite", _deg(154.1, 150.1, 150.1, 148.98, 144.97, 148.98),
        home=tuple(math.radians(a) for a in (0.0, -16.0, 75.0, 0.0, -60.0, 0.0)),
        dh=dh.GEN3_LITE, dh_base=None, mjcf="gen3_lite.xml",
        max_joint_speed=(_LITE,) * 6, reach=0.76, shoulder_height=0.2433),
}


def get_arm(name: str) -> ArmModel:
    if name not in ARMS:
        raise KeyError(f"unknown Kinova model '{name}'; known: {', '.join(ARMS)}")
    return ARMS[name]
