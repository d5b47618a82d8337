"""The emulator building blocks plugins test their drivers against."""

from __future__ import annotations

import os
import select
import socket

from rio.emulation import FingerModel, PtyDevice, TcpDevice
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


def test_pty_device_answers_on_its_port():
    with Upper() as dev:
        fd = os.open(dev.port, os.O_RDWR | os.O_NOCTTY)
        try:
            os.write(fd, b"ping")
            got = b""
            while len(got) < 4 and select.select([fd], [], [], 3.0)[0]:
                got += os.read(fd, 16)
            assert got == b"PING"
        finally:
            os.close(fd)


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
