"""Modbus RTU for device emulators: the CRC, request framing, a register-map slave and a serial line.

Why in core: grippers and tools on RS-485 (a gripper on a USB adapter, a tool on an arm's tool port
that the arm controller relays frames to) speak Modbus RTU, and every plugin that emulates one needs
the same protocol. The register map is the device's; the protocol is written once, here.

- `crc16`, `with_crc`, `frame_length`: CRC-16/MODBUS and the length of a request on the wire;
- `RegisterSlave`: one slave id answering functions 3, 4 (read), 6 (write one) and 16 (write many)
  on frames without their CRC (`handle(frame) -> reply`), so the same register model serves a
  serial line and a controller that carries frames inside its own protocol. Refusals are Modbus
  exceptions: 1 illegal function, 2 illegal data address, 3 illegal data value;
- `ModbusRtuDevice`: RTU framing on a pseudo-terminal around slaves (`.port` to open).
"""

from __future__ import annotations

import struct
import threading
import time
from typing import Any

from rio.emulation.pty import PtyDevice

ILLEGAL_FUNCTION, ILLEGAL_DATA_ADDRESS, ILLEGAL_DATA_VALUE, SLAVE_DEVICE_FAILURE = 1, 2, 3, 4
#: Slave id 0: every slave applies the request and none replies.
BROADCAST = 0

_FIXED_LENGTH = {1: 8, 2: 8, 3: 8, 4: 8, 5: 8, 6: 8}


def crc16(data: bytes) -> int:
    """CRC-16/MODBUS (polynomial 0xA001 reflected, start 0xFFFF); sent low byte first."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return crc


def with_crc(frame: bytes) -> bytes:
    """`frame` followed by its CRC, as it goes on the wire."""
    return bytes(frame) + crc16(frame).to_bytes(2, "little")


def frame_length(buf: bytes | bytearray) -> int | None:
    """Length of the request at the start of `buf` with its CRC, or None while too little has arrived.
    An unknown function code's length cannot be known: the whole buffer is taken as the frame."""
    if len(buf) < 2:
        return None
    fn = buf[1]
    if fn in _FIXED_LENGTH:
        n = _FIXED_LENGTH[fn]
    elif fn in (15, 16):
        if len(buf) < 7:
            return None
        n = 9 + buf[6]
    else:
        n = len(buf) if len(buf) >= 4 else 0
    return n if n and len(buf) >= n else None


def in_block(address: int, count: int, start: int, size: int) -> bool:
    """Whether registers address..address+count-1 all lie in start..start+size-1."""
    return start <= address and address + count <= start + size


class ModbusError(Exception):
    """A request the device refuses: the reply is exception `code`."""

    def __init__(self, code: int, why: str = ""):
        self.code = int(code)
        super().__init__(why or f"Modbus exception {code}")


class RegisterSlave:
    """One slave id. Subclasses give the register map, either a register at a time (`read_register`,
    `write_register`) or a block at a time (`read_registers`, `write_registers`: a multiple write
    arrives whole, for devices that act on a block); what they do not have answers exception 2.

    `lock` is taken while a request is handled: hold it to change the device from another thread."""

    def __init__(self, slave_id: int):
        self.slave_id = int(slave_id)
        self.lock = threading.RLock()
        #: requests answered, by function code (tests check which functions a driver uses)
        self.requests: dict[int, int] = {}

    # -- the device (override) --------------------------------------------------------------------------
    def read_register(self, address: int) -> int:
        raise ModbusError(ILLEGAL_DATA_ADDRESS, f"no register 0x{address:04X}")

    def write_register(self, address: int, value: int) -> None:
        raise ModbusError(ILLEGAL_DATA_ADDRESS, f"register 0x{address:04X} is not writable")

    def read_registers(self, function: int, address: int, count: int) -> list[int]:
        """Registers address..address+count-1 for function 3 (holding) or 4 (input)."""
        return [self.read_register(a) for a in range(address, address + count)]

    def write_registers(self, address: int, values: list[int]) -> None:
        for a, v in enumerate(values, start=address):
            self.write_register(a, v)

    # -- the protocol -----------------------------------------------------------------------------------
    def handle(self, frame: bytes) -> bytes:
        """The reply to a request (`slave | function | data`, no CRC), the same way; b"" for silence (a
        request for another slave, or a broadcast, which is applied)."""
        if len(frame) < 2:
            return b""
        sid, fn = frame[0], frame[1]
        if sid not in (self.slave_id, BROADCAST):
            return b""
        with self.lock:
            self.requests[fn] = self.requests.get(fn, 0) + 1
            try:
                reply = self._dispatch(fn, bytes(frame[2:]))
            except ModbusError as e:
                reply = bytes([fn | 0x80, e.code])
        return b"" if sid == BROADCAST else bytes([sid]) + reply

    def _dispatch(self, fn: int, data: bytes) -> bytes:
        if fn in (3, 4):
            if len(data) != 4:
                raise ModbusError(ILLEGAL_DATA_VALUE, "a read request has 4 data bytes")
            address, count = struct.unpack(">HH", data)
            if not 1 <= count <= 125:
                raise ModbusError(ILLEGAL_DATA_VALUE, f"cannot read {count} registers")
            values = [int(v) & 0xFFFF for v in self.read_registers(fn, address, count)]
            return bytes([fn, 2 * count]) + struct.pack(f">{count}H", *values)
        if fn == 6:
            if len(data) != 4:
                raise ModbusError(ILLEGAL_DATA_VALUE, "a single write has 4 data bytes")
            address, value = struct.unpack(">HH", data)
            self.write_registers(address, [value])
            return bytes([fn]) + data
        if fn == 16:
            if len(data) < 5:
                raise ModbusError(ILLEGAL_DATA_VALUE, "a multiple write has at least 5 data bytes")
            address, count, nbytes = struct.unpack(">HHB", data[:5])
            if not 1 <= count <= 123 or nbytes != 2 * count or len(data) != 5 + nbytes:
                raise ModbusError(ILLEGAL_DATA_VALUE, "register count and byte count disagree")
            self.write_registers(address, list(struct.unpack(f">{count}H", data[5:])))
            return bytes([fn]) + data[:4]
        raise ModbusError(ILLEGAL_FUNCTION, f"function {fn} is not supported")


class ModbusRtuDevice(PtyDevice):
    """Modbus RTU framing on a pseudo-terminal around `devices` (objects with `handle(frame) -> reply`,
    frames without CRC, such as `RegisterSlave`s), so a driver opens `port` with its Modbus library
    exactly as it opens a USB-RS485 adapter. What the framing does, as slaves on a real line would:

    - a frame's length follows from its function code (8 bytes for 1..6; 9 + byte count for 15, 16), so
      a request split over several reads is put back together, and two back to back are both answered;
    - the CRC is checked; a frame with a bad CRC gets no reply, and what is buffered is dropped;
    - a silence longer than `gap_s` between bytes ends a frame: a partial request left by a master that
      gave up is discarded when the next one starts (RTU's 3.5-character gap is 0.3 ms at 115200 baud,
      shorter than a loaded machine's scheduling jitter on a pty, hence a lenient default);
    - several devices may share the line (different slave ids); the one addressed answers.

    `silent = True` makes the line dead (an unpowered device, a swapped A/B pair) for timeout tests."""

    def __init__(self, *devices: Any, gap_s: float = 0.02, start: bool = True):
        if not devices:
            raise ValueError("ModbusRtuDevice needs at least one device with handle(frame)")
        self.devices = list(devices)
        self.gap_s = float(gap_s)
        #: a dead line: requests are read and never answered
        self.silent = False
        #: frames answered, and frames dropped for a bad CRC
        self.frames = 0
        self.bad_crc = 0
        self._buf = bytearray()
        self._t_last = 0.0
        super().__init__(start=start)

    @property
    def device(self) -> Any:
        """The first (often the only) device on the line."""
        return self.devices[0]

    def on_data(self, data: bytes) -> bytes:
        now = time.monotonic()
        if self._buf and now - self._t_last > self.gap_s:
            self._buf.clear()  # a frame gap: what was buffered was an abandoned partial request
        self._t_last = now
        self._buf += data
        out = bytearray()
        while (n := frame_length(self._buf)) is not None:
            frame, self._buf = bytes(self._buf[:n]), self._buf[n:]
            if crc16(frame[:-2]) != int.from_bytes(frame[-2:], "little"):
                self.bad_crc += 1
                self._buf.clear()  # lost sync: wait for the next frame after a gap
                break
            if self.silent:
                continue
            for device in self.devices:
                reply = device.handle(frame[:-2])
                if reply:
                    out += with_crc(reply)
                    break
            self.frames += 1
        return bytes(out)
