"""Feetech (SCS/STS) wire protocol facts, shared by the driver side and the emulated bus.

Instruction packet: `FF FF id len inst params.. chk`; status packet: `FF FF id len error params.. chk`;
`len` counts the bytes after itself, `chk = ~(id + len + inst|error + sum(params)) & 0xFF`. Broadcast
id 0xFE: no servo answers, except each listed id of a SYNC READ, in the order listed.
"""

from __future__ import annotations

BROADCAST_ID = 0xFE
HEADER = b"\xff\xff"

PING, READ, WRITE, REG_WRITE, ACTION = 0x01, 0x02, 0x03, 0x04, 0x05
SYNC_READ, SYNC_WRITE = 0x82, 0x83

# Error bits of a status packet (and of the STATUS register).
ERR_VOLTAGE = 0x01
ERR_ANGLE = 0x02
ERR_OVERHEAT = 0x04
ERR_OVERCURRENT = 0x08
ERR_OVERLOAD = 0x20

ERROR_NAMES = {
    ERR_VOLTAGE: "input voltage out of range",
    ERR_ANGLE: "angle sensor error",
    ERR_OVERHEAT: "overheat",
    ERR_OVERCURRENT: "overcurrent",
    ERR_OVERLOAD: "overload",
}


def describe_error(bits: int) -> str:
    """'overload, overheat' for the bits set (unknown bits by value)."""
    names = [name for bit, name in ERROR_NAMES.items() if bits & bit]
    unknown = bits & ~sum(ERROR_NAMES)
    if unknown:
        names.append(f"unknown error bits 0x{unknown:02x}")
    return ", ".join(names) or "no error"


def checksum(body) -> int:
    """Checksum of the bytes from the id to the last parameter."""
    return ~sum(body) & 0xFF


def packet(servo_id: int, code: int, params=b"") -> bytes:
    """An instruction (code = instruction) or status (code = error bits) packet."""
    body = bytes([servo_id, len(params) + 2, code]) + bytes(params)
    return HEADER + body + bytes([checksum(body)])
