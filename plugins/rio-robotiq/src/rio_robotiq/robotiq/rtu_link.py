"""A Robotiq gripper over Modbus RTU (the Robotiq USB-RS485 converter, or any RS-485 adapter): the
link the driver calls, as register writes (function 16 at 0x03E8) and status reads (function 4, input
registers, at 0x07D0: the real gripper answers it, and function 3, on that block)."""

from __future__ import annotations

from ..rtu import RtuClient
from .registers import INPUT_ADDRESS, OUTPUT_ADDRESS, USED_REGISTERS, RobotiqStatus, action_registers


class RobotiqRtuLink:
    def __init__(self, port: str, slave_id: int, *, baudrate: int, timeout_s: float, label: str, retries: int = 2):
        self.client = RtuClient(port, slave_id, baudrate=baudrate, timeout_s=timeout_s, retries=retries, label=label)
        self.where = self.client.where
        self._last = (0, 0, 0)  # rPR, rSP, rFR of the last command: a stop keeps them

    def open(self) -> RobotiqRtuLink:
        self.client.open()
        return self

    def close(self) -> None:
        self.client.close()

    def status(self, full: bool = True) -> RobotiqStatus:
        """One read of the three status registers (all fields, whatever `full` says)."""
        return RobotiqStatus.from_registers(self.client.read(INPUT_ADDRESS, USED_REGISTERS, functioncode=4))

    def activate(self, on: bool) -> None:
        """rACT alone: 1 starts the activation, 0 resets the gripper and clears its fault."""
        self._last = (0, 0, 0)
        self.client.write(OUTPUT_ADDRESS, action_registers(on, False, 0, 0, 0))

    def go(self, position: int, speed: int, force: int) -> None:
        """rACT + rGTO with a position, speed and force request: the fingers move."""
        self._last = (position, speed, force)
        self.client.write(OUTPUT_ADDRESS, action_registers(True, True, position, speed, force))

    def stop(self) -> None:
        """rGTO cleared: the fingers stop where they are, the gripper stays activated."""
        self.client.write(OUTPUT_ADDRESS, action_registers(True, False, *self._last))
