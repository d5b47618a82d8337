"""rio-unitree's plugin module (entry point group `rio`): drivers, packaged stations, requirements and
the `rio unitree ...` commands. Specs only: nothing here imports the SDK, cyclonedds or MuJoCo."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

_P = "rio_unitree"


@hookimpl
def rio_drivers() -> list[Spec]:
    return [
        Spec("unitree.g1", "humanoid", f"{_P}.driver:G1",
             "Unitree G1 (29 DoF) over DDS: arms and waist on rt/arm_sdk beside Unitree's locomotion, or the "
             "whole body on rt/lowcmd (debug mode)"),
        Spec("unitree.g1_23dof", "humanoid", f"{_P}.driver:G1", "Unitree G1 (23 DoF) over DDS, as unitree.g1",
             preset={"dof": 23}),
        Spec("unitree.dex3", "hand", f"{_P}.hand:Dex3",
             "Unitree Dex3-1 hand (config side) over DDS: rt/dex3/<side>/cmd and state, 7 joints"),
        Spec("unitree.inspire", "hand", f"{_P}.inspire:Inspire",
             "Inspire RH56 hand of a G1 (config side) through Unitree's Inspire service: rt/inspire/cmd and state, "
             "6 joints"),
        Spec("unitree.bridge", "sensor", f"{_P}.bridge.node:BridgeNode",
             "the G1 sim: MuJoCo physics behind the robot's DDS topics, for the G1 drivers without a robot"),
    ]


_STATIONS = {
    "g1-sim": "Unitree G1 (whole body, rt/lowcmd) against the G1 sim: the MuJoCo DDS bridge on loopback (no robot)",
    "g1-sim-hands": "Unitree G1 and its two Dex3-1 hands against the G1 sim on loopback (needs rio-sim)",
    "g1-sim-inspire": "Unitree G1 and its two Inspire hands (emulated fingers) against the G1 sim on loopback",
    "g1-sim-floating": "Unitree G1, free base held by a gantry until lowered, against the G1 sim "
                       "(locomotion policies; no robot)",
    "g1": "Unitree G1: arms and waist over rt/arm_sdk while Unitree's locomotion stands it (edit the interface)",
}


#: station names before the stand-ins got one word each (fake, emulator, sim): still loaded, with a notice
_FORMERLY = {
    "g1-sim": ("g1-bridge",),
    "g1-sim-hands": ("g1-bridge-hands",),
    "g1-sim-inspire": ("g1-bridge-inspire",),
    "g1-sim-floating": ("g1-bridge-floating",),
}


@hookimpl
def rio_stations() -> list[Spec]:
    here = Path(__file__).parent / "stations"
    return [Spec(name, "station", f"{_P}:stations/{name}.toml", text, formerly=_FORMERLY.get(name, ()))
            for name, text in _STATIONS.items()
            if (here / f"{name}.toml").is_file()]


@hookimpl
def rio_requirements() -> list[Requirement]:
    return [
        Requirement("unitree_sdk2py", "pip install unitree-sdk2py-dimos",
                    "every Unitree driver (the G1's DDS message types and CRC)"),
        Requirement("cyclonedds", "pip install 'cyclonedds>=0.10.2' (Linux aarch64: build Cyclone DDS, README)",
                    "every Unitree driver (DDS)"),
        Requirement("mujoco", "pip install mujoco", "the G1 bridge (rio unitree bridge, unitree.bridge)"),
    ]


@hookimpl
def rio_cli(app: Any) -> None:
    from .cli import app as unitree

    app.add_typer(unitree, name="unitree")
