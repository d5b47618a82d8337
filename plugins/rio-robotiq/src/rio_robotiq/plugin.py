"""rio-robotiq's plugin module (entry point group `rio`): driver specs, a packaged station and what
`rio doctor` checks. Specs only: nothing here imports minimalmodbus or pyserial."""

from __future__ import annotations

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

_P = "rio_robotiq"
_RTU = f"{_P}.robotiq.driver:RobotiqGripper"
_URCAP = f"{_P}.robotiq.driver:RobotiqUrcapGripper"
_DH = f"{_P}.dh.driver:DhGripper"


@hookimpl
def rio_drivers() -> list[Spec]:
    rtu = ' over Modbus RTU on an RS-485 adapter (or port = "emulator")'
    return [
        Spec("robotiq.2f85", "gripper", _RTU, "Robotiq 2F-85" + rtu, preset={"model": "2f85"}),
        Spec("robotiq.2f140", "gripper", _RTU, "Robotiq 2F-140" + rtu, preset={"model": "2f140"}),
        Spec("robotiq.hande", "gripper", _RTU, "Robotiq Hand-E" + rtu, preset={"model": "hande"}),
        Spec("robotiq.urcap", "gripper", _URCAP,
             'Robotiq 2F-85/2F-140/Hand-E through the URCap socket of a UR controller (or host = "emulator")'),
        Spec("dh.ag95", "gripper", _DH, "DH-Robotics AG-95 (AG-160-95)" + rtu, preset={"model": "ag95"}),
        Spec("dh.ag105", "gripper", _DH, "DH-Robotics AG-105-145" + rtu, preset={"model": "ag105"}),
    ]


@hookimpl
def rio_stations() -> list[Spec]:
    return [Spec("robotiq-emulator", "station", f"{_P}:stations/robotiq-emulator.toml",
                 "a fake arm with an emulated Robotiq 2F-85 on an emulated RS-485 line, scripted teleop (no hardware)",
                 formerly=("robotiq-virtual",))]


@hookimpl
def rio_requirements() -> list[Requirement]:
    return [
        Requirement("minimalmodbus", "pip install minimalmodbus", "Modbus RTU of the Robotiq and DH drivers",
                    check="rio.plugins.requirements:serial_port_problem"),
        Requirement("serial", "pip install pyserial", "serial ports under minimalmodbus"),
    ]
