"""The arm's end (tool) board: its digital I/O, its RS-485 port and the tool attached to them.

The SDK reaches the board through controller registers: 16/32-bit register reads and writes
addressed to the board itself (host id 9: GPIO, the RS-485 baud rate, soft reboot) or, in the
gripper's old protocol, to the xArm Gripper behind it (device id 8); and RS-485 relays, where a
Modbus RTU frame (without CRC) goes to whichever slave has its id, provided the port runs at that
slave's baud rate (else the slave stays silent, as on the wire). The SDK checks and sets the baud
rate before talking to a gripper, which takes it a write to 0x1A0B and a soft reboot of the board.

Register writes carry their value as an fp32 (the controller's convention), reads answer a 32-bit
big-endian integer.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

log = logging.getLogger("rio_ufactory.emulator")

HOST_ID = 9  # the tool board (robot RS-485 host)
CONTROL_BOX_HOST_ID = 11  # the control box's RS-485 port (nothing attached here)
DEVICE_ID = 8  # the gripper in the old register protocol

#: Baud rates the board knows, by index (what register 0x0A0B holds).
BAUDS = (4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600, 1000000, 1500000, 2000000, 2500000)

_BAUD = 0x0A0B
_SAVE = 0x1000  # "and save" flag of a register address
_SOFT_REBOOT = 0x0607
_MB_TIMEOUT = 0x0A0E
_TI2 = 0x0A12
_DIGITAL_IN = 0x0A14
_DIGITAL_OUT = 0x0A15
_ANALOG_IN = (0x0A16, 0x0A17)
_DIGITAL_OUT_STATE = 0x0A18


class ToolBoard:
    """Tool GPIO and RS-485 with `device` attached (a Modbus slave with `handle(frame)`, a GPIO tool
    with `on_outputs(bits)` / `inputs()`, or None)."""

    VERSION = (2, 3, 0)

    def __init__(self, device=None, clock: Callable[[], float] = time.monotonic):
        self.device = device
        self.clock = clock
        self.rtu = device if callable(getattr(device, "handle", None)) else None
        self.gpio = device if callable(getattr(device, "on_outputs", None)) else None
        default_baud = getattr(self.rtu, "baud", 2_000_000)
        self.baud_index = BAUDS.index(default_baud) if default_baud in BAUDS else BAUDS.index(2_000_000)
        self._baud_pending: int | None = None
        self.outputs = 0  # digital outputs: bit0 DO0, bit1 DO1, bit2.. the rest
        self.modbus_timeout_ms = 10
        self._delayed: list[tuple[float, int, bool]] = []

    @property
    def baud(self) -> int:
        return BAUDS[self.baud_index]

    # -- GPIO --------------------------------------------------------------------------------------
    def set_outputs(self, mask: int, values: int) -> None:
        self.outputs = (self.outputs & ~mask) | (values & mask)
        if self.gpio is not None:
            self.gpio.on_outputs(self.outputs)

    def set_output_later(self, bit: int, on: bool, delay: float) -> None:
        self._delayed.append((self.clock() + max(delay, 0.0), bit, on))

    def inputs(self) -> int:
        return int(self.gpio.inputs()) if self.gpio is not None else 0

    def update(self) -> None:
        """Apply delayed outputs that are due."""
        if not self._delayed:
            return
        now = self.clock()
        due = [d for d in self._delayed if d[0] <= now]
        self._delayed = [d for d in self._delayed if d[0] > now]
        for _, bit, on in due:
            self.set_outputs(1 << bit, (1 << bit) if on else 0)

    # -- board registers -----------------------------------------------------------------------------
    def read(self, bid: int, addr: int, wide: bool = False) -> int | None:
        """A register of the board (bid 9) or of the gripper behind it (bid 8); None: no such one."""
        if bid == DEVICE_ID:
            reg_read = getattr(self.device, "reg_read", None)
            return reg_read(addr, wide) if reg_read is not None else None
        if bid != HOST_ID:
            return None
        a = addr & ~_SAVE
        if a == _BAUD:
            return self.baud_index
        if a == _DIGITAL_IN:
            return self.inputs() & 0x0F
        if a == _DIGITAL_OUT_STATE:
            return self.outputs & 0x1F
        if a in (_TI2, *_ANALOG_IN):
            return 0
        if a == _MB_TIMEOUT:
            return self.modbus_timeout_ms
        if 0x0801 <= a <= 0x0803:
            return self.VERSION[a - 0x0801]
        return None

    def write(self, bid: int, addr: int, value: float, wide: bool = False) -> bool:
        v = int(round(value))
        if bid == DEVICE_ID:
            reg_write = getattr(self.device, "reg_write", None)
            return bool(reg_write(addr, v, wide)) if reg_write is not None else False
        if bid != HOST_ID:
            return False
        a = addr & ~_SAVE
        if a == _BAUD:
            if not 0 <= v < len(BAUDS):
                return False
            self._baud_pending = v  # takes effect at the board's next (soft) reboot
            return True
        if a == _SOFT_REBOOT:
            if self._baud_pending is not None:
                self.baud_index, self._baud_pending = self._baud_pending, None
                log.debug("tool board: RS-485 at %d baud", self.baud)
            return True
        if a == _DIGITAL_OUT:
            self.set_outputs((v >> 8) & 0xFF, v & 0xFF)
            return True
        if a == _MB_TIMEOUT:
            self.modbus_timeout_ms = v
            return True
        return False

    # -- RS-485 --------------------------------------------------------------------------------------
    def relay(self, frame: bytes) -> bytes | None:
        """Send a Modbus RTU request on the tool port; the slave's reply, or None (nobody answered)."""
        if self.rtu is None:
            return None
        if getattr(self.rtu, "baud", self.baud) != self.baud:
            return None  # wrong speed: the slave sees noise
        return self.rtu.handle(bytes(frame)) or None  # b"": not its slave id, silence

    def device_error(self) -> int:
        """The gripper's error code (controller register TGPIO_ERR)."""
        return int(getattr(self.device, "error_code", 0) or 0)
