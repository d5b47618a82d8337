"""Portal middleware: danijar's portal RPC protocol (as in the RIO paper), served by our own code.

Portal is request/reply only (no pub/sub), so every channel is a method of the node's server:

- ``hello(b"\\0")``: transport-level handshake: layout fingerprints and the newest sample's bytes.
- ``poll(since)``: long poll. Answers as soon as samples newer than count ``since`` exist, or after
  ~80 ms with none; a client thread calls it in a loop and puts the records into its local mirror.
  Its steady answers double as the heartbeat a client on another machine watches.
- ``req(record)``: one request record (raw bytes of the node's request layout). Answered once the
  record is in the node's request queue, or with why not (full queue, invalid record), which
  `send_request` raises (QueueFull, InvalidRequest): no request is dropped silently.
- ``call(wire.pack_call bytes)`` -> ``wire.pack_reply`` bytes: remote API methods.

Every argument and result is one `bytes` value that RIO encodes itself (raw records, `rio.runtime.wire`).

Both ends are ours and speak portal 3.8's wire format (`portal_wire`), so danijar's `portal.Client`
can still call a node; the `portal` package itself is not used (its server ended the whole process on
a malformed length prefix or a burst of messages, allocated what a peer's length claimed before
checking it, and attached shared memory named by a peer). What the server does with network bytes
(`portal_server`): a length prefix outside 16..`max_message_bytes` disconnects the peer before
anything is allocated; a message that is not one `bytes` argument (e.g. a numpy or shared-memory
leaf) is answered with an error without decoding any leaf; records are checked against the layout
and calls decoded by `rio.runtime.wire` (msgpack, nothing unpickled); each connection has at most
`max_pending_per_connection` messages waiting; an error reply carries the exception's type and message,
never a traceback. There is no authentication: servers bind loopback by default (`host` option);
expose a node beyond loopback only to trusted peers.
"""

from __future__ import annotations

import itertools
import logging
import socket
import struct
import threading
from typing import TYPE_CHECKING, Any

from pydantic import Field

from rio import clock
from rio.errors import ConfigError, InvalidRequest, NodeDiedError, NodeError, NodeTimeout, QueueFull
from rio.middleware import portal_wire as pw
from rio.runtime import wire
from rio.runtime.buffers import RequestSender, RingBuffer
from rio.runtime.node import Node
from rio.runtime.transport import ClientTransport, Middleware, NetworkConfig, NodeLayouts, local_process_watch

if TYPE_CHECKING:
    from rio.station.model import MachineSection
from rio.middleware.portal_server import OK, PortalServer

log = logging.getLogger("rio.middleware.portal")

_SLICE_S = 0.05  # how often a waiting client re-checks liveness


# -- client -------------------------------------------------------------------------------------------
class _Closing(Exception):
    """The client is being closed: background waits end quietly."""


class _Reply:
    """One awaited answer, filled in by the connection's reader thread."""

    __slots__ = ("event", "data", "error", "lost")

    def __init__(self) -> None:
        self.event = threading.Event()
        self.data: memoryview | None = None
        self.error: str | None = None  # portal's error text, or why the connection was lost
        self.lost = False


class _Connection:
    """Client end of one portal connection (`portal_wire`): one `bytes` argument and result.

    Why not `portal.Client`: in portal 3.8 its socket thread can keep a stale wake-up byte and then
    busy-loop on a non-blocking recv whenever it has nothing to send (measured: ~1 CPU core per idle
    client, and call latency several times worse); `Future.wait` can miss a wake-up; and an unexpected
    exception in its threads ends the whole program with `os._exit(1)`. Here, sends go out from the
    calling thread under a lock and one reader thread blocks in recv.
    """

    def __init__(self, host: str, port: int, name: str, connect_timeout: float, send_timeout: float,
                 max_message_bytes: int, max_reply_bytes: int = 1 << 31):
        self.sock = socket.create_connection((host, port), timeout=connect_timeout)
        try:
            self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self.sock.settimeout(send_timeout)  # bounds a send to a peer that stopped reading
            self.sock.sendall(pw.HANDSHAKE)
        except OSError:
            self.sock.close()
            raise
        #: When bytes last arrived (the heartbeat: a large answer on a slow link is not silence).
        self.last_rx = clock.now()
        self.name, self.max_message_bytes, self.max_reply_bytes = name, max_message_bytes, max_reply_bytes
        self._lock = threading.Lock()
        self._ids = itertools.count(1)
        self._pending: dict[int, _Reply] = {}
        self.lost: str | None = None
        self._closing = False
        self._reader = threading.Thread(target=self._read_loop, name=f"rio-{name}-portal-recv", daemon=True)
        self._reader.start()

    def send(self, method: bytes, payload: bytes, reply: _Reply) -> int:
        """Send one call; its answer will be put into `reply`. Raises ConnectionError when lost, ValueError
        for a message the server would refuse by dropping the connection."""
        with self._lock:
            if self.lost is not None:
                raise ConnectionError(self.lost)
            reqnum = next(self._ids)
            frame = pw.request_frame(reqnum, method, payload)
            if len(frame) - 8 > self.max_message_bytes:
                raise ValueError(f"node '{self.name}': a '{method.decode()}' message of {len(frame) - 8} bytes is "
                                 f"over max_message_bytes ({self.max_message_bytes})")
            self._pending[reqnum] = reply
            try:
                self.sock.sendall(frame)
            except OSError as e:  # a timeout leaves a partial message: the connection is unusable
                self._lose(f"send failed: {type(e).__name__}: {e}", locked=True)
                raise ConnectionError(self.lost) from e
        return reqnum

    def forget(self, reqnum: int) -> None:
        self._pending.pop(reqnum, None)

    def _recv_into(self, view: memoryview) -> int:
        while True:
            try:
                k = self.sock.recv_into(view)
            except TimeoutError:  # idle connection; the timeout is there for sends
                if self._closing:
                    raise ConnectionError("closed") from None
                continue
            self.last_rx = clock.now()  # any bytes count: a large answer on a slow link is not silence
            return k

    def _read_loop(self) -> None:
        try:
            while True:
                reqnum, error, data = pw.parse_reply(pw.read_frame(self._recv_into, self.max_reply_bytes))
                reply = self._pending.pop(reqnum, None)
                if reply is None:  # a timed-out call, answered late
                    continue
                reply.error, reply.data = error, data
                reply.event.set()
        except Exception as e:
            self._lose("client closed" if self._closing else f"connection to the portal server lost ({e})")

    def _lose(self, detail: str, locked: bool = False) -> None:
        if not locked:
            with self._lock:
                return self._lose(detail, locked=True)
        if self.lost is None:
            self.lost = detail
        pending, self._pending = self._pending, {}
        for reply in pending.values():
            reply.error, reply.lost = self.lost, True
            reply.event.set()

    def close(self) -> None:
        self._closing = True
        try:
            self.sock.shutdown(socket.SHUT_RDWR)  # wakes the reader
        except OSError:
            pass
        self._reader.join(1.0)
        self.sock.close()


class PortalClient(ClientTransport):
    def __init__(self, node: Node, layouts: NodeLayouts, address: dict[str, Any], config: PortalConfig):
        self.name, self.config = node.name, config
        host, port = str(address["host"]), int(address["port"])
        self._watch = local_process_watch(address, self.name)
        self._dead: str | None = None
        self._closing = False
        self._ids = itertools.count(1)
        self._conn: _Connection | None = None
        self._poller: threading.Thread | None = None
        self.ring_buffer = RingBuffer(layouts.data, layouts.buffer_capacity) if layouts.data is not None else None
        self.request_queue = RequestSender(layouts.request, self._send_request) if layouts.request is not None else None
        try:
            self._conn = _Connection(host, port, self.name, config.connect_timeout, max(config.call_timeout, 1.0),
                                     config.message_limit(layouts))
        except OSError as e:
            if self._watch is not None:
                self._watch.close()
            raise NodeDiedError(self.name, f"no portal server answers at {host}:{port} ({e})") from e
        try:
            self._handshake(layouts, f"{host}:{port}")
        except BaseException:
            self.close()
            raise
        self._poller = threading.Thread(target=self._poll_loop, name=f"rio-{self.name}-portal-poll", daemon=True)
        self._poller.start()

    def _handshake(self, layouts: NodeLayouts, where: str) -> None:
        hello = wire.unpack(self._rpc(b"hello", b"\0", self.config.connect_timeout, "handshake"))
        if list(hello["fingerprint"]) != layouts.fingerprint():
            raise ConfigError(f"node '{self.name}': the server at {where} has a different data/request layout "
                              f"(fingerprints {hello['fingerprint']} != {layouts.fingerprint()}); "
                              "client and server must build the node with the same config")
        self._since = int(hello["count"])
        if self.ring_buffer is not None and hello["newest"] is not None:
            self.ring_buffer.put_bytes(hello["newest"])

    def _lost(self, detail: str, background: bool = False) -> Exception:
        """The exception for a lost connection (and remember it, unless we are closing)."""
        if self._closing:
            return _Closing() if background else NodeDiedError(self.name, "client closed")
        if self._dead is None:
            self._dead = detail
        return NodeDiedError(self.name, self._dead)

    def _wait(self, reply: _Reply, timeout: float, what: str, *, background: bool = False) -> memoryview:
        """Wait for an answer, checking liveness every 50 ms: a dead server never hangs a caller."""
        deadline = clock.now() + timeout
        while not reply.event.wait(_SLICE_S):
            if background and self._closing:
                raise _Closing()
            self.check_alive()
            if clock.now() > deadline:
                raise NodeTimeout(self.name, what, timeout)
        if reply.lost:
            raise self._lost(reply.error or "connection lost", background)
        if reply.error is not None:
            raise NodeError(self.name, "PortalError", reply.error)
        return reply.data  # type: ignore[return-value]

    def _rpc(self, method: bytes, payload: bytes, timeout: float, what: str, *, background: bool = False) -> memoryview:
        reply = _Reply()
        try:
            reqnum = self._conn.send(method, payload, reply)  # type: ignore[union-attr]
        except ConnectionError as e:
            raise self._lost(str(e), background) from e
        try:
            return self._wait(reply, timeout, what, background=background)
        except (NodeTimeout, NodeDiedError, _Closing):
            self._conn.forget(reqnum)  # type: ignore[union-attr]
            raise

    # -- state mirror ---------------------------------------------------------------------------------
    def _poll_loop(self) -> None:
        ring, head = self.ring_buffer, struct.Struct("<QI")
        try:
            while not self._closing:
                data = self._rpc(b"poll", self._since.to_bytes(8, "little"), float("inf"), "poll", background=True)
                count, n = head.unpack_from(data)
                if ring is not None and n:
                    size = (len(data) - head.size) // n
                    for i in range(n):
                        ring.put_bytes(data[head.size + i * size:head.size + (i + 1) * size])
                self._since = count
        except (NodeDiedError, _Closing):
            pass
        except Exception as e:  # a malformed answer: stop mirroring and say so on the next read
            if not self._closing:
                log.exception("node '%s': portal state mirror stopped", self.name)
                self._dead = self._dead or f"state mirror failed: {type(e).__name__}: {e}"

    # -- ClientTransport ------------------------------------------------------------------------------
    def check_alive(self) -> None:
        if self._dead is not None:
            raise NodeDiedError(self.name, self._dead)
        conn = self._conn
        if self._watch is not None:  # server on this machine: its process tells exactly
            try:
                self._watch.check()
            except NodeDiedError as e:
                self._dead = self._dead or e.detail
                raise
        elif conn is not None and clock.now() - conn.last_rx > self.config.heartbeat_timeout:
            raise self._lost(f"no heartbeat for {self.config.heartbeat_timeout:.3g} s")
        if conn is not None and conn.lost is not None and not self._closing:
            raise self._lost(conn.lost)

    def _send_request(self, record: bytes) -> None:
        """Returns once the record is in the node's request queue; raises QueueFull or InvalidRequest when
        the node refused it, NodeTimeout / NodeDiedError when the answer does not come."""
        self.check_alive()
        data = self._rpc(b"req", record, self.config.call_timeout, "send_request")
        if data != OK:
            raise self._refusal(data)

    def _refusal(self, data: memoryview) -> Exception:
        """The error the server's answer to a refused request stands for (`PortalServer._run_request`)."""
        try:
            kind, *fields = wire.unpack(data)
            if kind == "QueueFull":
                return QueueFull(self.name, int(fields[0]), float(fields[1]))
            if kind == "InvalidRequest":
                return InvalidRequest(self.name, fields[0], str(fields[1]))
        except (ValueError, TypeError, IndexError):
            pass
        return NodeError(self.name, "ProtocolError", f"unexpected answer to a request: {bytes(data[:64])!r}")

    def call(self, method: str, args: tuple, kwargs: dict) -> Any:
        self.check_alive()
        call_id = next(self._ids)
        data = self._rpc(b"call", wire.pack_call(call_id, method, args, kwargs), self.config.call_timeout,
                         f"call {method}()")
        reply_id, ok, value = wire.unpack_reply(data)
        if reply_id != call_id:
            raise NodeError(self.name, "ProtocolError", f"answer to call {reply_id}, expected {call_id}")
        if not ok:
            raise NodeError(self.name, *value)
        return value

    def close(self) -> None:
        self._closing = True
        if self._conn is not None:
            self._conn.close()
        if self._poller is not None:
            self._poller.join(1.0)
        if self._watch is not None:
            self._watch.close()


class PortalMiddleware(Middleware):
    name = "portal"
    class Config(NetworkConfig):
        authenticates = False  # refuses `keys`: portal's wire format has no authentication
        #: Interface the server binds; "0.0.0.0" (or a machine's address) to serve other machines, only
        #: with `insecure = true` (no authentication; prefer a tunnel).
        host: str = "127.0.0.1"
        #: TCP port; None picks a free one (reported in the address). One port serves one node.
        port: int | None = Field(default=None, ge=0, le=65535)
        #: Seconds a client waits for the TCP connection and handshake.
        connect_timeout: float = 5.0
        #: A server on another machine whose long poll stays silent this long is reported dead.
        heartbeat_timeout: float = 0.5
        #: Upper bound on one poll answer (the newest samples that fit; at least one).
        max_batch_bytes: int = Field(default=8 * 1024 * 1024, ge=1)
        #: Calls, requests and long polls one connection may have waiting on the server; more are
        #: answered with an error (a client sends one poll at a time, and one call per thread).
        max_pending_per_connection: int = Field(default=16, ge=1)

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
