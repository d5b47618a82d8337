"""UFACTORY end effectors as the controller's tool port sees them.

- `XArmGripper`: the xArm Gripper, Modbus slave 8 at 2 Mbaud. Enable 0x0100, mode 0x0101, speed
  0x0303 (r/min), target 0x0700 and position 0x0702 (32-bit, pulses: 0 closed .. 850 open = 85 mm),
  error 0x000F, status 0x0000 (1 moving, 2 stopped on an object), reset 0x0109, versions 0x0801-3.
  `g2=True` is the xArm Gripper G2: same registers, plus the 0x0C00 block (go, speed, force, target)
  the SDK's `set_gripper_g2_position` writes; its pulses map to millimetres through the G2 linkage
  (mm = 110 sin(pulse / 18.28 - 8.33 deg) + 16, 0 .. 84 mm) and its speed register is in pulses.
- `BioGripper`: the BIO Gripper G2, slave 8 at 2 Mbaud: status 0x0000 (bits 0-1 motion: 0 stopped,
  1 moving, 2 object, 3 fault; bits 2-3 enable: 2 enabled), error 0x000F, enable 0x0100, control mode
  0x010A (write 0x110A), speed 0x0303, force 0x0506, target 0x0700 / position 0x0702 (32-bit; in
  control mode 1 pulses = 3.7342 mm - 265.13, 71 .. 150 mm), the 0x0C00 block, SN 0x0B10.
- `Lite6Tool`: the Lite 6 gripper and the vacuum gripper, on tool digital outputs 0 and 1 (1,0 open
  / suction on; 0,1 close; 0,0 stop); digital input 0 reports a held object under suction.
- `RobotiqPort`: a Robotiq 2F-85 at slave 9 (115200 baud) whose registers are another object's
  (`handle(frame) -> reply`, frames without CRC).

The fingers of all of them are `rio.emulation.FingerModel`s (or the simulated fingers of a rio-sim
world, same interface): set `fingers.object_width` to put an object between them.
"""

from __future__ import annotations

import math
import struct

from rio.emulation import ILLEGAL_DATA_ADDRESS, FingerModel, ModbusError, RegisterSlave

GRIPPER_SLAVE = 8
ROBOTIQ_SLAVE = 9


def _split32(value: int) -> tuple[int, int]:
    raw = struct.pack(">i", int(value))
    return int.from_bytes(raw[:2], "big"), int.from_bytes(raw[2:], "big")


def _join32(hi: int, lo: int) -> int:
    return struct.unpack(">i", struct.pack(">HH", hi & 0xFFFF, lo & 0xFFFF))[0]


class _Fingered(RegisterSlave):
    """A Modbus slave (core's `RegisterSlave`: the tool port relays frames without CRC) moving a
    `FingerModel`, with 32-bit target/position registers in pulses."""

    TARGET, POSITION = 0x0700, 0x0702

    def __init__(self, slave_id: int, fingers: FingerModel):
        super().__init__(slave_id)
        self.fingers = fingers
        self.error_code = 0
        self._target_hi = 0
        self.target = self.to_pulses(fingers.update())

    def to_pulses(self, width: float) -> int:
        raise NotImplementedError

    def to_width(self, pulses: int) -> float:
        raise NotImplementedError

    def finger_speed(self) -> float:
        raise NotImplementedError

    def can_move(self) -> bool:
        return True

    def go(self, pulses: int) -> None:
        self.target = int(pulses)
        if self.can_move() and self.error_code == 0:
            self.fingers.command(self.to_width(self.target), speed=self.finger_speed())

    def motion_status(self) -> int:
        """0 stopped, 1 moving, 2 stopped on an object."""
        if self.fingers.object_detected:
            return 2
        return 1 if self.fingers.moving else 0

    def read32(self, addr: int) -> int | None:
        if addr == self.POSITION:
            return self.to_pulses(self.fingers.update())
        if addr == self.TARGET:
            return self.target
        return None

    def read_register(self, addr: int) -> int:
        for base in (self.TARGET, self.POSITION):
            if addr in (base, base + 1):
                hi, lo = _split32(self.read32(base) or 0)
                return hi if addr == base else lo
        raise ModbusError(ILLEGAL_DATA_ADDRESS)

    def write_register(self, addr: int, value: int) -> None:
        if addr == self.TARGET:
            self._target_hi = value
        elif addr == self.TARGET + 1:
            self.go(_join32(self._target_hi, value))
        else:
            raise ModbusError(ILLEGAL_DATA_ADDRESS)


class XArmGripper(_Fingered):
    """The xArm Gripper (or G2 with `g2=True`) on the tool RS-485 port, slave 8."""

    baud = 2_000_000
    G1_WIDTH, G2_WIDTH = 0.085, 0.084

    def __init__(self, fingers: FingerModel | None = None, g2: bool = False):
        self.g2 = g2
        self.enabled = False
        self.mode = 0
        self.speed = 1500 if not g2 else self._g2_speed_pulses(100.0)  # r/min (G1), pulse units (G2)
        self.force = 50
        self.versions = (5, 1, 0) if g2 else (3, 4, 3)
        super().__init__(GRIPPER_SLAVE, fingers or FingerModel(self.G2_WIDTH if g2 else self.G1_WIDTH))

    # -- units -----------------------------------------------------------------------------------
    @staticmethod
    def _g2_speed_pulses(mm_s: float) -> int:
        return int(((mm_s * 60) / 9.88235 + 140) / 0.4)

    def to_pulses(self, width: float) -> int:
        if not self.g2:
            return int(round(width * 10000.0))  # 850 pulses = 85 mm
        mm = min(max(width * 1000.0, 0.0), 84.0)
        return int(round((math.degrees(math.asin((mm - 16.0) / 110.0)) + 8.33) * 18.28))

    def to_width(self, pulses: int) -> float:
        if not self.g2:
            return pulses / 10000.0
        return (math.sin(math.radians(pulses / 18.28 - 8.33)) * 110.0 + 16.0) / 1000.0

    def finger_speed(self) -> float:
        if self.g2:
            return max((self.speed * 0.4 - 140) * 9.88235 / 60.0, 1.0) / 1000.0  # mm/s -> m/s
        return max(self.speed, 1) / 5000.0 * 0.15  # 5000 r/min ~ 0.15 m/s of opening

    def can_move(self) -> bool:
        return self.enabled and self.mode == 0

    # -- registers -------------------------------------------------------------------------------
    def read_register(self, addr: int) -> int:
        regs = {0x0000: self.motion_status(), 0x000F: self.error_code, 0x0100: int(self.enabled),
                0x0101: self.mode, 0x0303: self.speed, 0x0500: self.force,
                0x0801: self.versions[0], 0x0802: self.versions[1], 0x0803: self.versions[2]}
        if addr in regs:
            return regs[addr]
        return super().read_register(addr)

    def write_registers(self, addr: int, values: list[int]) -> None:
        if addr == 0x0C00 and len(values) == 5:  # G2 block: go, speed, force, target (32-bit)
            _, self.speed, self.force = values[:3]
            self.enabled = True
            self.go(_join32(values[3], values[4]))
            return
        super().write_registers(addr, values)

    def write_register(self, addr: int, value: int) -> None:
        if addr == 0x0100:
            self.enabled = bool(value)
            if not self.enabled:
                self.fingers.command(self.fingers.update())  # released: stays where it is
        elif addr == 0x0101:
            self.mode = int(value)
        elif addr == 0x0303:
            self.speed = int(value)
        elif addr == 0x0500:
            self.force = int(value)
        elif addr == 0x0109:
            self.error_code = 0
        elif addr in (0x0817, 0x0C00):
            pass  # set zero / lone G2 "go" word: nothing to model
        else:
            super().write_register(addr, value)

    # -- the old register protocol (controller registers TGPIO_*16B/32B with device id 8) ----------
    def reg_read(self, addr: int, wide: bool) -> int | None:
        if wide:
            return self.read32(addr)
        try:
            return self.read_register(addr)
        except ModbusError:
            return None

    def reg_write(self, addr: int, value: int, wide: bool) -> bool:
        try:
            if wide and addr == self.TARGET:
                self.go(value)
            else:
                self.write_register(addr, value)
        except ModbusError:
            return False
        return True


class BioGripper(_Fingered):
    """The BIO Gripper G2 on the tool RS-485 port, slave 8: 71 .. 150 mm."""

    baud = 2_000_000
    MIN_MM, MAX_MM = 71.0, 150.0
    SN = "BIO2G000000001"

    def __init__(self, fingers: FingerModel | None = None):
        self.enable_state = 0  # 0 disabled, 2 enabled
        self.control_mode = 1  # 1: positions in pulses, 0: in mm
        self.speed = 2000
        self.force = 100
        super().__init__(GRIPPER_SLAVE, fingers or FingerModel(self.MAX_MM / 1000.0))

    def to_pulses(self, width: float) -> int:
        return int(round(width * 1000.0 * 3.7342 - 265.13))

    def to_width(self, pulses: int) -> float:
        mm = (pulses + 265.13) / 3.7342 if self.control_mode == 1 else float(pulses)
        return min(max(mm, self.MIN_MM), self.MAX_MM) / 1000.0

    def finger_speed(self) -> float:
        return max(self.speed, 1) / 2000.0 * 0.1  # 2000 ~ 0.1 m/s

    def can_move(self) -> bool:
        return self.enable_state == 2

    def read_register(self, addr: int) -> int:
        if addr == 0x0000:
            motion = 3 if self.error_code else self.motion_status()
            return motion | (self.enable_state << 2)
        regs = {0x000F: self.error_code, 0x0100: int(self.enable_state == 2), 0x010A: self.control_mode,
                0x0303: self.speed, 0x0506: self.force, 0x0801: 2, 0x0802: 1, 0x0803: 0}
        if addr in regs:
            return regs[addr]
        if 0x0B10 <= addr < 0x0B10 + 16:  # SN, one character per register, as the SDK decodes it
            i = addr - 0x0B10
            c = ord(self.SN[i]) if i < len(self.SN) else 0
            return ((c // 10) << 8) | (c % 10)
        return super().read_register(addr)

    def write_registers(self, addr: int, values: list[int]) -> None:
        if addr == 0x0C00 and len(values) == 5:
            _, self.speed, self.force = values[:3]
            self.go(_join32(values[3], values[4]))
            return
        super().write_registers(addr, values)

    def write_register(self, addr: int, value: int) -> None:
        if addr == 0x0100:
            self.enable_state = 2 if value else 0
            if not value:
                self.fingers.command(self.fingers.update())
        elif addr == 0x000F:
            self.error_code = 0
        elif addr in (0x110A, 0x010A):
            self.control_mode = int(value)
        elif addr == 0x0303:
            self.speed = int(value)
        elif addr == 0x0506:
            self.force = int(value)
        elif addr in (0x0607, 0x0C00):
            pass  # MCU reset / lone "go" word
        else:
            super().write_register(addr, value)


class Lite6Tool:
    """The Lite 6 gripper and vacuum gripper: tool digital outputs 0 and 1 drive them, digital input 0
    says whether the suction cup holds something (`vacuum_object`)."""

    WIDTH = 0.02  # opening of the Lite 6 gripper's fingers (m), assumed
    SPEED = 0.04  # m/s: about half a second from open to closed

    def __init__(self, fingers: FingerModel | None = None):
        self.fingers = fingers or FingerModel(self.WIDTH, speed=self.SPEED)
        self.suction = False
        #: Set by tests: an object under the suction cup (picked up while suction is on).
        self.vacuum_object = False

    def on_outputs(self, bits: int) -> None:
        do0, do1 = bits & 1, (bits >> 1) & 1
        self.suction = bool(do0 and not do1)
        if do0 and not do1:
            self.fingers.command(self.fingers.max_width)
        elif do1 and not do0:
            self.fingers.command(0.0)
        else:
            self.fingers.command(self.fingers.update())  # stop: hold where they are

    def inputs(self) -> int:
        return int(self.suction and self.vacuum_object)


class RobotiqPort:
    """A Robotiq 2F-85 at slave 9 on the tool RS-485 port: frames go to `registers.handle` as they are."""

    baud = 115_200

    def __init__(self, registers):
        if not callable(getattr(registers, "handle", None)):
            raise TypeError("robotiq= needs an object with handle(frame: bytes) -> bytes")
        self.registers = registers
        self.slave_id = ROBOTIQ_SLAVE

    @property
    def fingers(self):
        return getattr(self.registers, "fingers", None)

    def handle(self, frame: bytes) -> bytes | None:
        if len(frame) < 2 or frame[0] != self.slave_id:
            return None
        return self.registers.handle(bytes(frame))
