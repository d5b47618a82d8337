"""Portal middleware: a `portal.Server` per node (danijar's portal RPC, as in the RIO paper).

Portal is request/reply only (no pub/sub), so every channel is a method of the node's server:

- ``hello(b"\\0")``: transport-level handshake: layout fingerprints and the newest sample's bytes.
- ``poll(since)``: long poll. Answers as soon as samples newer than count ``since`` exist, or after
  ~80 ms with none; a client thread calls it in a loop and puts the records into its local mirror.
  Its steady answers double as the heartbeat a client on another machine watches.
- ``req(record)``: one request record (raw bytes of the node's request layout), fire-and-forget.
- ``call(wire.pack_call bytes)`` -> ``wire.pack_reply`` bytes: remote API methods.

Every argument and result is one `bytes` value that RIO encodes itself (raw records, `rio.wire`).

What portal does with network bytes (portal 3.8, read from its source): messages are framed by
length and decoded by `portal.packlib.unpack` (msgpack headers; leaves become bytes, str, None, numpy
arrays through `np.frombuffer`, or a `SharedArray`). Nothing received is unpickled: cloudpickle is used
only for `portal.Process` targets and context options, which never travel over a socket. Hazards
that remain, and what this module does about them:

- A ``sharray`` leaf makes portal attach a shared-memory segment named by the peer and unlink it when
  the array is garbage collected. The server drops any message carrying anything but `bytes` before
  portal decodes it (`PortalServer._guard_recv`).
- Portal's loop threads end the whole process (`os._exit(1)`) on an unexpected exception, e.g. a
  malformed length header. So servers bind loopback by default (`host` option) and run with
  ``errors=False`` (a bad call is answered with an error instead of stopping the server); expose a
  node beyond loopback only to trusted peers.
- The client end is not `portal.Client` but `_Connection`, a small client of portal's framing
  (reasons in its docstring; the main one: portal 3.8's client socket thread busy-loops).

`import portal` forces the `spawn` start method on the whole program: it is imported lazily, on the
server side only, and the host program's start method is put back (`_portal`).
"""

from __future__ import annotations

import collections
import itertools
import logging
import multiprocessing
import socket
import struct
import threading
from typing import Any

import msgpack
from pydantic import Field

from .. import clock, wire
from ..buffers import RequestQueue, RequestSender, RingBuffer
from ..errors import ConfigError, InvalidRequest, NodeDiedError, NodeError, NodeTimeout, QueueFull
from ..node import Node
from .base import (
    ClientTransport,
    Middleware,
    NetworkConfig,
    NodeLayouts,
    ServerTransport,
    local_process_watch,
    warn_if_exposed,
)

log = logging.getLogger("rio.middleware.portal")

_POLL_WAIT_S = 0.08  # server-side long-poll wait: one answer (heartbeat) at least every ~100 ms
_SLICE_S = 0.05  # how often a waiting client re-checks liveness
_OK = b"\x01"  # portal cannot send an empty buffer, so replies are never b""
_LOOPBACK = {"127.0.0.1", "localhost", "::1"}
_IMPORT_LOCK = threading.Lock()


def _portal() -> Any:
    """Import portal without letting it change the program's multiprocessing start method."""
    with _IMPORT_LOCK:
        before = multiprocessing.get_start_method(allow_none=True)
        import portal

        if multiprocessing.get_start_method(allow_none=True) != before:
            multiprocessing.set_start_method(before, force=True)
        return portal


def _one_bytes_argument(frame: Any) -> bool:
    """True if a portal request frame carries exactly one `bytes` argument (all RIO ever sends).

    Frame: reqnum u64, name length u64, name, then packlib: buffer count u64 (3: tree, leaf specs,
    one leaf), one u64 size per buffer, msgpack tree, msgpack leaf specs, the leaf. Checked before
    portal decodes it (see the module docstring).
    """
    try:
        strlen = int.from_bytes(frame[8:16], "little")
        body = frame[16 + strlen:]
        if int.from_bytes(body[:8], "little") != 3:
            return False
        tree, specs, _ = struct.unpack("<3Q", body[8:32])
        return msgpack.unpackb(body[32 + tree:32 + tree + specs]) == [["bytes"]]
    except Exception:
        return False


# -- server -------------------------------------------------------------------------------------------
class PortalServer(ServerTransport):
    def __init__(self, node: Node, layouts: NodeLayouts, config: PortalConfig):
        self.name, self.layouts, self.config = node.name, layouts, config
        self.ring_buffer = (RingBuffer(layouts.data, layouts.buffer_capacity, on_put=self._on_put)
                            if layouts.data is not None else None)
        self.request_queue = (RequestQueue(layouts.request, layouts.request_capacity)
                              if layouts.request is not None else None)
        # Raw bytes of the newest samples, kept for the long polls (the ring's slots get overwritten).
        self._recent: collections.deque[bytes] = collections.deque(maxlen=max(layouts.buffer_capacity - 1, 1))
        self._count = 0
        self._cond = threading.Condition()
        self._closing = False
        self._dispatch: Any = None
        self._server: Any = None

    # node side: called by the ring buffer in the node's writer thread
    def _on_put(self, rec: Any) -> None:
        data = rec.tobytes()
        with self._cond:
            self._recent.append(data)
            self._count += 1
            self._cond.notify_all()

    # -- portal methods (run in portal's worker threads; must never raise) --------------------------
    def _hello(self, addr: Any, _: Any) -> bytes:
        self._no_delay(addr)
        with self._cond:
            newest = self._recent[-1] if self._recent else None
            count = self._count
        return wire.pack({"fingerprint": self.layouts.fingerprint(), "count": count, "newest": newest})

    def _no_delay(self, addr: Any) -> None:
        """Portal leaves Nagle's algorithm on, so a small answer can wait for the ACK of the previous
        one (up to the peer's delayed-ACK time, ~40 ms). Switch it off for this client's connection."""
        try:
            self._server.socket.conns[addr].sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        except Exception as e:  # portal internals changed, or the client is already gone
            log.debug("node '%s': could not set TCP_NODELAY: %s", self.name, e)

    def _poll(self, since_b: Any) -> bytes:
        """Samples after count `since` (newest first up to max_batch_bytes), as count u64, n u32, records."""
        since = int.from_bytes(bytes(since_b[:8]), "little") if isinstance(since_b, (bytes, memoryview)) else 0
        with self._cond:
            if self._count <= since and not self._closing:
                self._cond.wait(_POLL_WAIT_S)
            count = self._count
            new = min(max(count - since, 0), len(self._recent))
            picked: list[bytes] = []
            size = 0
            for data in reversed(self._recent):
                if len(picked) == new or (picked and size + len(data) > self.config.max_batch_bytes):
                    break
                picked.append(data)
                size += len(data)
        picked.reverse()
        return b"".join([struct.pack("<QI", count, len(picked)), *picked])

    def _req(self, record: Any) -> bytes:
        try:
            if self.request_queue is None:
                raise InvalidRequest(self.name, None, "this node takes no requests")
            self.request_queue.put_bytes(record)
        except (InvalidRequest, QueueFull) as e:
            log.warning("%s", e)
            return str(e).encode()
        except Exception as e:  # e.g. a non-bytes argument from a foreign client
            log.warning("node '%s': dropped a malformed request: %s", self.name, e)
            return b"malformed request"
        return _OK

    def _call(self, data: Any) -> bytes:
        try:
            call_id, method, args, kwargs = wire.unpack_call(data)
        except Exception as e:
            return wire.pack_reply(-1, False, wire.error_payload(e))
        try:
            return wire.pack_reply(call_id, True, self._dispatch(method, args, kwargs))
        except BaseException as e:  # SystemExit from node code too: escaping here would stop portal's loop
            return wire.pack_reply(call_id, False, wire.error_payload(e))

    # -- lifecycle --------------------------------------------------------------------------------------
    def start(self, dispatch: Any) -> dict[str, Any]:
        portal = _portal()
        self._dispatch = dispatch
        warn_if_exposed(self.config, self.name, log)
        opts = self.config
        ipv6 = ":" in opts.host
        self._server = server = portal.Server(
            opts.port or 0, f"rio-{self.name}", workers=1, errors=False,
            host=opts.host, ipv6=ipv6, logging=False)
        self._guard_recv(server)
        server.bind("hello", self._hello, workers=1, addr=True)
        server.bind("poll", self._poll, workers=opts.poll_workers)
        server.bind("req", self._req, workers=1)  # one worker: requests stay in order
        server.bind("call", self._call)  # portal's default pool (one thread); the node lock serializes anyway
        server.start(block=False)
        port = server.socket.sock.getsockname()[1]
        host = opts.host if opts.host not in ("0.0.0.0", "::", "") else socket.gethostname()
        return {"host": host, "port": port}

    def _guard_recv(self, server: Any) -> None:
        """Drop, before portal decodes them, messages carrying anything but bytes (this server only)."""
        recv = server.socket.recv
        name = self.name

        def guarded(timeout: float | None = None) -> Any:
            addr, frame = recv(timeout)
            if _one_bytes_argument(frame):
                return addr, frame
            log.warning("node '%s': dropped a message from %s that carries non-bytes data", name, addr)
            raise TimeoutError  # portal's loop reads this as "nothing received"

        server.socket.recv = guarded

    def close(self) -> None:
        with self._cond:
            self._closing = True
            self._cond.notify_all()  # pending long polls answer at once
        server, self._server = self._server, None
        if server is None:
            return
        # Portal's close can wait forever on a peer that stopped reading: bound it.
        t = threading.Thread(target=server.close, kwargs={"timeout": 1.0}, name=f"rio-{self.name}-close", daemon=True)
        t.start()
        t.join(3.0)
        if t.is_alive():
            log.warning("node '%s': portal server did not close within 3 s", self.name)


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
    """Client end of one portal connection: portal's framing, one `bytes` argument and result.

    Framing (portal 3.8): every message is a u64 length then the body. Request body: reqnum u64,
    method-name length u64, name, packlib(args); reply body: reqnum u64, status u64 (non-zero: a utf-8
    error text follows), packlib(result). packlib: leaf count u64, one u64 size per buffer, msgpack
    tree, msgpack leaf specs, the leaves. We send and accept only a single `bytes` leaf.

    Why not `portal.Client`: in portal 3.8 its socket thread can keep a stale wake-up byte and then
    busy-loop on a non-blocking recv whenever it has nothing to send (measured: ~1 CPU core per idle
    client, and call latency several times worse); `Future.wait` can miss a wake-up; and an unexpected
    exception in its threads ends the whole program with `os._exit(1)`. Here, sends go out from the
    calling thread under a lock and one reader thread blocks in recv.
    """

    _TREE = msgpack.packb([None])  # the argument tuple: one positional argument
    _SPECS = msgpack.packb([["bytes"]])
    _RESULT_TREE = msgpack.packb(None)  # the result: one leaf

    def __init__(self, host: str, port: int, name: str, connect_timeout: float, send_timeout: float,
                 max_reply_bytes: int = 1 << 31):
        self.sock = socket.create_connection((host, port), timeout=connect_timeout)
        try:
            self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self.sock.settimeout(send_timeout)  # bounds a send to a peer that stopped reading
            self.sock.sendall(b"portal_handshake")
        except OSError:
            self.sock.close()
            raise
        #: When bytes last arrived (the heartbeat: a large answer on a slow link is not silence).
        self.last_rx = clock.now()
        self.max_reply_bytes = max_reply_bytes
        self._lock = threading.Lock()
        self._ids = itertools.count(1)
        self._pending: dict[int, _Reply] = {}
        self.lost: str | None = None
        self._closing = False
        self._reader = threading.Thread(target=self._read_loop, name=f"rio-{name}-portal-recv", daemon=True)
        self._reader.start()

    def send(self, method: bytes, payload: bytes, reply: _Reply) -> int:
        """Send one call; its answer will be put into `reply`. Raises ConnectionError when lost."""
        sizes = struct.pack("<4Q", 3, len(self._TREE), len(self._SPECS), len(payload))
        n = 24 + len(method) + len(sizes) + len(self._TREE) + len(self._SPECS) + len(payload)
        with self._lock:
            if self.lost is not None:
                raise ConnectionError(self.lost)
            reqnum = next(self._ids)
            self._pending[reqnum] = reply
            msg = b"".join([struct.pack("<3Q", n - 8, reqnum, len(method)), method, sizes,
                            self._TREE, self._SPECS, payload])
            try:
                self.sock.sendall(msg)
            except OSError as e:  # a timeout leaves a partial message: the connection is unusable
                self._lose(f"send failed: {type(e).__name__}: {e}", locked=True)
                raise ConnectionError(self.lost) from e
        return reqnum

    def forget(self, reqnum: int) -> None:
        self._pending.pop(reqnum, None)

    def _read_exact(self, n: int) -> bytearray:
        buf = bytearray(n)
        view, pos = memoryview(buf), 0
        while pos < n:
            try:
                k = self.sock.recv_into(view[pos:])
            except TimeoutError:  # idle connection; the timeout is there for sends
                if self._closing:
                    raise ConnectionError("closed") from None
                continue
            if k == 0:
                raise ConnectionError("connection closed by the server")
            pos += k
            self.last_rx = clock.now()
        return buf

    def _result(self, body: bytearray) -> memoryview:
        count = int.from_bytes(body[16:24], "little")
        if count != 3:
            raise ValueError(f"reply with {count} buffers")
        t, sp, leaf = struct.unpack_from("<3Q", body, 24)
        start = 48
        if bytes(body[start:start + t]) != self._RESULT_TREE or bytes(body[start + t:start + t + sp]) != self._SPECS:
            raise ValueError("reply is not a single bytes value")
        return memoryview(body)[start + t + sp:start + t + sp + leaf]

    def _read_loop(self) -> None:
        try:
            while True:
                n = int.from_bytes(self._read_exact(8), "little")
                if not 16 <= n <= self.max_reply_bytes:
                    raise ValueError(f"bad message length {n}")
                body = self._read_exact(n)
                reqnum, status = struct.unpack_from("<2Q", body)
                reply = self._pending.pop(reqnum, None)
                if reply is None:  # a timed-out call, answered late
                    continue
                if status:
                    reply.error = bytes(body[16:]).decode("utf-8", "replace")
                else:
                    try:
                        reply.data = self._result(body)
                    except ValueError as e:
                        reply.error = f"malformed reply: {e}"
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
        self._inflight: collections.deque[_Reply] = collections.deque()  # sent requests, oldest first
        self._inflight_lock = threading.Lock()
        self._conn: _Connection | None = None
        self._poller: threading.Thread | None = None
        self.ring_buffer = RingBuffer(layouts.data, layouts.buffer_capacity) if layouts.data is not None else None
        self.request_queue = RequestSender(layouts.request, self._send_request) if layouts.request is not None else None
        try:
            self._conn = _Connection(host, port, self.name, config.connect_timeout, max(config.call_timeout, 1.0))
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
        self.check_alive()
        with self._inflight_lock:
            while self._inflight and self._inflight[0].event.is_set():
                reply = self._inflight.popleft()
                if reply.data is not None and bytes(reply.data) != _OK:  # the server refused it (and logged it)
                    log.warning("node '%s': request refused: %s", self.name, bytes(reply.data).decode(errors="replace"))
            oldest = self._inflight[0] if len(self._inflight) >= self.config.max_inflight_requests else None
        if oldest is not None:  # back-pressure: the node is not keeping up
            self._wait(oldest, self.config.call_timeout, "send_request (request queue backlog)")
        reply = _Reply()
        with self._inflight_lock:
            try:
                self._conn.send(b"req", record, reply)  # type: ignore[union-attr]
            except ConnectionError as e:
                raise self._lost(str(e)) from e
            self._inflight.append(reply)

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
        #: Interface the server binds; "0.0.0.0" (or a machine's address) to serve other machines, only
        #: with `insecure = true` (no authentication; prefer a tunnel).
        host: str = "127.0.0.1"
        #: TCP port; None picks a free one (reported in the address). One port serves one node.
        port: int | None = Field(default=None, ge=0, le=65535)
        #: Seconds a client waits for the TCP connection and handshake.
        connect_timeout: float = 5.0
        #: A server on another machine whose long poll stays silent this long is reported dead.
        heartbeat_timeout: float = 0.5
        #: Server threads for long polls: how many clients are mirrored without waiting for a turn.
        poll_workers: int = Field(default=16, ge=1)
        #: Upper bound on one poll answer (the newest samples that fit; at least one).
        max_batch_bytes: int = Field(default=8 * 1024 * 1024, ge=1)
        #: Requests a client may have unacknowledged before `send_request` waits (back-pressure).
        max_inflight_requests: int = Field(default=64, ge=1)

    def make_server(self, node: Node, layouts: NodeLayouts, resources: dict[str, Any]) -> PortalServer:
        return PortalServer(node, layouts, self.config)

    def make_client(self, node: Node, layouts: NodeLayouts, address: dict[str, Any]) -> PortalClient:
        return PortalClient(node, layouts, address, self.config)


PortalConfig = PortalMiddleware.Config
