"""What RIO knows about each UFACTORY arm model: the controller's identity codes (axis count and
device type, as the controller reports them in its version string), joint limits, the home pose and
the kinematic model (MJCF in `assets/`, written for RIO from UFACTORY's published kinematic tables).

One table shared by the driver (limits, home, model check on connect, robot description) and the
emulator (which identity to report, which model to move).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

ASSETS = Path(__file__).parent / "assets"

#: What an arm node on an xArm control box starts from (a station may set others): the box's servo loop runs
#: at 250 Hz and takes at most 500 targets a second; 0.01 rad per cycle is 2.5 rad/s, 2 mm is 0.5 m/s.
NODE_DEFAULTS = {"rate_hz": 250.0, "max_step_rad": 0.01, "max_tool_step_m": 0.002, "max_tool_step_rad": 0.01}
MAX_RATE_HZ = 500.0

_TURN = (-2 * math.pi, 2 * math.pi)


@dataclass(frozen=True)
class ArmModel:
    name: str
    label: str
    #: Joint count the controller reports (`arm.axis`).
    axis: int
    #: Device type the controller reports (`arm.device_type`): 5/6/7 xArm, 9 Lite 6, 12 xArm 850.
    device_type: int
    #: Joint limits (rad), from the controller's own table (the SDK's `XCONF.Robot.JOINT_LIMITS`).
    limits: tuple[tuple[float, float], ...]
    #: Ready pose (rad): tool pointing down in front of the base.
    home: tuple[float, ...]
    #: MJCF in `assets/`; its tool frame is the site `tcp` (the flange, z out of it).
    mjcf: str
    #: UFACTORY's published reach (m) and the shoulder joint's height above the base (m, the MJCF's link1):
    #: the workspace box of an arm installed without IK (`rio.kinematics.reach.reach_box_from_table`).
    reach: float
    shoulder_height: float
    #: Largest joint speed the controller accepts in servo mode (rad/s).
    max_joint_speed: float = math.pi

    @property
    def joint_names(self) -> list[str]:
        return [f"joint{i}" for i in range(1, self.axis + 1)]

    @property
    def mjcf_path(self) -> Path:
        return ASSETS / self.mjcf


ARMS: dict[str, ArmModel] = {
    "xarm5": ArmModel(
        "xarm5", "xArm 5", 5, 5,
        (_TURN, (-2.059488, 2.094395), (-3.92699, 0.191986), (-1.692969, math.pi), _TURN),
        home=(0.0, -0.4047, -0.3287, 0.7333, 0.0), mjcf="xarm5.xml", reach=0.7,
        shoulder_height=0.267),
    "xarm6": ArmModel(
        "xarm6", "xArm 6", 6, 6,
        (_TURN, (-2.059488, 2.094395), (-3.92699, 0.191986), _TURN, (-1.692969, math.pi), _TURN),
        home=(0.0, -0.4047, -0.3287, 0.0, 0.7333, 0.0), mjcf="xarm6.xml", reach=0.7,
        shoulder_height=0.267),
    "xarm7": ArmModel(
        "xarm7", "xArm 7", 7, 7,
        (_TURN, (-2.059488, 2.094395), _TURN, (-0.191986, 3.92699), _TURN, (-1.692969, math.pi), _TURN),
        home=(0.0, -0.3653, 0.0, 0.3333, 0.0, 0.6986, 0.0), mjcf="xarm7.xml", reach=0.7,
        shoulder_height=0.267),
    "xarm850": ArmModel(
        "xarm850", "xArm 850", 6, 12,
        (_TURN, (-2.303834612632515, 2.303834612632515), (-4.223696789826278, 0.061086523819801536), _TURN,
         (-2.1642082724729685, 2.1642082724729685), _TURN),
        home=(0.0, -0.0795, -0.379, 0.0, -0.2995, 0.0), mjcf="xarm850.xml", reach=0.85, shoulder_height=0.364),
    "lite6": ArmModel(
        "lite6", "Lite 6", 6, 9,
        (_TURN, (-2.6179938779914944, 2.6179938779914944), (-0.061086523819801536, 5.235987755982989), _TURN,
         (-2.1642082724729685, 2.1642082724729685), _TURN),
        home=(0.0, 0.2128, 0.8688, 0.0, 0.656, 0.0), mjcf="lite6.xml", reach=0.44, shoulder_height=0.2433),
}


def get_arm(name: str) -> ArmModel:
    if name not in ARMS:
        raise KeyError(f"unknown UFACTORY model '{name}'; known: {', '.join(ARMS)}")
    return ARMS[name]


def model_of(axis: int, device_type: int) -> ArmModel | None:
    """The model a controller reports (axis, device type), or None for one RIO does not know."""
    return next((m for m in ARMS.values() if (m.axis, m.device_type) == (axis, device_type)), None)
