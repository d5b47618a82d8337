"""`ModbusRtuDevice` as a serial line: CRC against the Robotiq manual's frames, requests split over
several writes or sent back to back, bad CRCs and abandoned partial frames, several slaves on a line,
a dead line. Raw bytes through pyserial, as a master sees them."""

from __future__ import annotations

import time

import pytest
import serial
from rio_robotiq.emulator import DhRegisters, ModbusRtuDevice, RobotiqRegisters

from rio.emulation import crc16, frame_length, with_crc


def h(text: str) -> bytes:
    return bytes.fromhex(text)


@pytest.mark.parametrize("frame, crc", [
    ("09 10 03 E8 00 03 06 00 00 00 00 00 00", "73 30"),  # the manuals' activation request
    ("09 03 07 D0 00 01", "85 CF"),                       # status read
    ("09 10 03 E8 00 03 06 09 00 00 FF FF FF", "42 29"),  # close at full speed and force
    ("01 06 01 03 01 F4", "78 21"),                       # DH: position 500
])
def test_crc_matches_the_manuals(frame, crc):
    assert with_crc(h(frame))[-2:] == h(crc)
    assert crc16(h(frame)) == int.from_bytes(h(crc), "little")


def test_frame_length():
    assert frame_length(h("09 03 07")) is None
    assert frame_length(h("09 03 07 D0 00 01 85 CF")) == 8
    assert frame_length(h("09 10 03 E8 00 03")) is None  # byte count not there yet
    assert frame_length(h("09 10 03 E8 00 03 06 00")) is None
    assert frame_length(with_crc(h("09 10 03 E8 00 03 06 00 00 00 00 00 00"))) == 15


@pytest.fixture
def line():
    with ModbusRtuDevice(RobotiqRegisters("2f85"), DhRegisters("ag95")) as dev:
        port = serial.Serial(dev.port, 115200, timeout=0.5)
        try:
            yield dev, port
        finally:
            port.close()


def exchange(port: serial.Serial, *chunks: bytes, expect: int, pause: float = 0.0) -> bytes:
    port.reset_input_buffer()
    for c in chunks:
        port.write(c)
        port.flush()
        time.sleep(pause)
    return port.read(expect)


STATUS = with_crc(h("09 03 07 D0 00 01"))
STATUS_REPLY = with_crc(h("09 03 02 00 00"))


def test_a_request_split_over_writes_is_answered_once(line):
    _, port = line
    assert exchange(port, STATUS[:3], STATUS[3:5], STATUS[5:], expect=7, pause=0.002) == STATUS_REPLY
    assert port.read(1) == b""


def test_back_to_back_requests_are_both_answered(line):
    _, port = line
    dh = with_crc(h("01 03 02 00 00 01"))
    assert exchange(port, STATUS + dh, expect=14) == STATUS_REPLY + with_crc(h("01 03 02 00 00"))


def test_a_bad_crc_gets_no_reply_and_the_next_frame_does(line):
    dev, port = line
    bad = STATUS[:-1] + bytes([STATUS[-1] ^ 0xFF])
    assert exchange(port, bad, expect=7) == b""
    assert dev.bad_crc == 1
    time.sleep(dev.gap_s * 2)
    assert exchange(port, STATUS, expect=7) == STATUS_REPLY


def test_a_gap_drops_an_abandoned_partial_frame(line):
    dev, port = line
    assert exchange(port, STATUS[:4], expect=1) == b""  # half a request, then the master gave up (timeout)
    time.sleep(dev.gap_s * 2)
    assert exchange(port, STATUS, expect=7) == STATUS_REPLY


def test_write_multiple_through_the_line(line):
    dev, port = line
    write = with_crc(h("09 10 03 E8 00 03 06 01 00 00 00 00 00"))
    assert exchange(port, write, expect=8) == with_crc(h("09 10 03 E8 00 03"))
    assert dev.device.rACT == 1
    assert dev.frames >= 1


def test_a_silent_line(line):
    dev, port = line
    dev.silent = True
    assert exchange(port, STATUS, expect=7) == b""
