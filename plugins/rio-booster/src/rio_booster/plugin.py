"""rio-booster's plugin module (entry point group `rio`): the driver, packaged stations and requirements.
Specs only: nothing here imports the SDK."""

from __future__ import annotations

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

_P = "rio_booster"


@hookimpl
def rio_drivers() -> list[Spec]:
    return [
        Spec("booster.t1", "humanoid", f"{_P}.driver:T1",
             "Booster T1 (23 DoF) on Booster's SDK: low state in, SERIAL joint commands in custom mode, mode "
             "changes through B1LocoClient; sdk = 'rio_booster.emulator' for the emulated T1 "
             "(interface = 'sim': on rio-sim physics)"),
    ]


_STATIONS = {
    "t1": "Booster T1: the whole body in custom mode over Booster's SDK (edit the interface; hang the robot)",
    "t1-fake": "Booster T1 driver against the in-process fake T1 (SDK-object fake, no robot, no DDS)",
    "t1-sim": "Booster T1 driver against the emulated T1 on rio-sim physics: stand, table, head camera, "
              "scripted hand tracking (pip install 'rio-booster[sim]')",
}


#: station names before the stand-ins got one word each (fake, emulator, sim): still loaded, with a notice
_FORMERLY = {"t1-fake": ("t1-emulator",)}


@hookimpl
def rio_stations() -> list[Spec]:
    return [Spec(name, "station", f"{_P}:stations/{name}.toml", text, formerly=_FORMERLY.get(name, ()))
            for name, text in _STATIONS.items()]


@hookimpl
def rio_requirements() -> list[Requirement]:
    return [
        Requirement("booster_robotics_sdk_python", "pip install booster-robotics-sdk-python (CPython 3.11, Linux "
                    "x86-64; elsewhere build Booster's SDK from source)", "booster.t1 on a robot"),
    ]
