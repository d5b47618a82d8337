"""What the GELLO part of rio-teleop registers: drivers (one name per layout, a preset of one class),
packaged stations and requirements. Specs only: nothing here imports dynamixel-sdk."""

from __future__ import annotations

from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

from .layouts import LAYOUTS

_P = "rio_teleop"

STATIONS = {
    "gello-xarm7-fake": "emulated GELLO (xArm 7 layout, waving) driving a 7-joint fake arm + gripper (no hardware)",
    "gello-xarm7-emulator": "emulated GELLO driving the xArm 7 + gripper through the real xArm SDK against its "
                            "emulator (needs rio-ufactory)",
    "gello-bimanual-fake": "two emulated GELLOs (UR5e layout) driving two 6-joint fake arms + grippers, ALOHA-style",
    "gello-xarm7": "GELLO leader + xArm 7 + xArm Gripper (edit the port and the IP)",
    "gello-ur5e": "GELLO leader + UR5e + Robotiq 2F-85 (edit the port and the IP)",
    "gello-fr3": "GELLO leader + Franka Research 3 + Franka Hand (edit the port and the IP)",
}

#: station names before the stand-ins got one word each (fake, emulator, sim): still loaded, with a notice
FORMERLY = {"gello-xarm7-fake": ("gello-xarm7-virtual",), "gello-bimanual-fake": ("gello-bimanual-virtual",)}


def drivers() -> list[Spec]:
    return [Spec(f"gello.{name}", "teleop", f"{_P}.gello.driver:GelloLeader",
                 f"{lay.label}: leader arm (Dynamixel XL330, or port = \"emulator\") for leader-follower teleop",
                 preset={"layout": name})
            for name, lay in LAYOUTS.items()]


def stations() -> list[Spec]:
    return [Spec(name, "station", f"{_P}:stations/{name}.toml", text, formerly=FORMERLY.get(name, ()))
            for name, text in STATIONS.items()]


def requirements() -> list[Requirement]:
    return [Requirement("dynamixel_sdk", "pip install dynamixel-sdk",
                        "the Dynamixel bus of GELLO leader arms (gello.*)",
                        check="rio.plugins.requirements:serial_port_problem")]
