"""A Modbus RTU master for one slave on a USB-RS485 adapter, over minimalmodbus: the transport both
the Robotiq and the DH drivers use.

Why a wrapper: minimalmodbus caches serial ports by name across instruments (two drivers on two
emulated ptys that happen to reuse a /dev/pts number would share a stale object), so this opens its own
exclusive `serial.Serial` and hands it over; it retries a transaction lost on the wire (RS-485 noise, a
gripper busy booting); and its errors name the port, the slave id and what to check. minimalmodbus and
pyserial are imported when the port opens, never when a driver module is imported.
"""

from __future__ import annotations

import logging
from typing import Any

from .errors import CommunicationError

log = logging.getLogger("rio_robotiq")


class RtuClient:
    def __init__(self, port: str, slave_id: int, *, baudrate: int = 115200, timeout_s: float = 0.2,
                 retries: int = 2, label: str = "gripper"):
        self.port, self.slave_id, self.baudrate = port, int(slave_id), int(baudrate)
        self.timeout_s, self.retries, self.label = float(timeout_s), int(retries), label
        self.where = f"{port} (slave id {self.slave_id}, {self.baudrate} baud)"
        self._serial: Any = None
        self._instrument: Any = None

    def open(self) -> RtuClient:
        import minimalmodbus
        import serial

        try:
            self._serial = serial.Serial(self.port, baudrate=self.baudrate, bytesize=8, parity=serial.PARITY_NONE,
                                         stopbits=1, timeout=self.timeout_s, write_timeout=1.0, exclusive=True)
        except (serial.SerialException, OSError, ValueError) as e:
            raise CommunicationError(f"cannot open the serial port of the {self.label} on {self.port}: {e}") from e
        self._instrument = minimalmodbus.Instrument(self._serial, self.slave_id)
        return self

    def close(self) -> None:
        if self._serial is not None:
            try:
                self._serial.close()
            finally:
                self._serial = self._instrument = None

    # -- transactions ---------------------------------------------------------------------------------------
    def read(self, address: int, count: int, functioncode: int = 3) -> list[int]:
        return self._call(f"reading {count} registers at 0x{address:04X} (FC{functioncode:02d})",
                          lambda i: i.read_registers(address, count, functioncode=functioncode))

    def write(self, address: int, values: list[int]) -> None:
        """Function 16 (write multiple registers)."""
        self._call(f"writing {len(values)} registers at 0x{address:04X} (FC16)",
                   lambda i: i.write_registers(address, [int(v) for v in values]))

    def write_one(self, address: int, value: int) -> None:
        """Function 6 (write single register)."""
        self._call(f"writing register 0x{address:04X} (FC06)",
                   lambda i: i.write_register(address, int(value), functioncode=6))

    def _call(self, what: str, fn) -> Any:
        import minimalmodbus

        if self._instrument is None:
            raise CommunicationError(f"the {self.label} on {self.where} is not open")
        for attempt in range(self.retries + 1):
            try:
                return fn(self._instrument)
            except minimalmodbus.SlaveReportedException as e:  # the gripper answered "no": retrying won't help
                raise CommunicationError(f"{self.label} on {self.where} refused {what}: {e}") from e
            except (minimalmodbus.ModbusException, OSError) as e:
                if attempt < self.retries:
                    log.debug("%s on %s: %s failed (%s); retrying", self.label, self.where, what, e)
                    continue
                raise CommunicationError(
                    f"{self.label} on {self.where}: no valid answer {what} after {self.retries + 1} tries ({e}); check "
                    "the 24 V supply, the RS-485 wiring (A/B), the slave id and the baud rate") from e
        raise AssertionError("unreachable")
