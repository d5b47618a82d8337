"""Robotiq 2F-85 / 2F-140 / Hand-E register map (instruction manuals, "Control"): the byte layout both
transports reduce to, and its decoding into `RobotiqStatus`.

Robot output (what the master writes), registers from 0x03E8, high byte first:
    byte 0 ACTION REQUEST  rACT (bit 0), rGTO (bit 3), rATR (bit 4), rARD (bit 5)
    byte 1-2 reserved, byte 3 rPR position request, byte 4 rSP speed, byte 5 rFR force
Robot input (status), registers from 0x07D0:
    byte 0 GRIPPER STATUS  gACT (bit 0), gGTO (bit 3), gSTA (bits 4-5), gOBJ (bits 6-7)
    byte 1 reserved, byte 2 FAULT STATUS gFLT (bits 0-3, kFLT above), byte 3 gPR echo,
    byte 4 gPO position, byte 5 gCU current (about 10 mA per count)
Positions: 0 = open, 255 = closed.
"""

from __future__ import annotations

from dataclasses import dataclass

OUTPUT_ADDRESS = 0x03E8
INPUT_ADDRESS = 0x07D0
#: each block is 16 bytes (8 registers); bytes 6..15 are reserved
BLOCK_REGISTERS = 8
#: the registers a command or a status read needs (bytes 0..5)
USED_REGISTERS = 3
DEFAULT_SLAVE_ID = 9

ACT, GTO, ATR, ARD = 0x01, 0x08, 0x10, 0x20

#: gSTA
STA_RESET, STA_ACTIVATING, STA_ACTIVE = 0, 1, 3
#: gOBJ
OBJ_MOVING, OBJ_CONTACT_OPENING, OBJ_CONTACT_CLOSING, OBJ_AT_POSITION = 0, 1, 2, 3

#: gCU: amperes per count
CURRENT_PER_COUNT = 0.010


def action_registers(act: bool, gto: bool, position: int, speed: int, force: int) -> list[int]:
    """The three output registers for one command (rATR/rARD stay 0: no automatic release)."""
    action = (ACT if act else 0) | (GTO if gto else 0)
    return [action << 8, position & 0xFF, ((speed & 0xFF) << 8) | (force & 0xFF)]


@dataclass
class RobotiqStatus:
    """The status bytes, decoded. Fields a transport did not read are None (the URCap socket reads
    only what a cycle needs)."""

    gOBJ: int
    gFLT: int
    gPO: int
    gACT: int | None = None
    gGTO: int | None = None
    gSTA: int | None = None
    gPR: int | None = None
    gCU: int | None = None

    @property
    def activated(self) -> bool:
        return self.gACT == 1 and self.gSTA == STA_ACTIVE

    @property
    def object_detected(self) -> bool:
        """Fingers stopped on contact, while opening (1) or closing (2)."""
        return self.gOBJ in (OBJ_CONTACT_OPENING, OBJ_CONTACT_CLOSING)

    @classmethod
    def from_registers(cls, regs: list[int]) -> RobotiqStatus:
        status, fault_byte, echo = regs[0] >> 8, regs[1] >> 8, regs[1] & 0xFF
        return cls(gOBJ=(status >> 6) & 0x3, gFLT=fault_byte & 0x0F, gPO=regs[2] >> 8, gACT=status & 0x1,
                   gGTO=(status >> 3) & 0x1, gSTA=(status >> 4) & 0x3, gPR=echo, gCU=regs[2] & 0xFF)
