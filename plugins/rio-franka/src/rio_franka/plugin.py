"""rio-franka's plugin module (entry point group `rio`): drivers, packaged stations, requirements and the
`rio franka ...` commands. Specs only: nothing here imports franky."""

from __future__ import annotations

from typing import Any

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

from .models import ARMS

_P = "rio_franka"


@hookimpl
def rio_drivers() -> list[Spec]:
    arms = [Spec(f"franka.{m.name}", "arm", f"{_P}.arm.driver:FrankaArm",
                 f"{m.label} through franky (libfranka's 1 kHz loop; asynchronous joint and Cartesian motions)",
                 preset={"model": m.name}) for m in ARMS.values()]
    return arms + [Spec("franka.hand", "gripper", f"{_P}.hand:FrankaHand",
                        "Franka Hand through franky's Gripper (move, grasp with force)")]


_STATIONS = {
    "fr3-hand": "FR3 + Franka Hand through franky (edit the IP and the RealSense serials)",
    "fr3-fake": "FR3 + Franka Hand on the fake franky robot (modelled arm, no hardware)",
    "panda-sim": "Panda + hand on the fake franky robot driving a rio-sim world (needs rio-sim)",
}


#: station names before the stand-ins got one word each (fake, emulator, sim): still loaded, with a notice
_FORMERLY = {"fr3-fake": ("fr3-virtual",)}


@hookimpl
def rio_stations() -> list[Spec]:
    return [Spec(name, "station", f"{_P}:stations/{name}.toml", text, formerly=_FORMERLY.get(name, ()))
            for name, text in _STATIONS.items()]


@hookimpl
def rio_requirements() -> list[Requirement]:
    return [Requirement("franky", "pip install franky-control", "every Franka driver (franky, bundling libfranka)"),
            Requirement("mink", "pip install 'rio-franka[ik]'",
                        'eef_control = "ik", eef_pose from RIO\'s model, the fake robot '
                        "(mink on MuJoCo)")]


@hookimpl
def rio_cli(app: Any) -> None:
    from .cli import app as franka

    app.add_typer(franka, name="franka")
