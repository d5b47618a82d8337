"""ATI's Raw Data Transfer (RDT) protocol of the Net F/T box, written from its documented layout: one
place for the bytes, so the driver and the emulator cannot disagree.

The host sends an 8-byte request to UDP port 49152, network byte order:

    uint16 header = 0x1234    uint16 command    uint32 sample_count (0: stream until told to stop)

and the box answers each requested sample with a 36-byte record (several per datagram in buffered mode):

    uint32 rdt_sequence   one per record of this stream, from 1 at every start (a gap: a lost datagram)
    uint32 ft_sequence    one per internal sample (the box samples at 7000 Hz; the step is the decimation)
    uint32 status         0 when healthy; bits set on saturation, a broken gage, a threshold monitor
    int32  Fx Fy Fz Tx Ty Tz   counts: divide by the calibration's counts per force / torque unit

Counts per unit come from the box's configuration page (`rio_ati.calibration`), not from this protocol.
"""

from __future__ import annotations

import struct
from typing import NamedTuple

PORT = 49152
HEADER = 0x1234
REQUEST = struct.Struct(">HHI")
RECORD = struct.Struct(">III6i")

STOP = 0x0000               # stop streaming
START_REALTIME = 0x0002     # one record per datagram, at the configured RDT rate
START_BUFFERED = 0x0003     # `buffer size` records per datagram
START_MULTI_UNIT = 0x0004   # as buffered, for several boxes on one host (not emulated)
RESET_THRESHOLD_LATCH = 0x0041
SET_SOFTWARE_BIAS = 0x0042  # the box subtracts the present reading from every later one

COMMANDS = {STOP: "stop", START_REALTIME: "start realtime", START_BUFFERED: "start buffered",
            START_MULTI_UNIT: "start multi-unit", RESET_THRESHOLD_LATCH: "reset threshold latch",
            SET_SOFTWARE_BIAS: "set software bias"}


class Record(NamedTuple):
    rdt_sequence: int
    ft_sequence: int
    status: int
    counts: tuple[int, int, int, int, int, int]


def request(command: int, sample_count: int = 0) -> bytes:
    """The 8 bytes that ask the box for `command` (a sample count of 0: until stopped)."""
    return REQUEST.pack(HEADER, command, sample_count)


def parse_request(data: bytes) -> tuple[int, int]:
    """(command, sample_count) of a request, or ValueError saying what is wrong with it."""
    if len(data) != REQUEST.size:
        raise ValueError(f"an RDT request is {REQUEST.size} bytes, got {len(data)}")
    header, command, count = REQUEST.unpack(data)
    if header != HEADER:
        raise ValueError(f"RDT request header 0x{header:04x}, expected 0x{HEADER:04x}")
    return command, count


def record(rdt_sequence: int, ft_sequence: int, status: int, counts) -> bytes:
    """One 36-byte record (sequence numbers wrap at 2**32, counts are clipped to int32)."""
    c = [max(-(2**31), min(2**31 - 1, int(round(v)))) for v in counts]
    return RECORD.pack(rdt_sequence & 0xFFFFFFFF, ft_sequence & 0xFFFFFFFF, status & 0xFFFFFFFF, *c)


def parse_records(data: bytes) -> list[Record]:
    """Every record of one datagram (one in realtime mode, several in buffered mode)."""
    if not data or len(data) % RECORD.size:
        raise ValueError(f"an RDT datagram is a whole number of {RECORD.size}-byte records, got {len(data)} bytes")
    out = []
    for i in range(0, len(data), RECORD.size):
        v = RECORD.unpack_from(data, i)
        out.append(Record(v[0], v[1], v[2], tuple(v[3:])))
    return out


def sequence_gap(previous: int, current: int) -> int:
    """Records missing between two rdt_sequence numbers (wrapping at 2**32); 0 when consecutive, and 0 when
    the sequence went back (a new stream: the box numbers every stream's records from 1)."""
    step = (current - previous) & 0xFFFFFFFF
    return 0 if step >= 2**31 else max(step - 1, 0)
