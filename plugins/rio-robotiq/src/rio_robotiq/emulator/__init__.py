"""Emulators of the grippers' wire protocols, for tests, stations without hardware and other plugins:

- `registers.RobotiqRegisters`, `registers.DhRegisters`: register models on a `FingerModel`, with
  `handle(frame)` for Modbus requests without CRC (transport-free; the protocol is core's
  `rio.emulation.RegisterSlave`);
- `ModbusRtuDevice` (core's `rio.emulation.ModbusRtuDevice`, re-exported): Modbus RTU framing on a
  pseudo-terminal around them (`.port` to open);
- `urcap.UrcapServer`: the Robotiq URCap's ASCII socket around a `RobotiqRegisters`.

    with ModbusRtuDevice(RobotiqRegisters("2f85")) as dev:
        gripper = RobotiqGripper(port=dev.port)
"""

from __future__ import annotations

from rio.emulation import ModbusRtuDevice

from .registers import DhRegisters, RobotiqRegisters
from .urcap import UrcapServer

__all__ = ["RobotiqRegisters", "DhRegisters", "ModbusRtuDevice", "UrcapServer"]
