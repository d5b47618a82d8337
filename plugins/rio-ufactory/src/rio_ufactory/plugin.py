"""rio-ufactory's plugin module (entry point group `rio`): drivers, packaged stations and the
`rio ufactory ...` commands. Specs only: nothing here imports the xArm SDK."""

from __future__ import annotations

from typing import Any

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

from .models import ARMS

_P = "rio_ufactory"

_GRIPPERS = [
    Spec("ufactory.gripper", "gripper", f"{_P}.gripper.xarm_gripper:XArmGripper",
         "xArm Gripper on the arm's tool connector (shares the arm's controller connection)"),
    Spec("ufactory.gripper_g2", "gripper", f"{_P}.gripper.xarm_gripper:XArmGripper",
         "xArm Gripper G2 on the arm's tool connector", preset={"generation": 2, "max_width": 0.084}),
    Spec("ufactory.bio_gripper", "gripper", f"{_P}.gripper.bio:BioGripper",
         "UFACTORY BIO Gripper G2 on the arm's tool connector"),
    Spec("ufactory.lite6_gripper", "gripper", f"{_P}.gripper.lite6:Lite6Gripper",
         "Lite 6 gripper (open/close on tool IO, no position sensor)"),
    Spec("ufactory.vacuum", "gripper", f"{_P}.gripper.lite6:VacuumGripper",
         "vacuum gripper on tool IO, driven as a gripper (closed = suction on)"),
    Spec("ufactory.robotiq", "gripper", f"{_P}.gripper.robotiq:XArmRobotiq",
         "Robotiq 2F-85 on the xArm's tool RS-485 (the SDK's robotiq methods)", preset={"model": "2f85"}),
    Spec("ufactory.robotiq_2f140", "gripper", f"{_P}.gripper.robotiq:XArmRobotiq",
         "Robotiq 2F-140 on the xArm's tool RS-485", preset={"model": "2f140", "max_width": 0.140}),
    Spec("ufactory.emulator", "sensor", f"{_P}.emulator_node:EmulatorNode",
         "an xArm controller emulator (the SDK's protocol on a loopback address), optionally backed by rio-sim"),
]


@hookimpl
def rio_drivers() -> list[Spec]:
    arms = [Spec(f"ufactory.{m.name}", "arm", f"{_P}.arm.driver:XArm",
                 f"UFACTORY {m.label} on its controller (xArm SDK: servo mode, real-time report)",
                 preset={"model": m.name}) for m in ARMS.values()]
    return arms + _GRIPPERS


_STATIONS = {
    "xarm7-robotiq": "xArm 7 + Robotiq 2F-85 on the tool RS-485 + RealSense cameras (the paper's station: edit "
                     "the IP and serials)",
    "xarm7-sim": "xArm 7 + gripper through the real SDK against the emulator, backed by rio-sim physics "
                 "(no hardware; needs rio-sim)",
    "xarm7-emulator": "xArm 7 + xArm Gripper through the real SDK against the emulator's model arm (no physics, "
                      "no hardware)",
    "lite6-emulator": "Lite 6 + its gripper through the real SDK against the emulator's model arm (no hardware)",
}


#: station names before the stand-ins got one word each (fake, emulator, sim): still loaded, with a notice
_FORMERLY = {
    "xarm7-sim": ("xarm7-emulator",),
    "xarm7-emulator": ("xarm7-virtual",),
    "lite6-emulator": ("lite6-virtual",),
}


@hookimpl
def rio_stations() -> list[Spec]:
    return [Spec(name, "station", f"{_P}:stations/{name}.toml", text, formerly=_FORMERLY.get(name, ()))
            for name, text in _STATIONS.items()]


@hookimpl
def rio_requirements() -> list[Requirement]:
    return [Requirement("xarm", "pip install xarm-python-sdk", "every UFACTORY driver (the xArm Python SDK)"),
            Requirement("mink", "pip install 'rio-ufactory[ik]'",
                        'eef_control = "ik", eef_pose from RIO\'s model without the control box, '
                        "the emulator's Cartesian commands (mink on MuJoCo)")]


@hookimpl
def rio_cli(app: Any) -> None:
    from .cli import app as ufactory

    app.add_typer(ufactory, name="ufactory")
