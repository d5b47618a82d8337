"""A Robotiq gripper through the Robotiq URCap on a Universal Robots controller: the URCap serves an
ASCII protocol on TCP port 63352 and relays it to the gripper's registers.

    SET ACT 1                          -> ack      (variables: ACT GTO ATR ADR POS SPE FOR)
    SET POS 100 SPE 255 FOR 255 GTO 1  -> ack      (several variables in one line)
    GET POS                            -> POS 123  (read: ACT GTO STA OBJ FLT POS PRE SPE FOR)

One request, one reply. `ack` comes without a line end (clients compare the bytes), `GET` replies end
with one; this client accepts both shapes. Values are the register values (0..255, 0 = open). The
gripper current is not served, so `current` is NaN on this transport.
"""

from __future__ import annotations

import re
import select
import socket
import time

from ..errors import CommunicationError
from .registers import RobotiqStatus

_REPLY = re.compile(rb"^([A-Z]{3}) +([0-9A-Fa-f]+)\s*$")
#: how long a reply that looks whole but has no line end may still grow
_GRACE_S = 0.005


class RobotiqUrcapLink:
    def __init__(self, host: str, port: int, *, timeout_s: float, label: str, connect_timeout_s: float = 0.0):
        self.host, self.port, self.timeout_s, self.label = host, int(port), float(timeout_s), label
        self.connect_timeout_s = float(connect_timeout_s)
        self.where = f"URCap {host}:{self.port}"
        self._sock: socket.socket | None = None

    def open(self) -> RobotiqUrcapLink:
        """Connect, trying again for `connect_timeout_s` (a controller still booting, an emulator starting
        with the station)."""
        deadline = time.monotonic() + self.connect_timeout_s
        while True:
            try:
                self._sock = socket.create_connection((self.host, self.port), timeout=self.timeout_s)
                break
            except OSError as e:
                if time.monotonic() >= deadline:
                    raise CommunicationError(f"cannot connect to the {self.label} on {self.where}: {e}; is the "
                                             "robot on, the Robotiq URCap installed and the gripper powered?") from e
                time.sleep(0.2)
        self._sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        return self

    def close(self) -> None:
        if self._sock is not None:
            try:
                self._sock.close()
            finally:
                self._sock = None

    # -- protocol -------------------------------------------------------------------------------------------
    def get(self, var: str) -> int:
        reply = self._request(f"GET {var}", complete=lambda b: b.endswith(b"\n"))
        m = _REPLY.match(reply)
        if not m or m.group(1).decode() != var:
            raise CommunicationError(f"{self.label} on {self.where}: GET {var} answered {reply!r}")
        text = m.group(2).decode()
        try:
            return int(text)
        except ValueError:  # a fault code may come as two hex digits
            return int(text, 16)

    def set(self, **values: int) -> None:
        line = "SET " + " ".join(f"{k} {int(v)}" for k, v in values.items())
        reply = self._request(line, complete=lambda b: b.strip() == b"ack" or b.endswith(b"\n"))
        if reply.strip() != b"ack":
            raise CommunicationError(f"{self.label} on {self.where}: '{line}' answered {reply!r}, not ack")

    def _request(self, line: str, complete) -> bytes:
        sock = self._sock
        if sock is None:
            raise CommunicationError(f"the {self.label} on {self.where} is not connected")
        buf = b""
        try:
            sock.sendall(line.encode("ascii") + b"\n")
            while not complete(buf):
                looks_whole = _REPLY.match(buf) is not None  # "POS 12": maybe all of it, without a line end
                ready, _, _ = select.select([sock], [], [], _GRACE_S if looks_whole else self.timeout_s)
                if not ready:
                    if looks_whole:
                        break
                    raise TimeoutError(f"no reply within {self.timeout_s} s")
                chunk = sock.recv(256)
                if not chunk:
                    raise ConnectionError("the URCap closed the connection")
                buf += chunk
        except OSError as e:
            raise CommunicationError(f"{self.label} on {self.where}: '{line}' failed: {e}") from e
        return buf

    # -- the link the driver calls ---------------------------------------------------------------------------
    def status(self, full: bool = True) -> RobotiqStatus:
        """POS, OBJ and FLT every cycle; with `full`, also ACT, GTO, STA and PRE (activation, checks)."""
        st = RobotiqStatus(gOBJ=self.get("OBJ"), gFLT=self.get("FLT"), gPO=self.get("POS"))
        if full:
            st.gACT, st.gGTO, st.gSTA, st.gPR = self.get("ACT"), self.get("GTO"), self.get("STA"), self.get("PRE")
        return st

    def activate(self, on: bool) -> None:
        if on:
            self.set(ACT=1)
        else:
            self.set(ACT=0, ATR=0)

    def go(self, position: int, speed: int, force: int) -> None:
        self.set(POS=position, SPE=speed, FOR=force, GTO=1)

    def stop(self) -> None:
        self.set(GTO=0)
