"""rio-sim's plugin module (entry point group `rio`): the sim drivers and the packaged stations.
Specs only: nothing here imports MuJoCo."""

from __future__ import annotations

from rio.hookspecs import hookimpl
from rio.specs import Spec

_S = "rio_sim"


@hookimpl
def rio_drivers() -> list[Spec]:
    return [
        Spec("sim.world", "sensor", f"{_S}.world:SimWorld",
             "MuJoCo physics of a sim station (scene, objects' ground-truth poses)",
             config=f"{_S}.world:SimWorldConfig"),
        Spec("sim.arm", "arm", f"{_S}.arm:SimArm",
             "simulated arm (so100, xarm7): joint and end-effector control, IK", config=f"{_S}.arm:SimArmConfig"),
        Spec("sim.gripper", "gripper", f"{_S}.gripper:SimGripper",
             "simulated parallel gripper", config=f"{_S}.gripper:SimGripperConfig"),
        Spec("sim.camera", "camera", f"{_S}.camera:SimCamera",
             "simulated camera: RGB and depth by offscreen rendering", config=f"{_S}.camera:SimCameraConfig"),
    ]


_STATIONS = {
    "sim-so100": "SO-100 arm + gripper, wrist and front cameras, cube to pick (MuJoCo)",
    "sim-bimanual": "two SO-100 arms + grippers, wrist and front cameras (MuJoCo)",
    "sim-xarm7": "xArm7 + gripper, wrist and front (RGB-D) cameras, end-effector actions (MuJoCo)",
}


@hookimpl
def rio_stations() -> list[Spec]:
    return [Spec(name, "station", f"{_S}:stations/{name}.toml", text) for name, text in _STATIONS.items()]
