"""The xArm controller's TCP framing, as the controller puts it on the wire (written from the protocol,
independently of the SDK, so that tests through the unmodified SDK check both ends).

Command port (502): Modbus-TCP-like frames. A request is

    transaction id (u16 BE) | protocol id (u16 BE) | length (u16 BE) | register (u8) | params

where length counts the register byte and the params. The private protocol (id 2, or 3 once the
client keeps the connection alive with heartbeats) answers with the same header, the register, one
*status byte* and the reply params (length = 2 + params). The status byte is how the controller tells
every caller about its condition on every reply: 0x40 an error is active, 0x20 a warning is active,
0x10 the arm is not ready to move, 0x08 this command was invalid. Protocol id 0 is plain Modbus TCP
(unit id + function code); the controller serves its GPIO that way. Feedback frames (motion started,
finished, triggered) are pushed on the command connection with register 0xFF.

Numbers: multi-byte integers are big-endian, floats are little-endian IEEE fp32.

Report ports (30001 normal, 30002 rich, 30003 real-time): a stream of fixed-size frames, each
starting with its total length (u32 BE); see `report.py`.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

COMMAND_PORT = 502
REPORT_NORMAL_PORT = 30001
REPORT_RICH_PORT = 30002
REPORT_REAL_PORT = 30003

PROTOCOL_MODBUS = 0
PROTOCOL_HEARTBEAT = 1
PROTOCOL_PRIVATE = 2
PROTOCOL_PRIVATE_KEEPALIVE = 3
PRIVATE_PROTOCOLS = (PROTOCOL_PRIVATE, PROTOCOL_PRIVATE_KEEPALIVE)

FEEDBACK_REGISTER = 0xFF

# status byte of a private-protocol reply
STATUS_INVALID = 0x08
STATUS_NOT_READY = 0x10
STATUS_WARN = 0x20
STATUS_ERROR = 0x40

HEADER = struct.Struct(">HHHB")  # transaction, protocol, length, register/unit


@dataclass(frozen=True)
class Request:
    transaction: int
    protocol: int
    register: int
    params: bytes


def split_frames(buf: bytearray) -> Iterator[Request]:
    """Complete requests at the head of `buf` (consumed from it); a partial frame stays for later."""
    while len(buf) >= 6:
        length = int.from_bytes(buf[4:6], "big")
        if len(buf) < 6 + length:
            return
        frame = bytes(buf[:6 + length])
        del buf[:6 + length]
        if length < 1:
            continue  # nothing to answer: not even a register
        tid, prot, _, reg = HEADER.unpack_from(frame)
        yield Request(tid, prot, reg, frame[7:])


def reply(req: Request, status: int, params: bytes = b"") -> bytes:
    """A private-protocol reply to `req`: its register, the status byte, `params`."""
    return HEADER.pack(req.transaction, req.protocol, 2 + len(params), req.register) + bytes([status & 0xFF]) + params


def modbus_reply(req: Request, pdu: bytes) -> bytes:
    """A plain Modbus-TCP reply (protocol 0): unit id echoed, then the response PDU."""
    return HEADER.pack(req.transaction, req.protocol, 1 + len(pdu), req.register) + pdu


def feedback_frame(transaction: int, protocol: int, status: int, kind: int, register: int, code: int,
                   task_id: int = 0, t_us: int = 0) -> bytes:
    """A feedback frame for the command sent with `transaction`: `kind` 1 started, 2 finished (or
    discarded), 4 triggered; `code` 0 success, 1 failure, 2 discarded; `t_us` the controller time."""
    body = bytes([status & 0xFF, kind & 0xFF, register & 0xFF]) + struct.pack(">HBQ", task_id & 0xFFFF, code & 0xFF,
                                                                              t_us & 0xFFFFFFFFFFFFFFFF)
    return HEADER.pack(transaction, protocol, 1 + len(body), FEEDBACK_REGISTER) + body


# -- parameter encodings ------------------------------------------------------------------------------
def floats(data: bytes, n: int | None = None, offset: int = 0) -> list[float]:
    """`n` little-endian fp32 from `data` at `offset` (all that fit when n is None)."""
    if n is None:
        n = (len(data) - offset) // 4
    return list(struct.unpack_from(f"<{n}f", data, offset))


def pack_floats(values: Iterable[float]) -> bytes:
    vals = [float(v) for v in values]
    return struct.pack(f"<{len(vals)}f", *vals)


def u16(value: int) -> bytes:
    return struct.pack(">H", int(value) & 0xFFFF)


def s32(value: int) -> bytes:
    return struct.pack(">i", int(value))


def text(value: str, size: int) -> bytes:
    """`value` as ASCII, NUL-terminated, padded with NULs to at least `size` bytes."""
    raw = value.encode("ascii") + b"\0"
    return raw + b"\0" * max(size - len(raw), 0)
