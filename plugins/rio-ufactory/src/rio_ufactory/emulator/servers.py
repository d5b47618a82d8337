"""The controller's TCP servers: the command port (requests in, replies and feedback frames out) and
the report ports (a frame stream at a fixed rate), on `rio.emulation.TcpDevice`.

Sockets are given explicit timeouts: the SDK sets a process-wide default socket timeout of 1 s, which
accepted sockets would otherwise inherit (an idle command connection would then look closed).
"""

from __future__ import annotations

import logging
import socket
import threading
import time
from collections.abc import Callable
from typing import Any

from rio.emulation import TcpDevice

from .protocol import split_frames

log = logging.getLogger("rio_ufactory.emulator")


class Connection:
    """A client of the command port: replies and feedback frames are written under one lock."""

    def __init__(self, sock: socket.socket, addr: Any):
        self.sock, self.addr = sock, addr
        self.feedback_type = 0  # feedback bits the client asked for (SET_FEEDBACK_TYPE)
        self.open = True
        self._lock = threading.Lock()

    def send(self, data: bytes) -> bool:
        if not self.open:
            return False
        try:
            with self._lock:
                self.sock.sendall(data)
            return True
        except OSError:
            self.open = False
            return False


class CommandServer(TcpDevice):
    """Port 502: each request goes to `handle(request, connection) -> reply bytes | None`."""

    def __init__(self, host: str, port: int, handle: Callable[[Any, Connection], bytes | None]):
        super().__init__(host, port)
        self.handle = handle

    def serve(self, conn: socket.socket, addr: Any) -> None:
        conn.settimeout(0.2)
        client = Connection(conn, addr)
        buf = bytearray()
        log.debug("command client %s connected to %s", addr, self.host)
        try:
            while not self._stop.is_set():
                try:
                    data = conn.recv(4096)
                except TimeoutError:
                    continue
                if not data:
                    return
                buf += data
                for req in split_frames(buf):
                    try:
                        answer = self.handle(req, client)
                    except Exception:  # an emulator bug must not hang the client: log, answer nothing
                        log.exception("command %d from %s", req.register, addr)
                        continue
                    if answer and not client.send(answer):
                        return
        finally:
            client.open = False


class ReportServer(TcpDevice):
    """A report port: every client gets `encode()` every `1 / hz` s until it goes away."""

    def __init__(self, host: str, port: int, hz: float, encode: Callable[[], bytes]):
        super().__init__(host, port)
        self.period = 1.0 / max(float(hz), 0.1)
        self.encode = encode

    def serve(self, conn: socket.socket, addr: Any) -> None:
        conn.settimeout(2.0)
        deadline = time.monotonic()
        while not self._stop.is_set():
            conn.sendall(self.encode())  # OSError (client gone, dropped) ends the connection
            deadline += self.period
            delay = deadline - time.monotonic()
            if delay > 0:
                self._stop.wait(delay)
            elif delay < -10 * self.period:
                deadline = time.monotonic()  # fell far behind (loaded machine): don't burst to catch up
