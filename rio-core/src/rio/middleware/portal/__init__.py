"""Portal middleware: danijar's portal RPC protocol (as in the RIO paper), served by our own code. It carries
RIO's network protocol (`rio.middleware.protocol`); portal being request/reply only, every channel is a
method of the node's server (`server`): `hello`, `req`, `call`, and `poll`, the long poll that carries the
state stream and its heartbeats. Every argument and result is one `bytes` value that RIO encodes itself.

Both ends are ours and speak portal 3.8's wire format (`wire`), so danijar's `portal.Client` can still call
a node; the `portal` package itself is not used (its server ended the whole process on a malformed length
prefix or a burst of messages, allocated what a peer's length claimed before checking it, and attached
shared memory named by a peer). Nor is its client: in portal 3.8 its socket thread can keep a stale
wake-up byte and busy-loop (~1 CPU core per idle client), `Future.wait` can miss a wake-up, and an
unexpected exception in its threads ends the program with `os._exit(1)`. Here, sends go out from the
calling thread under a lock and one reader thread blocks in recv.

There is no authentication: servers bind loopback by default (`host`); `keys` are refused. Expose a node
beyond loopback only to trusted peers (`insecure = true`), better through a tunnel.
"""

from __future__ import annotations

import itertools
import logging
import queue
import socket
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from pydantic import Field

from rio.errors import NodeDiedError, NodeError
from rio.middleware.portal import wire as pw
from rio.middleware.portal.server import TAKEN, PortalServer
from rio.middleware.protocol import NetworkClient, NetworkConfig
from rio.middleware.protocol.client import POLL_S
from rio.middleware.protocol.messages import ACK, OK, REPLY, REQUEST, REQUEST_ID, STATE, STREAM_HEAD, pack_ack
from rio.runtime import wire
from rio.runtime.node import Node
from rio.runtime.transport import Middleware, NodeLayouts

if TYPE_CHECKING:
    from rio.station.model import MachineSection

log = logging.getLogger("rio.middleware.portal")

#: on_answer(error text or None, result or None): the answer to one message, or why it will never come.
OnAnswer = Callable[[str | None, Any], None]


class _Connection:
    """Client end of one portal connection (`wire`): sends from the caller's thread, one reader thread."""

    def __init__(self, host: str, port: int, name: str, config: PortalConfig, max_message_bytes: int,
                 heard: Callable[[], None], lost: Callable[[str], None]):
        self.sock = socket.create_connection((host, port), timeout=config.connect_timeout)
        try:
            self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self.sock.settimeout(max(config.call_timeout, 1.0))  # bounds a send to a peer that stopped reading
            self.sock.sendall(pw.HANDSHAKE)
        except OSError:
            self.sock.close()
            raise
        self.name, self.max_message_bytes, self._heard, self._on_lost = name, max_message_bytes, heard, lost
        self._lock = threading.Lock()
        self._ids = itertools.count(1)
        self._pending: dict[int, OnAnswer] = {}
        self.lost: str | None = None
        self._closing = False
        self._reader = threading.Thread(target=self._read_loop, name=f"rio-{name}-portal-recv", daemon=True)
        self._reader.start()

    def send(self, method: bytes, payload: bytes | memoryview, on_answer: OnAnswer) -> None:
        """Send one message; `on_answer` gets its answer (or the lost connection) from the reader thread."""
        with self._lock:
            if self.lost is not None:
                raise NodeDiedError(self.name, self.lost)
            reqnum = next(self._ids)
            frame = pw.request_frame(reqnum, method, payload)
            if len(frame) - 8 > self.max_message_bytes:  # the server would drop the connection
                raise ValueError(f"node '{self.name}': a '{method.decode()}' message of {len(frame) - 8} bytes is "
                                 f"over max_message_bytes ({self.max_message_bytes})")
            self._pending[reqnum] = on_answer
            try:
                self.sock.sendall(frame)
            except OSError as e:  # a timeout leaves a partial message: the connection is unusable
                self._lose(f"send failed: {type(e).__name__}: {e}", locked=True)
                raise NodeDiedError(self.name, str(self.lost)) from e

    def _recv_into(self, view: memoryview) -> int:
        while True:
            try:
                k = self.sock.recv_into(view)
            except TimeoutError:  # idle connection; the timeout is there for sends
                if self._closing:
                    raise ConnectionError("closed") from None
                continue
            self._heard()  # any bytes count: a large answer on a slow link is not silence
            return k

    def _read_loop(self) -> None:
        try:
            while True:
                reqnum, error, data = pw.parse_reply(pw.read_frame(self._recv_into, 1 << 31))
                on_answer = self._pending.pop(reqnum, None)
                if on_answer is not None:
                    on_answer(error, data)
        except Exception as e:
            self._lose("client closed" if self._closing else f"connection to the portal server lost ({e})")

    def _lose(self, detail: str, locked: bool = False) -> None:
        if not locked:
            with self._lock:
                return self._lose(detail, locked=True)
        if self.lost is None:
            self.lost = detail
            if not self._closing:
                self._on_lost(detail)
        pending, self._pending = self._pending, {}
        for on_answer in pending.values():
            on_answer(self.lost, None)
        return None

    def close(self) -> None:
        self._closing = True
        try:
            self.sock.shutdown(socket.SHUT_RDWR)  # wakes the reader
        except OSError:
            pass
        self._reader.join(1.0)
        self.sock.close()


class PortalClient(NetworkClient):
    mw = "portal"

    def __init__(self, node: Node, layouts: NodeLayouts, address: dict[str, Any], config: PortalConfig):
        host, port = str(address["host"]), int(address["port"])
        super().__init__(node, layouts, address, config)
        self._closing = False
        self._answers: dict[bytes, queue.SimpleQueue[tuple[str | None, Any]]] = {
            REPLY: queue.SimpleQueue(), ACK: queue.SimpleQueue()}
        self._poller: threading.Thread | None = None
        self._conn: _Connection | None = None
        try:
            self._conn = _Connection(host, port, self.name, config, config.message_limit(layouts), self._heard,
                                     self._lose)
        except OSError as e:
            super().close()
            raise NodeDiedError(self.name, f"no portal server answers at {host}:{port} ({e})") from e
        try:
            box: queue.SimpleQueue[tuple[str | None, Any]] = queue.SimpleQueue()
            self._conn.send(b"hello", b"\0", lambda error, data: box.put((error, data)))
            try:
                error, hello = box.get(timeout=config.connect_timeout)
            except queue.Empty:
                raise NodeDiedError(self.name, f"no handshake from {host}:{port}") from None
            if error is not None:
                raise NodeDiedError(self.name, f"handshake with {host}:{port} failed: {error}")
            self._handshake(hello, f"{host}:{port}")
        except BaseException:
            self.close()
            raise
        self._poller = threading.Thread(target=self._poll_loop, name=f"rio-{self.name}-portal-poll", daemon=True)
        self._poller.start()

    def _send(self, kind: bytes, body: bytes) -> None:
        assert self._conn is not None
        answers = self._answers[ACK if kind == REQUEST else REPLY]
        if kind != REQUEST:
            self._conn.send(b"call", body, lambda error, data: answers.put((error, data)))
            return
        rid = REQUEST_ID.unpack_from(body)[0]

        def ack(error: str | None, data: Any) -> None:  # the protocol's acknowledgement, with our id
            if error is None:
                data = pack_ack(rid, OK) if data == TAKEN else pack_ack(rid, *wire.unpack(data)[1:])
            answers.put((error, data))

        self._conn.send(b"req", memoryview(body)[REQUEST_ID.size:], ack)

    def _recv(self, kind: bytes) -> Any:
        try:
            error, data = self._answers[kind].get(timeout=POLL_S)
        except queue.Empty:
            return None
        if error is None:
            return data
        if self._conn is not None and self._conn.lost is not None:
            raise NodeDiedError(self.name, self._gone or self._conn.lost)
        raise NodeError(self.name, "PortalError", error)

    def _poll_loop(self) -> None:
        """The state stream: one long poll at a time, each answered with the messages after our newest."""
        size = self.layouts.data.itemsize if self.layouts.data else 0
        box: queue.SimpleQueue[tuple[str | None, Any]] = queue.SimpleQueue()
        try:
            while not self._closing and self._gone is None and self._conn is not None:
                self._conn.send(b"poll", self._seq.to_bytes(8, "little"), lambda e, d: box.put((e, d)))
                error, data = box.get()
                if error is not None:
                    return
                pos, end = 0, len(data)
                while pos + STREAM_HEAD.size <= end:
                    head = data[pos:pos + STREAM_HEAD.size]
                    pos += STREAM_HEAD.size
                    record = data[pos:pos + size] if head[:1] == STATE else None
                    pos += size if record is not None else 0
                    self._on_stream(head, record)
        except NodeDiedError:
            pass
        except Exception as e:  # a malformed answer: stop mirroring and say so on the next read
            log.exception("node '%s': portal state mirror stopped", self.name)
            self._lose(f"state mirror failed: {type(e).__name__}: {e}")

    def close(self) -> None:
        self._closing = True
        if self._conn is not None:
            self._conn.close()
        if self._poller is not None:
            self._poller.join(1.0)
        super().close()


class PortalMiddleware(Middleware):
    name = "portal"

    class Config(NetworkConfig):
        authenticates = False  # refuses `keys`: portal's wire format has no authentication
        #: TCP port; None picks a free one (reported in the address). One port serves one node.
        port: int | None = Field(default=None, ge=0, le=65535)
        #: Upper bound on one poll answer (the newest samples that fit; at least one).
        max_batch_bytes: int = Field(default=8 * 1024 * 1024, ge=1)

    def placed(self, node: str, index: int, machine: str, section: MachineSection
               ) -> tuple[dict[str, Any], dict[str, Any]]:
        """One fixed port per node from the machine's `port` (only with `insecure = true`: no keys here)."""
        port = section.port + index
        return {"host": section.bind or section.address, "port": port}, {"host": section.address, "port": port}

    def make_server(self, node: Node, layouts: NodeLayouts, resources: dict[str, Any]) -> PortalServer:
        return PortalServer(node, layouts, self.config)

    def make_client(self, node: Node, layouts: NodeLayouts, address: dict[str, Any]) -> PortalClient:
        return PortalClient(node, layouts, address, self.config)


PortalConfig = PortalMiddleware.Config
