"""Dynamixel Protocol 2.0 framing, written from the protocol's description (the servo side of it: the
emulated bus parses instruction packets and builds status packets; the driver side is dynamixel-sdk).

    FF FF FD 00 | id | len_lo len_hi | instruction | params... | crc_lo crc_hi

`len` counts instruction, params and CRC. The CRC is CRC-16 with polynomial 0x8005 (not reflected,
initial value 0) over everything before it. Byte stuffing keeps a header out of the payload: after
every FF FF FD inside instruction+params an extra FD is sent (and counted in `len`); the receiver
drops it. A status packet's instruction is 0x55 and its first parameter the error byte.
"""

from __future__ import annotations

HEADER = b"\xff\xff\xfd\x00"
BROADCAST_ID = 0xFE

PING, READ, WRITE, REG_WRITE, ACTION, FACTORY_RESET, REBOOT = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x08
STATUS = 0x55
SYNC_READ, SYNC_WRITE, FAST_SYNC_READ = 0x82, 0x83, 0x8A
BULK_READ, BULK_WRITE = 0x92, 0x93

#: Error byte of a status packet: bit 7 is the hardware alert, the low bits one of these numbers.
ERR_RESULT_FAIL, ERR_INSTRUCTION, ERR_CRC, ERR_DATA_RANGE, ERR_DATA_LENGTH, ERR_DATA_LIMIT, ERR_ACCESS = range(1, 8)
ERR_ALERT = 0x80


def _crc_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        c = byte << 8
        for _ in range(8):
            c = ((c << 1) ^ 0x8005) if c & 0x8000 else (c << 1)
        table.append(c & 0xFFFF)
    return tuple(table)


_TABLE = _crc_table()


def crc16(data: bytes | bytearray) -> int:
    crc = 0
    for b in data:
        crc = ((crc << 8) ^ _TABLE[((crc >> 8) ^ b) & 0xFF]) & 0xFFFF
    return crc


def stuff(payload: bytes) -> bytes:
    """Insert FD after every FF FF FD (the payload follows the 7 header bytes, which end in a length
    byte, so a header cannot straddle the boundary)."""
    out = bytearray()
    for b in payload:
        out.append(b)
        if b == 0xFD and out[-3:-1] == b"\xff\xff":
            out.append(0xFD)
    return bytes(out)


def unstuff(payload: bytes) -> bytes:
    out = bytearray()
    i = 0
    while i < len(payload):
        b = payload[i]
        out.append(b)
        if b == 0xFD and out[-3:-1] == b"\xff\xff" and i + 1 < len(payload) and payload[i + 1] == 0xFD:
            i += 1  # the stuffed FD
        i += 1
    return bytes(out)


def packet(servo_id: int, instruction: int, params: bytes = b"") -> bytes:
    """One complete packet (stuffed, with CRC)."""
    body = stuff(bytes([instruction]) + bytes(params))
    length = len(body) + 2
    head = HEADER + bytes([servo_id & 0xFF, length & 0xFF, length >> 8])
    crc = crc16(head + body)
    return head + body + bytes([crc & 0xFF, crc >> 8])


def status(servo_id: int, error: int = 0, params: bytes = b"") -> bytes:
    return packet(servo_id, STATUS, bytes([error & 0xFF]) + bytes(params))


class Parser:
    """Splits a byte stream into (id, instruction, params) of CRC-valid packets; counts what it drops."""

    def __init__(self) -> None:
        self.buf = bytearray()
        self.bad_crc = 0

    def feed(self, data: bytes):
        self.buf += data
        buf = self.buf
        while True:
            start = buf.find(HEADER)
            if start < 0:
                del buf[:max(len(buf) - 3, 0)]  # a header may be split across reads
                return
            del buf[:start]
            if len(buf) < 7:
                return
            total = 7 + (buf[5] | buf[6] << 8)
            if total < 10:
                del buf[:1]
                continue
            if len(buf) < total:
                return
            pkt = bytes(buf[:total])
            if crc16(pkt[:-2]) != (pkt[-2] | pkt[-1] << 8):
                self.bad_crc += 1
                del buf[:1]  # resynchronise on the next header
                continue
            del buf[:total]
            body = unstuff(pkt[7:-2])
            yield pkt[4], body[0], body[1:]


def u16(data: bytes, i: int = 0) -> int:
    return data[i] | data[i + 1] << 8


def le(value: int, size: int) -> bytes:
    """`value` as `size` little-endian bytes (two's complement for negatives)."""
    return (int(value) & ((1 << (8 * size)) - 1)).to_bytes(size, "little")


def signed(data: bytes | list[int], size: int = 4) -> int:
    return int.from_bytes(bytes(data[:size]), "little", signed=True)
