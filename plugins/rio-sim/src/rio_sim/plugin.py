"""rio-sim's plugin module (entry point group `rio`): the sim drivers and the packaged stations.
Specs only: nothing here imports MuJoCo."""

from __future__ import annotations

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

from .robots import ROBOTS  # a table of names and files: no MuJoCo

_S = "rio_sim"


@hookimpl
def rio_drivers() -> list[Spec]:
    return [
        Spec("sim.world", "sensor", f"{_S}.world:SimWorld",
             "MuJoCo physics of a sim station (scene, objects' ground-truth poses)"),
        Spec("sim.arm", "arm", f"{_S}.arm:SimArm",
             f"simulated arm ({', '.join(ROBOTS)}): joint and end-effector control, IK"),
        Spec("sim.gripper", "gripper", f"{_S}.gripper:SimGripper",
             "simulated parallel gripper"),
        Spec("sim.wrench", "sensor", f"{_S}.wrench:SimWrench",
             "simulated wrist force/torque sensor of a sim arm (wrench kind; MuJoCo force and torque sensors)"),
        Spec("sim.base", "base", f"{_S}.base:SimBase",
             "simulated omni-wheel mobile base (a planar body driven by its body twist; wheel speeds, odometry)"),
        Spec("sim.camera", "camera", f"{_S}.camera:SimCamera",
             "simulated camera: RGB and depth by offscreen rendering"),
        Spec("teleop.expert", "teleop", f"{_S}.expert:SimExpert",
             "scripted expert for a sim station's pick-and-place task (reads the world's true state): "
             "demonstrations from every start, ended with keep or discard"),
        Spec("sim.g1", "humanoid", f"{_S}.humanoid:SimHumanoid",
             "simulated Unitree G1 (29 DoF): joint PD servos, pelvis IMU, wrist IK model; on a stand or free",
             preset={"robot": "g1"}),
        Spec("sim.t1", "humanoid", f"{_S}.humanoid:SimHumanoid",
             "simulated Booster T1 (23 DoF): joint PD servos, trunk IMU, hand IK model; on a stand or free",
             preset={"robot": "t1"}),
        Spec("sim.g1_hand", "hand", f"{_S}.humanoid:SimG1Hand",
             "simulated Unitree Dex3-1 hand of a sim.g1 (7 DoF), with its model for hand-tracking retargeting"),
    ]


_STATIONS = {
    "sim-so100": "SO-100 arm + gripper, wrist and front cameras; task: the cube onto the pad, random starts (MuJoCo)",
    "sim-so100-loop": "sim-so100 without cameras: its task for state-based policies, 15 s per trial (MuJoCo)",
    "sim-bimanual": "two SO-100 arms + grippers, wrist and front cameras; task: each cube onto its pad (MuJoCo)",
    "sim-xarm7": "xArm7 + gripper, wrist and front (RGB-D) cameras, end-effector actions (MuJoCo)",
    "sim-g1": "Unitree G1 + Dex3-1 hands on a stand at a table, head camera, scripted hand tracking (MuJoCo)",
    "sim-t1": "Booster T1 on a stand at a table, head camera, scripted hand tracking (MuJoCo)",
    "sim-g1-floating": "Unitree G1 with a free base, for locomotion policies: rio deploy --policy onnx.locomotion",
}


@hookimpl
def rio_stations() -> list[Spec]:
    return [Spec(name, "station", f"{_S}:stations/{name}.toml", text) for name, text in _STATIONS.items()]


@hookimpl
def rio_requirements() -> list[Requirement]:
    return [
        Requirement("mujoco", "pip install mujoco", "physics and rendering of every sim driver",
                    check=f"{_S}.gl:gl_problem"),  # offscreen OpenGL for sim.camera (tries a 16x16 context)
        Requirement("mink", "pip install mink", "sim.arm end-effector control (IK through rio.kinematics)"),
    ]
