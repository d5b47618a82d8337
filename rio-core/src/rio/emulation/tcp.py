"""A TCP server for protocol emulators: one thread accepts, one thread per client runs `serve(conn)`.

`drop_clients()` closes every open connection (a pulled cable, a rebooted controller) while the
server keeps listening, so drivers can be tested reconnecting. `stop()` closes everything.
"""

from __future__ import annotations

import logging
import socket
import threading
from collections.abc import Iterator
from typing import Any

log = logging.getLogger("rio.emulation")


class TcpDevice:
    """Subclass and write `serve(conn, addr)`; it returns when the client goes away (recv gives b"" or
    raises OSError). `port=0` takes a free port (read `port` after `start()`)."""

    def __init__(self, host: str = "127.0.0.1", port: int = 0):
        self.host, self.port = host, int(port)
        self._sock: socket.socket | None = None
        self._clients: set[socket.socket] = set()
        self._guard = threading.Lock()
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    def serve(self, conn: socket.socket, addr: Any) -> None:
        raise NotImplementedError

    @staticmethod
    def read_lines(conn: socket.socket, encoding: str = "utf-8", errors: str = "strict",
              bufsize: int = 4096) -> Iterator[str]:
        """The newline-terminated request lines of a text protocol (a dashboard, the URCap socket), decoded,
        without their newline, until the client closes: `for line in self.read_lines(conn): ...`."""
        buf = b""
        while True:
            data = conn.recv(bufsize)
            if not data:
                return
            buf += data
            while b"\n" in buf:
                line, buf = buf.split(b"\n", 1)
                yield line.decode(encoding, errors)

    def start(self) -> TcpDevice:
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((self.host, self.port))
        except PermissionError as e:
            sock.close()
            raise PermissionError(f"cannot listen on {self.host}:{self.port} ({e}): ports below 1024 need root, "
                                  "or `sudo sysctl net.ipv4.ip_unprivileged_port_start=0`") from e
        except OSError as e:
            sock.close()
            raise OSError(f"cannot listen on {self.host}:{self.port}: {e}") from e
        sock.listen(8)
        sock.settimeout(0.1)
        self._sock, self.port = sock, sock.getsockname()[1]
        self._stop.clear()
        self._spawn(self._accept, f"rio-tcp-{self.host}:{self.port}")
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._sock is not None:
            self._sock.close()
            self._sock = None
        self.drop_clients()
        for t in self._threads:
            if t is not threading.current_thread():
                t.join(2.0)
        self._threads.clear()

    def drop_clients(self) -> int:
        """Close every client connection now; returns how many there were."""
        with self._guard:
            clients, self._clients = list(self._clients), set()
        for c in clients:
            try:
                c.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            c.close()
        return len(clients)

    @property
    def clients(self) -> int:
        with self._guard:
            return len(self._clients)

    def __enter__(self) -> Any:
        return self.start()

    def __exit__(self, *exc: Any) -> None:
        self.stop()

    def _spawn(self, target, name: str, *args: Any) -> None:
        t = threading.Thread(target=target, args=args, name=name, daemon=True)
        self._threads = [x for x in self._threads if x.is_alive()] + [t]
        t.start()

    def _accept(self) -> None:
        while not self._stop.is_set():
            sock = self._sock
            if sock is None:
                return
            try:
                conn, addr = sock.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            conn.settimeout(None)  # not the listener's poll timeout, nor a process-wide default (the xArm SDK sets one)
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            with self._guard:
                self._clients.add(conn)
            self._spawn(self._client, f"rio-tcp-client-{addr}", conn, addr)

    def _client(self, conn: socket.socket, addr: Any) -> None:
        try:
            self.serve(conn, addr)
        except OSError:
            pass
        except Exception:
            log.exception("emulator %s:%s: client %s", self.host, self.port, addr)
        finally:
            with self._guard:
                self._clients.discard(conn)
            conn.close()
