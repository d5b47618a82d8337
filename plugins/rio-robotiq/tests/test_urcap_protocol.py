"""The URCap ASCII protocol both ways: the emulated server's replies line by line, and the client
accepting the reply shapes a real URCap may send (ack with or without a line end, a GET reply without
one, a fault code in hex) and naming the URCap when a reply is wrong."""

from __future__ import annotations

import socket

import pytest
from rio_robotiq.errors import CommunicationError
from rio_robotiq.robotiq.urcap_link import RobotiqUrcapLink

from rio.emulation import TcpDevice


def ask(sock: socket.socket, line: str) -> bytes:
    sock.sendall(line.encode() + b"\n")
    return sock.recv(64)


def test_the_server_answers_get_and_set(urcap):
    with socket.create_connection((urcap.host, urcap.port), timeout=2) as s:
        assert ask(s, "GET STA") == b"STA 0\n"
        assert ask(s, "SET ACT 1") == b"ack"
        assert ask(s, "SET SID 9") == b"ack"
        assert ask(s, "SET POS 100 SPE 255 FOR 50 GTO 1") == b"ack"
        assert ask(s, "GET PRE") == b"PRE 100\n"
        assert ask(s, "GET FOR") == b"FOR 50\n"
        assert ask(s, "GET ACT") == b"ACT 1\n"
        for bad in ("GET XYZ", "SET POS", "SET POS 300", "HELLO"):
            assert ask(s, bad) == b"?\n", bad
    assert urcap.registers.rPR == 100 and urcap.registers.rFR == 50


class Scripted(TcpDevice):
    """Answers each request line from a table."""

    def __init__(self, replies: dict[str, bytes]):
        super().__init__()
        self.replies = replies

    def serve(self, conn, addr):
        buf = b""
        while data := conn.recv(256):
            buf += data
            while b"\n" in buf:
                line, buf = buf.split(b"\n", 1)
                reply = self.replies.get(line.decode(), b"?\n")
                if reply:  # b"": stay silent
                    conn.sendall(reply)


@pytest.mark.parametrize("replies", [
    {"GET POS": b"POS 12", "GET FLT": b"FLT 0E", "SET GTO 0": b"ack\n"},  # no line end, hex, ack with one
    {"GET POS": b"POS 12\n", "GET FLT": b"FLT 14\n", "SET GTO 0": b"ack"},
])
def test_the_client_takes_every_reply_shape(replies):
    with Scripted(replies) as srv:
        link = RobotiqUrcapLink(srv.host, srv.port, timeout_s=1.0, label="gripper").open()
        try:
            assert link.get("POS") == 12
            assert link.get("FLT") == 0x0E
            link.stop()
        finally:
            link.close()


def test_a_wrong_or_missing_reply_names_the_urcap():
    with Scripted({"GET POS": b"OBJ 3\n", "SET GTO 0": b"?\n", "GET STA": b""}) as srv:
        link = RobotiqUrcapLink(srv.host, srv.port, timeout_s=0.3, label="gripper").open()
        try:
            with pytest.raises(CommunicationError, match=f"URCap 127.0.0.1:{srv.port}: GET POS answered"):
                link.get("POS")
            with pytest.raises(CommunicationError, match="not ack"):
                link.stop()
            with pytest.raises(CommunicationError, match="no reply within"):
                link.get("STA")
        finally:
            link.close()


def test_refused_connection_says_what_to_check():
    with pytest.raises(CommunicationError, match="URCap installed"):
        RobotiqUrcapLink("127.0.0.1", 1, timeout_s=0.5, label="Robotiq 2F-85").open()
