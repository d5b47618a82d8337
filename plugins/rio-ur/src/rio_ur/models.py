"""What RIO knows about each Universal Robots e-Series / UR-Series arm: the DH table, joint limits,
joint speed limits and a home pose.

One table shared by the driver (limits, home, robot description), the emulators (which model to move)
and the MJCF written from it (`mjcf.py`). The DH parameters are Universal Robots' published ones ("DH
parameters for calculations of kinematics and dynamics"); UR7e and UR12e share the UR5e and UR10e
kinematics. Every UR joint is a standard DH revolute joint with theta = q (no offsets), so the DH base
frame is the controller's base frame and the DH tool frame is its flange (TCP with a zero offset).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

_TURN = (-2 * math.pi, 2 * math.pi)

#: What a node on a UR controller starts from (a station may set others): the controller runs at 500 Hz and
#: takes servo targets at most that fast; 0.006 rad per cycle is 3 rad/s, 2 mm is 1 m/s.
NODE_DEFAULTS = {"rate_hz": 500.0, "max_step_rad": 0.006, "max_tool_step_m": 0.002, "max_tool_step_rad": 0.006}
MAX_RATE_HZ = 500.0
_ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
JOINT_NAMES = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
               "wrist_3_joint")


@dataclass(frozen=True)
class URModel:
    name: str
    label: str
    #: DH `d` (m) of joints 1..6; `a` (m) of joints 2 and 3 (the others are 0), alpha as `_ALPHA`.
    d: tuple[float, float, float, float, float, float]
    a2: float
    a3: float
    #: Largest joint speeds (rad/s), from the arm's datasheet: what the emulator's servo obeys.
    max_speed: tuple[float, float, float, float, float, float]
    #: Ready pose (rad): the flange about 0.4 m in front of the base (+x), tool pointing down.
    home: tuple[float, float, float, float, float, float]
    #: Universal Robots' published reach (m): with the shoulder's height (DH d1) the workspace box of an arm
    #: installed without IK (`rio.kinematics.reach.reach_box_from_table`).
    reach: float
    limits: tuple[tuple[float, float], ...] = (_TURN,) * 6
    payload_kg: float = 5.0

    @property
    def a(self) -> tuple[float, ...]:
        return (0.0, self.a2, self.a3, 0.0, 0.0, 0.0)

    @property
    def alpha(self) -> tuple[float, ...]:
        return _ALPHA

    @property
    def joint_names(self) -> list[str]:
        return list(JOINT_NAMES)

    @property
    def shoulder_height(self) -> float:
        return self.d[0]


def _deg(*v: float) -> tuple[float, ...]:
    return tuple(math.radians(x) for x in v)


_UR5E_D = (0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996)
_UR10E_D = (0.1807, 0.0, 0.0, 0.17415, 0.11985, 0.11655)
_UR20_D = (0.2363, 0.0, 0.0, 0.2010, 0.1593, 0.1543)
# Homes: solved once with RIO's IK on each model: flange tool-down at (0.4, 0, 0.3) m (UR3e: 0.3, 0, 0.3;
# UR10e and larger: 0.4, 0, 0.45), elbow up; tests/test_models.py checks them.

ARMS: dict[str, URModel] = {m.name: m for m in (
    URModel("ur3e", "UR3e", (0.15185, 0.0, 0.0, 0.13105, 0.08535, 0.0921), -0.24355, -0.2132,
            _deg(180, 180, 180, 360, 360, 360),
            home=(0.4521, -2.8747, 0.7045, 0.5994, -1.5708, 2.0229), payload_kg=3.0, reach=0.5),
    URModel("ur5e", "UR5e", _UR5E_D, -0.425, -0.3922, _deg(180, 180, 180, 180, 180, 180),
            home=(2.8018, -1.2766, 1.7239, 1.1235, 1.5708, 1.231), reach=0.85),
    URModel("ur7e", "UR7e", _UR5E_D, -0.425, -0.3922, _deg(180, 180, 180, 180, 180, 180),
            home=(2.8018, -1.2766, 1.7239, 1.1235, 1.5708, 1.231),
            payload_kg=7.5, reach=0.85),
    URModel("ur10e", "UR10e", _UR10E_D, -0.6127, -0.57155, _deg(120, 120, 180, 180, 180, 180),
            home=(2.6911, -1.6449, 2.0499, 1.1659, 1.5708, 1.1203),
            payload_kg=12.5, reach=1.3),
    URModel("ur12e", "UR12e", _UR10E_D, -0.6127, -0.57155, _deg(120, 120, 180, 180, 180, 180),
            home=(2.6911, -1.6449, 2.0499, 1.1659, 1.5708, 1.1203),
            payload_kg=12.0, reach=1.3),
    URModel("ur16e", "UR16e", _UR10E_D, -0.4784, -0.36, _deg(120, 120, 180, 180, 180, 180),
            home=(2.6911, -1.1751, 1.7828, 0.963, 1.5708, 1.1203),
            payload_kg=16.0, reach=0.9),
    URModel("ur20", "UR20", _UR20_D, -0.8620, -0.7287, _deg(120, 120, 150, 210, 210, 210),
            home=(2.6151, -1.6069, 2.3507, 0.8269, 1.5708, 1.0443),
            payload_kg=20.0, reach=1.75),
    URModel("ur30", "UR30", _UR20_D, -0.6370, -0.5037, _deg(120, 120, 150, 210, 210, 210),
            home=(2.6151, -1.4506, 2.0032, 1.0182, 1.5708, 1.0443),
            payload_kg=30.0, reach=1.3),
)}


def get_arm(name: str) -> URModel:
    if name not in ARMS:
        raise KeyError(f"unknown Universal Robots model '{name}'; known: {', '.join(ARMS)}")
    return ARMS[name]
