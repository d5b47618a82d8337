"""rio-so100's plugin module (entry point group `rio`): drivers, packaged stations and the
`rio so100 ...` commands. Specs only: nothing here imports the Feetech SDK."""

from __future__ import annotations

from typing import Any

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

_P = "rio_so100"


def _arm_specs(model: str) -> list[Spec]:
    label = "SO-101" if model == "so101" else "SO-100"
    preset = {"model": model}  # SO-101 is the same driver with another calibration folder
    return [
        Spec(f"{model}.follower", "arm", f"{_P}.follower.driver:So100Follower",
             f"{label} follower arm joints (Feetech STS3215 bus, or port = \"emulator\")", preset=preset),
        Spec(f"{model}.gripper", "gripper", f"{_P}.gripper.driver:So100Gripper",
             f"{label} jaw servo as a gripper (shares the follower's bus)", preset=preset),
        Spec(f"{model}.leader", "teleop", f"{_P}.leader.driver:So100Leader",
             f"{label} leader arm (torque off), joint positions for leader-follower teleop", preset=preset),
    ]


@hookimpl
def rio_drivers() -> list[Spec]:
    lekiwi = Spec("lekiwi.base", "base", f"{_P}.lekiwi.wheels:LeKiwiBase",
                  "LeKiwi's three omni wheels (STS3215 in wheel mode, ids 7-9, on the arm's bus; or port = "
                  "\"emulator\")")
    return _arm_specs("so100") + _arm_specs("so101") + [lekiwi]


_STATIONS = {
    "so100-emulator": "SO-100 follower + gripper + leader on emulated buses (no hardware; the leader waves)",
    "so100-bimanual-emulator": "two SO-100 followers + grippers + two leaders on emulated buses (ALOHA-style)",
    "so100-sim": "SO-100 drivers on emulated buses backed by rio-sim's MuJoCo arm, emulated leader (needs rio-sim)",
    "so100": "SO-100 follower + gripper + leader arm on serial ports (edit the ports)",
    "so100-bimanual": "two SO-100 followers + grippers + two leaders on serial ports (edit the ports)",
    "so101": "SO-101 follower + gripper + leader arm on serial ports (edit the ports)",
    "so101-bimanual": "two SO-101 followers + grippers + two leaders on serial ports (edit the ports)",
    "lekiwi": "LeKiwi: SO-101 follower + gripper and the three-wheel base on one serial port (edit the port)",
    "lekiwi-emulator": "LeKiwi's arm, gripper and wheels on emulated buses (no hardware), keyboard teleop",
    "lekiwi-sim": "LeKiwi in rio-sim's MuJoCo: arm + gripper on a three-wheel base, cameras (needs rio-sim)",
}


#: station names before the stand-ins got one word each (fake, emulator, sim): still loaded, with a notice
_FORMERLY = {
    "so100-emulator": ("so100-virtual",),
    "so100-bimanual-emulator": ("so100-bimanual-virtual",),
    "lekiwi-emulator": ("lekiwi-virtual",),
}


@hookimpl
def rio_stations() -> list[Spec]:
    return [Spec(name, "station", f"{_P}:stations/{name}.toml", text, formerly=_FORMERLY.get(name, ()))
            for name, text in _STATIONS.items()]


@hookimpl
def rio_requirements() -> list[Requirement]:
    return [
        Requirement("scservo_sdk", "pip install feetech-servo-sdk",
                    "the Feetech STS3215 bus of every SO-100/SO-101 driver",
                    check="rio.plugins.requirements:serial_port_problem"),
        Requirement("serial", "pip install pyserial", "serial ports under the Feetech SDK"),
    ]



@hookimpl
def rio_cli(app: Any) -> None:
    from .cli import app as so100

    app.add_typer(so100, name="so100")
