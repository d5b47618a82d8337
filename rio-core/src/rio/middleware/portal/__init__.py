"""Portal middleware: danijar's portal RPC (as in the RIO paper) carrying RIO's network protocol
(`rio.middleware.protocol`). Portal is request/reply only, so every channel is a method of the node's
server (`server`): `hello`, `req`, `call`, and `poll`, the long poll that carries the state stream.

Both ends are ours and speak portal 3.8's wire format (`wire`), so danijar's `portal.Client` can still call
a node; the `portal` package is not used: its server ended the whole process on a malformed length prefix
or a burst of messages, allocated what a peer's length claimed before checking it and attached shared
memory named by a peer; its client could busy-loop on a stale wake-up byte (~1 CPU core per idle client)
and ends the program (`os._exit(1)`) on an unexpected exception in its threads.

No authentication: servers bind loopback by default and `keys` are refused; beyond loopback only with
`insecure = true`, better through a tunnel.
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

from rio.errors import NodeDiedError, NodeError, TooManyConnections
from rio.middleware.portal import wire as pw
from rio.middleware.portal.server import TAKEN, PortalServer
from rio.middleware.protocol import NetworkClient, NetworkConfig
from rio.middleware.protocol.codecs import CODED_HEAD
from rio.middleware.protocol.messages import ACK, CODED, OK, REPLY, REQUEST, REQUEST_ID, STATE, STREAM_HEAD, pack_ack
from rio.runtime import wire
from rio.runtime.node import Node
from rio.runtime.transport import Middleware, NodeLayouts

if TYPE_CHECKING:
    from rio.station.model import MachineSection

log = logging.getLogger("rio.middleware.portal")

#: on_answer(error text or None, result or None): the answer to one message, or why it will never come.
OnAnswer = Callable[[str | None, Any], None]
Answer = tuple[str | None, Any]


class PortalClient(NetworkClient):
    mw = "portal"
    config: PortalConfig

    def __init__(self, node: Node, layouts: NodeLayouts, address: dict[str, Any], config: PortalConfig):
        host, port = str(address["host"]), int(address["port"])
        super().__init__(node, layouts, address, config)
        self._closing = False
        self._refused: str | None = None  # why the server refused this connection, if it did
        self._pending: dict[int, OnAnswer] = {}  # reqnum -> who takes its answer
        self._reqnums = itertools.count(1)
        self._lock = threading.Lock()
        self._threads: list[threading.Thread] = []
        try:
            sock = socket.create_connection((host, port), timeout=config.connect_timeout)
            sock.sendall(pw.HANDSHAKE)
        except OSError as e:
            super().close()
            raise NodeDiedError(self.name, f"no portal server answers at {host}:{port} ({e})") from e
        self._link = pw.Link(sock, f"{host}:{port}", self.name, max(config.call_timeout, 1.0), self._heard,
                             writer=False)
        self._limit = config.message_limit(layouts)
        try:
            self._spawn(self._read_loop, "recv")
            box: queue.SimpleQueue[Answer] = queue.SimpleQueue()
            self._ask(b"hello", b"\0", lambda error, data: box.put((error, data)))
            try:
                error, hello = box.get(timeout=config.connect_timeout)
            except queue.Empty:
                raise NodeDiedError(self.name, f"no handshake from {host}:{port}") from None
            if error is not None:
                raise NodeDiedError(self.name, f"handshake with {host}:{port} failed: {error}")
            self._handshake(hello, f"{host}:{port}")
        except NodeDiedError:
            if self._link.closed:  # the reader ends once it has read all the server said (a refusal first)
                self._threads[0].join(config.connect_timeout)
            self.close()
            if self._refused is not None:  # the node runs: it has no room for this client
                raise TooManyConnections(self.name, f"{host}:{port}", self._refused) from None
            raise
        except BaseException:
            self.close()
            raise
        self._spawn(self._poll_loop, "poll")

    def _spawn(self, target: Callable[[], None], what: str) -> None:
        t = threading.Thread(target=target, name=f"rio-{self.name}-portal-{what}", daemon=True)
        t.start()
        self._threads.append(t)

    def _ask(self, method: bytes, arg: bytes | memoryview, on_answer: OnAnswer) -> None:
        """Send one message; `on_answer` gets its answer (or the lost connection) from the reader thread."""
        with self._lock:
            if self._link.closed:
                raise NodeDiedError(self.name, self._gone or "connection to the portal server lost")
            reqnum = next(self._reqnums)
            frame = pw.request_frame(reqnum, method, arg)
            if len(frame) - 8 > self._limit:  # the server would drop the connection
                raise ValueError(f"node '{self.name}': a '{method.decode()}' message of {len(frame) - 8} bytes "
                                 f"is over max_message_bytes ({self._limit})")
            self._pending[reqnum] = on_answer
            self._link.send(frame)

    def _read_loop(self) -> None:
        try:
            while True:
                reqnum, error, data = pw.parse_reply(pw.read_frame(self._link.recv_into, 1 << 31))
                if reqnum == 0 and error is not None:  # (no request has number 0) the server refused us
                    self._refused = error
                    continue
                with self._lock:
                    on_answer = self._pending.pop(reqnum, None)
                if on_answer is not None:  # else a message we gave up on
                    on_answer(error, data)
        except Exception as e:  # the peer left, broke the framing, or we are closing
            why = "client closed" if self._closing else f"connection to the portal server lost ({e})"
            self._link.close(why)
            with self._lock:
                pending, self._pending = self._pending, {}
            if not self._closing:
                self._lose(why)
            for on_answer in pending.values():
                on_answer(why, None)

    def _send(self, kind: bytes, body: bytes) -> None:
        answer = ACK if kind == REQUEST else REPLY

        def take(error: str | None, data: Any) -> None:  # the protocol's answer, or the error it stands for
            if error is not None:
                data = NodeDiedError(self.name, self._gone or error) if self._link.closed else \
                    NodeError(self.name, "PortalError", error)
            elif kind == REQUEST:  # the protocol's acknowledgement, with our id
                data = pack_ack(rid, OK) if data == TAKEN else pack_ack(rid, *wire.unpack(data)[1:])
            self._answered(answer, data)

        if kind != REQUEST:
            return self._ask(b"call", body, take)
        rid = REQUEST_ID.unpack_from(body)[0]
        return self._ask(b"req", memoryview(body)[REQUEST_ID.size:], take)

    def _poll_loop(self) -> None:
        """The state stream: one long poll at a time, each answered with the messages after our newest."""
        size = self.layouts.data.itemsize if self.layouts.data else 0
        box: queue.SimpleQueue[Answer] = queue.SimpleQueue()
        try:
            while not self._link.closed and self._gone is None:
                self._ask(b"poll", self._seq.to_bytes(8, "little"), lambda error, data: box.put((error, data)))
                error, data = box.get()
                if error is not None:
                    return
                pos = 0
                while pos + STREAM_HEAD.size <= len(data):
                    head, pos = data[pos:pos + STREAM_HEAD.size], pos + STREAM_HEAD.size
                    kind = head[:1]
                    n = size if kind == STATE else (CODED_HEAD.unpack_from(data, pos)[0] if kind == CODED else 0)
                    self._on_stream(head, data[pos:pos + n] if n else None)
                    pos += n
        except NodeDiedError:
            pass
        except Exception as e:  # a malformed answer: stop mirroring and say so on the next read
            log.exception("node '%s': portal state mirror stopped", self.name)
            self._lose(f"state mirror failed: {type(e).__name__}: {e}")

    def close(self) -> None:
        self._closing = True
        link = getattr(self, "_link", None)
        if link is not None:
            link.close("client closed")
            for t in self._threads:
                if t is not threading.current_thread():
                    t.join(1.0)
            link.sock.close()
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
