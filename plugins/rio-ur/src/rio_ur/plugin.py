"""rio-ur's plugin module (entry point group `rio`): drivers, packaged stations and the `rio ur ...`
commands. Specs only: nothing here imports ur-rtde."""

from __future__ import annotations

from typing import Any

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

from .models import ARMS

_P = "rio_ur"


@hookimpl
def rio_drivers() -> list[Spec]:
    arms = [Spec(f"ur.{m.name}", "arm", f"{_P}.arm.driver:URArm",
                 f"Universal Robots {m.label} through ur-rtde (servoJ/servoL at 500 Hz, RTDE state, dashboard)",
                 preset={"model": m.name}) for m in ARMS.values()]
    return arms + [Spec("ur.emulator", "sensor", f"{_P}.emulator_node:EmulatorNode",
                        "a UR controller emulator (RTDE and dashboard protocols on a loopback address)")]


_STATIONS = {
    "ur5e-robotiq": "UR5e + Robotiq 2F-85 through the URCap socket (edit the IP and the RealSense serials)",
    "ur5e-sim": "UR5e + Robotiq URCap through the real ur-rtde against the emulator, backed by rio-sim physics",
    "ur5e-emulator": "UR5e + emulated URCap Robotiq through the real ur-rtde against the emulator (no hardware)",
}


#: station names before the stand-ins got one word each (fake, emulator, sim): still loaded, with a notice
_FORMERLY = {"ur5e-emulator": ("ur5e-virtual",)}


@hookimpl
def rio_stations() -> list[Spec]:
    return [Spec(name, "station", f"{_P}:stations/{name}.toml", text, formerly=_FORMERLY.get(name, ()))
            for name, text in _STATIONS.items()]


@hookimpl
def rio_requirements() -> list[Requirement]:
    return [Requirement("rtde_receive", "pip install ur-rtde", "every Universal Robots driver (ur-rtde)"),
            Requirement("mink", "pip install 'rio-ur[ik]'",
                        'eef_control = "ik", eef_pose from RIO\'s model, the emulator\'s servoL '
                        "(mink on MuJoCo)")]


@hookimpl
def rio_cli(app: Any) -> None:
    from .cli import app as ur

    app.add_typer(ur, name="ur")
