"""The robot models rio-sim ships: MJCF files in `assets/` plus what a driver needs to know about
each (which joints form the arm, which are fingers, the tool site, a home pose).

Models are written for RIO from public kinematic data (see each XML's header); they use simple
geoms, so the plugin installs in a few hundred kilobytes and renders fast on a CPU.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

ASSETS = Path(__file__).parent / "assets"


@dataclass(frozen=True)
class RobotModel:
    name: str
    #: MJCF file in `assets/`.
    file: str
    #: Arm joints in command order (names inside the robot's MJCF).
    arm_joints: tuple[str, ...]
    #: Finger slide joints (and their position actuators, same names); the opening is their sum.
    finger_joints: tuple[str, ...]
    #: Arm joints at home: the tool points down, `home_tool` (base frame) above the table.
    home: tuple[float, ...]
    home_tool: tuple[float, float, float]
    #: Full finger opening (m).
    max_width: float
    tool_site: str = "grasp"
    wrist_camera: str = "wrist"
    description: str = ""

    @property
    def path(self) -> Path:
        return ASSETS / self.file

    def xml(self) -> str:
        return self.path.read_text(encoding="utf-8")

    @property
    def dof(self) -> int:
        return len(self.arm_joints)


ROBOTS: dict[str, RobotModel] = {
    "so100": RobotModel(
        name="so100", file="so100.xml",
        arm_joints=("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"),
        finger_joints=("finger_a", "finger_b"),
        home=(0.0, 0.0706, 1.6431, 1.4278, 1.5708), home_tool=(0.20, 0.0, 0.10),
        max_width=0.06, description="SO-100-class 5-DOF arm with a parallel gripper"),
    "xarm7": RobotModel(
        name="xarm7", file="xarm7.xml",
        arm_joints=tuple(f"joint{i}" for i in range(1, 8)),
        finger_joints=("finger_a", "finger_b"),
        home=(0.0, -0.2085, 0.0, 0.5075, 0.0, 0.716, -1.5708), home_tool=(0.35, 0.0, 0.10),
        max_width=0.085, description="xArm7-class 7-DOF arm with a parallel gripper"),
    "xarm6": RobotModel(
        name="xarm6", file="xarm6.xml",
        arm_joints=tuple(f"joint{i}" for i in range(1, 7)),
        finger_joints=("finger_a", "finger_b"),
        home=(0.0, -0.2387, -0.5068, 0.0, 0.7455, -1.5708), home_tool=(0.35, 0.0, 0.10),
        max_width=0.085, description="xArm6-class 6-DOF arm with a parallel gripper"),
    "lite6": RobotModel(
        name="lite6", file="lite6.xml",
        arm_joints=tuple(f"joint{i}" for i in range(1, 7)),
        finger_joints=("finger_a", "finger_b"),
        home=(0.0, 0.2722, 0.8433, 0.0, 0.5712, -1.5708), home_tool=(0.25, 0.0, 0.10),
        max_width=0.06, description="Lite6-class 6-DOF arm with a parallel gripper"),
    "panda": RobotModel(
        name="panda", file="panda.xml",
        arm_joints=tuple(f"panda_joint{i}" for i in range(1, 8)),
        finger_joints=("finger_a", "finger_b"),
        home=(0.0, 0.169215, 0.0, -2.566342, 0.0, 2.735556, 0.785398), home_tool=(0.45, 0.0, 0.10),
        max_width=0.08, description="Panda-class 7-DOF arm (Franka's kinematics) with a Franka Hand-like gripper"),
    "ur5e": RobotModel(
        name="ur5e", file="ur5e.xml",
        arm_joints=("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
                    "wrist_2_joint", "wrist_3_joint"),
        finger_joints=("finger_a", "finger_b"),
        home=(2.8018, -1.2766, 1.7239, 1.1235, 1.5708, 1.231), home_tool=(0.40, 0.0, 0.10),
        max_width=0.085, description="UR5e (UR's DH table, via rio-ur) with a 2F-85-stroke parallel gripper"),
    "gen3": RobotModel(
        name="gen3", file="gen3.xml",
        arm_joints=tuple(f"joint_{i}" for i in range(1, 8)),
        finger_joints=("finger_a", "finger_b"),
        home=(0.002222, 0.623837, 3.141593, -1.810623, 0.0, -0.707133, 1.570796), home_tool=(0.45, 0.0, 0.10),
        max_width=0.085, description="Kinova Gen3 7-DOF (Kinova's DH table, via rio-kinova) with a 2F-85-stroke "
                                     "parallel gripper"),
}


def get_robot(name: str) -> RobotModel:
    if name not in ROBOTS:
        raise KeyError(f"unknown sim robot '{name}'; rio-sim ships: {', '.join(sorted(ROBOTS))}")
    return ROBOTS[name]
