"""`port = "emulator"` / `host = "emulator"`: a private emulator started inside the driver's process, so a
station or the conformance kit runs the real driver code (minimalmodbus on a pseudo-terminal, the
URCap socket client) without hardware. The emulator lives as long as the driver keeps the link open.
"""

from __future__ import annotations

from typing import Any

EMULATOR = "emulator"


def is_emulator(address: str) -> bool:
    return address == EMULATOR


def robotiq_rtu(model: str, slave_id: int) -> Any:
    """A Robotiq on an emulated RS-485 line: `.port` is the path to open."""
    from rio.emulation import ModbusRtuDevice

    from .registers import RobotiqRegisters

    return ModbusRtuDevice(RobotiqRegisters(model, slave_id=slave_id))


def robotiq_urcap(model: str) -> Any:
    """A Robotiq behind an emulated URCap server on 127.0.0.1: `.host`, `.port` to connect to."""
    from .registers import RobotiqRegisters
    from .urcap import UrcapServer

    return UrcapServer(RobotiqRegisters(model)).start()


def dh_rtu(model: str, slave_id: int) -> Any:
    from rio.emulation import ModbusRtuDevice

    from .dh import DhRegisters

    return ModbusRtuDevice(DhRegisters(model, slave_id=slave_id))


def stop(device: Any) -> None:
    """Close what `robotiq_rtu` / `dh_rtu` (a pty device) or `robotiq_urcap` (a TCP server) started."""
    if device is None:
        return
    if hasattr(device, "stop"):
        device.stop()
    else:
        device.close()
