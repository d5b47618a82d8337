"""The emulator building blocks plugins test their drivers against."""

from __future__ import annotations

import os
import select
import socket
import threading

import pytest

from rio.emulation import (
    ILLEGAL_DATA_ADDRESS,
    FingerModel,
    ModbusError,
    ModbusRtuDevice,
    PtyDevice,
    RegisterSlave,
    TcpDevice,
    crc16,
    frame_length,
    with_crc,
)
from rio.testing import wait_until


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_fingers_travel_at_speed_and_stop_on_an_object():
    clock = Clock()
    f = FingerModel(0.085, speed=0.1, clock=clock)
    f.object_width = 0.03
    f.command(0.0)
    clock.t = 0.2
    assert abs(f.update() - 0.065) < 1e-9 and f.moving and not f.object_detected
    clock.t = 2.0
    assert f.update() == 0.03 and f.object_detected and not f.moving
    f.command(0.08)  # opening leaves the object
    clock.t = 3.0
    assert abs(f.update() - 0.08) < 1e-9 and not f.object_detected
    f.command(0.05)  # closing to a goal wider than the object never touches it
    clock.t = 4.0
    assert abs(f.update() - 0.05) < 1e-9 and not f.object_detected


class Upper(PtyDevice):
    def on_data(self, data: bytes) -> bytes:
        return data.upper()


def exchange(port: str, request: bytes, expect: int, timeout: float = 3.0) -> bytes:
    """Write `request` to the serial device at `port`; what comes back, up to `expect` bytes."""
    fd = os.open(port, os.O_RDWR | os.O_NOCTTY)
    try:
        os.write(fd, request)
        got = b""
        while len(got) < expect and select.select([fd], [], [], timeout)[0]:
            got += os.read(fd, 256)
        return got
    finally:
        os.close(fd)


def test_pty_device_answers_on_its_port():
    with Upper() as dev:
        assert exchange(dev.port, b"ping", 4) == b"PING"


class Named(Upper):
    thread_name = "rio-test-upper"


def test_pty_device_started_later_serves_in_a_named_thread():
    dev = Named(start=False)
    closed = []
    dev.on_close(lambda: closed.append(True))
    try:
        assert not any(t.name.startswith("rio-test-upper") for t in threading.enumerate())
        assert dev.start() is dev and dev.start() is dev  # idempotent
        assert any(t.name == f"rio-test-upper-{dev.port}" for t in threading.enumerate())
        assert exchange(dev.port, b"late", 4) == b"LATE"
    finally:
        dev.close()
    assert closed == [True] and not any(t.name.startswith("rio-test-upper") for t in threading.enumerate())


class _SdkPort:
    """The part of a servo SDK's `PortHandler` that `port_handler` changes (a stand-in for the SDK's class):
    its own packet timeout, 34 ms."""

    def __init__(self, port: str):
        self.port = port

    def setPacketTimeout(self, packet_length: int) -> None:  # noqa: N802 (SDK name)
        self.packet_timeout = 34.0


def test_a_servo_port_this_process_emulates_waits_longer_for_its_answers():
    """Whoever opens a pty a `PtyDevice` of this process serves gets the slack a thread needs on a loaded
    machine; a real port, or the pty once its device closed, keeps the SDK's own timeout."""
    from rio.machine.servo_port import EMULATED_SLACK_MS, port_handler

    def timeout(port: str) -> float:
        ph = port_handler(_SdkPort, port)
        ph.setPacketTimeout(10)
        return ph.packet_timeout

    dev = Upper(start=False)
    try:
        assert timeout(dev.port) == EMULATED_SLACK_MS
        assert timeout("/dev/ttyUSB0") == 34.0
    finally:
        dev.close()
    assert timeout(dev.port) == 34.0


# -- Modbus ------------------------------------------------------------------------------------------------
def h(text: str) -> bytes:
    return bytes.fromhex(text)


class SmallMap(RegisterSlave):
    """Registers 0x10..0x13 a register at a time; 0x13 takes 0..100 only."""

    def __init__(self, slave_id: int = 5):
        super().__init__(slave_id)
        self.regs = {0x10: 1, 0x11: 2, 0x12: 3, 0x13: 4}

    def read_register(self, address: int) -> int:
        if address not in self.regs:
            return super().read_register(address)
        return self.regs[address]

    def write_register(self, address: int, value: int) -> None:
        if address not in self.regs:
            super().write_register(address, value)
        if address == 0x13 and value > 100:
            raise ModbusError(3, "0..100")
        self.regs[address] = value


class Block(RegisterSlave):
    """One block 0x100..0x102 written whole."""

    def __init__(self) -> None:
        super().__init__(7)
        self.writes: list[tuple[int, list[int]]] = []

    def read_registers(self, function: int, address: int, count: int) -> list[int]:
        return [function] * count

    def write_registers(self, address: int, values: list[int]) -> None:
        if address != 0x100:
            raise ModbusError(ILLEGAL_DATA_ADDRESS)
        self.writes.append((address, values))


def test_crc_and_frame_length():
    assert crc16(h("01 06 01 03 01 F4")) == 0x2178 and with_crc(h("01 06 01 03 01 F4"))[-2:] == h("78 21")
    assert frame_length(h("05 03 00")) is None and frame_length(h("05 03 00 10 00 02 00 00 FF")) == 8
    assert frame_length(h("05 10 00 10 00 02")) is None  # the byte count is not there yet
    assert frame_length(with_crc(h("05 10 00 10 00 02 04 00 07 00 08"))) == 13


@pytest.mark.parametrize("request_hex, reply_hex", [
    ("05 03 00 10 00 02", "05 03 04 00 01 00 02"),                # read holding registers
    ("05 04 00 12 00 02", "05 04 04 00 03 00 04"),                # read input registers
    ("05 06 00 11 00 09", "05 06 00 11 00 09"),                   # write one: echo
    ("05 10 00 10 00 02 04 00 07 00 08", "05 10 00 10 00 02"),    # write many: address and count
    ("05 2B 0E 01 00", "05 AB 01"),                               # illegal function
    ("05 03 00 13 00 02", "05 83 02"),                            # runs past the map: illegal address
    ("05 06 00 20 00 01", "05 86 02"),
    ("05 06 00 13 00 65", "05 86 03"),                            # the device refuses the value
    ("05 03 00 10 00 00", "05 83 03"),                            # zero registers
    ("05 10 00 10 00 02 06 00 00 00 00 00 00", "05 90 03"),       # 2 registers but 6 bytes
    ("06 03 00 10 00 01", ""),                                    # another slave: silence
])
def test_register_slave_functions_and_exceptions(request_hex, reply_hex):
    assert SmallMap().handle(h(request_hex)) == h(reply_hex)


def test_register_slave_applies_a_broadcast_silently_and_counts_requests():
    dev = SmallMap()
    assert dev.handle(h("00 06 00 12 00 2A")) == b"" and dev.regs[0x12] == 42
    dev.handle(h("05 03 00 10 00 01"))
    assert dev.requests == {6: 1, 3: 1}


def test_register_slave_block_writes_arrive_whole():
    dev = Block()
    assert dev.handle(h("07 10 01 00 00 03 06 00 01 00 02 00 03")) == h("07 10 01 00 00 03")
    assert dev.writes == [(0x100, [1, 2, 3])]
    assert dev.handle(h("07 04 00 00 00 01")) == h("07 04 02 00 04")  # the function reaches the map
    assert dev.handle(h("07 06 02 00 00 01")) == h("07 86 02")


def test_rtu_device_frames_checks_crc_and_routes_by_slave_id():
    with ModbusRtuDevice(SmallMap(5), Block()) as line:
        read = with_crc(h("07 03 00 00 00 01"))
        assert exchange(line.port, read, 7) == with_crc(h("07 03 02 00 03"))
        assert exchange(line.port, read[:-1] + bytes([read[-1] ^ 0xFF]), 1, timeout=0.3) == b""
        assert line.bad_crc == 1
        assert wait_until(lambda: exchange(line.port, with_crc(h("05 03 00 11 00 01")), 7, timeout=0.3)
                          == with_crc(h("05 03 02 00 02")), 5.0)
        line.silent = True
        assert exchange(line.port, read, 1, timeout=0.3) == b""


class Echo(TcpDevice):
    def serve(self, conn: socket.socket, addr) -> None:
        while data := conn.recv(64):
            conn.sendall(data)


def test_tcp_device_serves_and_drops_clients_while_listening():
    with Echo() as dev:
        c = socket.create_connection((dev.host, dev.port), timeout=3)
        c.sendall(b"hi")
        assert c.recv(8) == b"hi"
        assert wait_until(lambda: dev.clients == 1)
        assert dev.drop_clients() == 1
        assert c.recv(8) == b""  # the peer closed
        c.close()
        again = socket.create_connection((dev.host, dev.port), timeout=3)  # still listening
        again.sendall(b"x")
        assert again.recv(8) == b"x"
        again.close()


def test_free_loopback_skips_addresses_whose_ports_are_taken():
    from rio.emulation import can_listen, free_loopback, is_free

    host = free_loopback([47001, 47002])
    assert host.startswith("127.0.0.") and is_free(host, [47001, 47002])
    assert all(int(free_loopback([47001]).rsplit(".", 1)[1]) > 31 for _ in range(300)), \
        "127.0.0.2-31 are station files' addresses"
    taken = socket.socket()
    taken.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    taken.bind((host, 47002))
    taken.listen(1)
    try:
        assert not is_free(host, [47001, 47002])
        assert free_loopback([47001, 47002]) != host
    finally:
        taken.close()
    assert can_listen(47003)  # unprivileged ports are open to everyone


def test_parallel_test_workers_draw_from_disjoint_shares(monkeypatch):
    """Two pytest-xdist workers probing for a free address (or DDS domain) at the same moment would find
    the same one: each draws from its own share of the range instead, and one process from all of it."""
    from rio.emulation import free_loopback
    from rio.machine.parallel import worker_share

    for var in ("PYTEST_XDIST_WORKER", "PYTEST_XDIST_WORKER_COUNT"):
        monkeypatch.delenv(var, raising=False)
    assert worker_share(32, 254) == range(32, 255)
    monkeypatch.setenv("PYTEST_XDIST_WORKER_COUNT", "3")
    shares = []
    for n in range(3):
        monkeypatch.setenv("PYTEST_XDIST_WORKER", f"gw{n}")
        shares.append(worker_share(32, 254))
        drawn = {int(free_loopback([47001]).rsplit(".", 1)[1]) for _ in range(200)}
        assert drawn <= set(shares[-1]) and len(drawn) > 1, (n, sorted(drawn))
    assert [len(s) for s in shares] == [74, 74, 74]
    assert not set(shares[0]) & set(shares[1]) and not set(shares[1]) & set(shares[2])
    assert worker_share(100, 101) == range(100, 102)  # too small to split: shared, probing tells them apart
    monkeypatch.setenv("PYTEST_XDIST_WORKER", "master")  # not a worker's name: the whole range
    assert worker_share(32, 254) == range(32, 255)
