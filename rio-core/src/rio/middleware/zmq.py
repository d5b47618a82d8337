"""ZeroMQ middleware: a process per node, reachable over TCP (one machine or several).

Server sockets (bound to loopback unless `host` says otherwise):
- PUB (`state_port`): every published sample as two frames, a 20-byte header (kind, data-layout
  fingerprint, server epoch, sample sequence number) and the record's raw bytes; plus a heartbeat every
  `heartbeat_s` from its own thread, so a client on another machine notices a dead server even when
  the node publishes nothing. A "bye" goes out on a clean shutdown.
- ROUTER (`rpc_port`): the handshake, requests (raw record bytes, no reply) and API calls
  (`rio.wire` msgpack), all answered by the one thread that owns the socket (zmq sockets are not
  thread-safe). Calls run inline there: handing them to a worker thread and the reply back costs two
  thread wake-ups, which doubled the call latency. The price is that while a long API call runs,
  new handshakes and incoming requests wait; the node is stalled anyway then, because the
  Dispatcher holds the node's lock for the call and the node loop needs it for every request.
  A message larger than `max_message_bytes` disconnects its sender before anything is allocated.

Client: a SUB socket drained by a receive thread into a local ring-buffer mirror (reads never block
and never touch the network), one DEALER for calls and the handshake, and a second DEALER for
requests, so `send_request` is never queued behind a slow API call. The SUB connects *before* the
handshake and samples carry sequence numbers: the handshake seeds the mirror with the newest sample
(zmq's slow joiner would otherwise leave it empty) and the receive thread drops anything not newer,
so the mirror never goes backwards or holds duplicates.

Nothing from the network is unpickled: samples and requests are fixed-size records checked against
the layout, calls and the handshake are msgpack via `rio.wire`.
"""

from __future__ import annotations

import itertools
import logging
import os
import socket
import struct
import threading
import time
from typing import Any

import zmq
from pydantic import Field

from .. import clock, wire
from ..buffers import RequestQueue, RequestSender, RingBuffer
from ..errors import ConfigError, NodeDiedError, NodeError, NodeTimeout, RioError
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

log = logging.getLogger("rio.middleware.zmq")

# PUB header: kind, 3 pad bytes, data-layout fingerprint (u32), server epoch (u32, random per
# server start: a restarted server on the same port is a different server), sequence number (u64).
_HDR = struct.Struct("<c3xIIQ")
_STATE, _BEAT, _BYE = b"S", b"H", b"B"
# ROUTER/DEALER messages are one frame (after the ROUTER's identity): a kind byte, then the body.
# One frame rather than two: every frame costs a little on both sides of the latency-critical call.
_HELLO, _REQ, _CALL = b"h", b"r", b"c"

#: Bytes of samples a PUB/SUB pipe may hold: a few camera frames, or ~1000 small samples. A slow
#: reader then gets recent samples instead of a growing backlog (the PUB drops beyond it).
_HWM_BYTES = 4 << 20
_POLL_MS = 50  # how often blocking loops look at their stop flag / the server's liveness
#: Added to the request record's size for `max_message_bytes` (the kind byte, and room to spare).
_MESSAGE_HEADROOM = 4096
#: Messages of one peer the ROUTER holds before TCP pushes back (bounds a flood to this x the max size).
_ROUTER_HWM = 16
_WILDCARD = ("0.0.0.0", "*", "", "::")


def _hwm(msg_bytes: int) -> int:
    return max(2, min(1000, _HWM_BYTES // max(msg_bytes, 1)))


# -- server ------------------------------------------------------------------------------------------
class ZmqServer(ServerTransport):
    def __init__(self, node: Node, layouts: NodeLayouts, config: ZmqConfig):
        self.name, self.layouts, self.config = node.name, layouts, config
        self._data_fp = layouts.data.fingerprint if layouts.data else 0
        self._epoch = int.from_bytes(os.urandom(4), "little")
        self.ring_buffer = (RingBuffer(layouts.data, layouts.buffer_capacity, on_put=self._publish)
                            if layouts.data else None)
        self.request_queue = (RequestQueue(layouts.request, layouts.request_capacity)
                              if layouts.request else None)
        self._ctx = zmq.Context(io_threads=1)
        self._pub = self._ctx.socket(zmq.PUB)
        self._pub.setsockopt(zmq.LINGER, 0)
        self._pub.setsockopt(zmq.SNDHWM, _hwm(layouts.data.itemsize if layouts.data else 64))
        self._router = self._ctx.socket(zmq.ROUTER)
        self._router.setsockopt(zmq.LINGER, 0)
        self._router.setsockopt(zmq.RCVTIMEO, _POLL_MS)  # the rpc thread looks at its stop flag
        # A peer cannot make the node allocate what it claims: libzmq disconnects a peer whose message
        # header announces more than this, before reading it; and a flooding peer is throttled by TCP once
        # `_ROUTER_HWM` of its messages wait (the rpc thread drains real clients' few messages at once).
        self.max_message_bytes = max(config.max_message_bytes, (layouts.request.itemsize if layouts.request else 0)
                                     + _MESSAGE_HEADROOM)
        self._router.setsockopt(zmq.MAXMSGSIZE, self.max_message_bytes)
        self._router.setsockopt(zmq.RCVHWM, _ROUTER_HWM)
        self._pub_lock = threading.Lock()  # node loop, SDK callbacks and the heartbeat share the PUB
        self._last: tuple[int, bytes] | None = None  # newest (seq, record bytes) sent, for handshakes
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._dispatch: Any = None
        self._closed = False

    def _bind(self, sock: zmq.Socket, port: int | None, what: str) -> int:
        host = self.config.host
        try:
            sock.bind(f"tcp://{host}:{'*' if port is None else port}")
        except zmq.ZMQError as e:
            raise ConfigError(f"node '{self.name}': zmq cannot bind {what} to {host}:{port}: {e}") from e
        return int(sock.getsockopt_string(zmq.LAST_ENDPOINT).rsplit(":", 1)[1])

    def start(self, dispatch: Any) -> dict[str, Any]:
        self._dispatch = dispatch
        warn_if_exposed(self.config, self.name, log)
        state_port = self._bind(self._pub, self.config.state_port, "state_port")
        rpc_port = self._bind(self._router, self.config.rpc_port, "rpc_port")
        for target, what in ((self._serve_rpc, "rpc"), (self._beat, "heartbeat")):
            t = threading.Thread(target=target, name=f"rio-zmq-{self.name}-{what}", daemon=True)
            t.start()
            self._threads.append(t)
        host = self.config.host
        return {
            "host": "127.0.0.1" if host in _WILDCARD else host,
            "state_port": state_port,
            "rpc_port": rpc_port,
            "hostname": socket.gethostname(),
            "heartbeat_s": self.config.heartbeat_s,
        }

    # PUB side ------------------------------------------------------------------------------------
    def _publish(self, rec: Any) -> None:
        """RingBuffer.on_put: send the new record right after it is stored (node loop's thread)."""
        data = rec.tobytes()
        with self._pub_lock:
            if self._closed:
                return
            seq = self.ring_buffer.count
            self._last = (seq, data)
            self._pub.send_multipart([_HDR.pack(_STATE, self._data_fp, self._epoch, seq), data], copy=False)

    def _send_control(self, kind: bytes) -> None:
        with self._pub_lock:
            if not self._closed:
                seq = self._last[0] if self._last else 0
                self._pub.send(_HDR.pack(kind, self._data_fp, self._epoch, seq))

    def _beat(self) -> None:
        """Heartbeat from its own thread: keeps going while the node loop is busy or idle."""
        while not self._stop.wait(self.config.heartbeat_s):
            self._send_control(_BEAT)

    # ROUTER side ---------------------------------------------------------------------------------
    def _hello(self) -> bytes:
        last = self._last
        return wire.pack({"node": self.name, "fingerprint": self.layouts.fingerprint(), "epoch": self._epoch,
                          "seq": last[0] if last else 0, "latest": last[1] if last else None})

    def _serve_rpc(self) -> None:
        """Owns the ROUTER: answers handshakes, enqueues requests, runs API calls."""
        router = self._router
        while not self._stop.is_set():
            try:
                msg = router.recv_multipart()
            except zmq.Again:
                continue
            try:
                self._on_message(msg)
            except Exception:  # never let one bad message end the thread
                log.exception("node '%s': while handling a zmq message", self.name)

    def _on_message(self, msg: list[bytes]) -> None:
        if len(msg) != 2:
            log.warning("node '%s': ignored a zmq message of %d frames", self.name, len(msg))
            return
        ident, data = msg
        kind, body = data[:1], memoryview(data)[1:]
        if kind == _CALL:
            self._router.send_multipart([ident, _CALL + self._call(body)])
        elif kind == _REQ:
            if self.request_queue is None:
                log.warning("node '%s' takes no requests; dropped one", self.name)
                return
            try:
                self.request_queue.put_bytes(body)
            except RioError as e:  # InvalidRequest / QueueFull: report, keep serving
                log.warning("%s", e)
        elif kind == _HELLO:
            self._router.send_multipart([ident, _HELLO + self._hello()])
        else:
            log.warning("node '%s': ignored a zmq message of unknown kind %r", self.name, kind)

    def _call(self, payload: bytes | memoryview) -> bytes:
        try:
            call_id, method, args, kwargs = wire.unpack_call(payload)
        except Exception as e:  # cannot even tell which call: id -1 is never awaited
            return wire.pack_reply(-1, False, wire.error_payload(e))
        try:
            return wire.pack_reply(call_id, True, self._dispatch(method, args, kwargs))
        except Exception as e:
            return wire.pack_reply(call_id, False, wire.error_payload(e))

    def close(self) -> None:
        if self._closed:
            return
        self._send_control(_BYE)  # remote clients learn at once instead of after the timeout
        with self._pub_lock:
            self._closed = True
        self._stop.set()
        for t in self._threads:
            t.join(timeout=2.0)
        self._pub.close(linger=200)  # let the "bye" leave
        self._router.close(linger=0)
        if any(t.is_alive() for t in self._threads):
            # A call still running in the node would make term() wait for its socket; the
            # process is ending anyway, so leave the context to it.
            log.warning("node '%s': an API call was still running at shutdown", self.name)
            return
        self._ctx.term()


# -- client ------------------------------------------------------------------------------------------
class ZmqClient(ClientTransport):
    def __init__(self, node: Node, layouts: NodeLayouts, address: dict[str, Any], config: ZmqConfig):
        self.name, self.layouts, self.config = node.name, layouts, config
        try:
            host, state_port, rpc_port = address["host"], int(address["state_port"]), int(address["rpc_port"])
        except (KeyError, TypeError, ValueError) as e:
            raise ConfigError(f"node '{self.name}': zmq address needs host, state_port, rpc_port; got {address}") from e
        self._data_fp = layouts.data.fingerprint if layouts.data else 0
        self._watch = local_process_watch(address, self.name)
        self._beat_timeout = max(config.heartbeat_timeout, 5 * float(address.get("heartbeat_s", 0.05)))
        self._last_heard = clock.now()
        #: Why the server is known to be gone; sticky: a server that comes back is a new server
        #: (new sequence numbers, maybe a new layout), so the client must connect again.
        self._gone: str | None = None
        self._epoch: int | None = None
        self._last_seq = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

        self.ring_buffer = RingBuffer(layouts.data, layouts.buffer_capacity) if layouts.data else None
        self._ctx = zmq.Context(io_threads=1)
        self._sub = self._socket(zmq.SUB)
        self._sub.setsockopt(zmq.RCVHWM, _hwm(layouts.data.itemsize if layouts.data else 64))
        self._sub.setsockopt(zmq.SUBSCRIBE, b"")
        self._call_sock = self._socket(zmq.DEALER)
        self._req_sock = self._socket(zmq.DEALER)
        self._req_sock.setsockopt(zmq.SNDHWM, max(layouts.request_capacity, 2))
        self._call_lock, self._req_lock = threading.Lock(), threading.Lock()
        self._call_ids = itertools.count(1)  # next() is atomic under the GIL
        try:
            self._sub.connect(f"tcp://{host}:{state_port}")  # before the handshake: see module doc
            self._call_sock.connect(f"tcp://{host}:{rpc_port}")
            self._req_sock.connect(f"tcp://{host}:{rpc_port}")
            self._handshake()
        except BaseException:
            self.close()
            raise
        self.request_queue = RequestSender(layouts.request, self._send_request) if layouts.request else None
        self._thread = threading.Thread(target=self._receive, name=f"rio-zmq-{self.name}-sub", daemon=True)
        self._thread.start()

    def _socket(self, kind: int) -> zmq.Socket:
        s = self._ctx.socket(kind)
        s.setsockopt(zmq.LINGER, 0)
        # Queue only on live connections: a command must not wait in a buffer and be delivered to
        # a server that comes back later.
        if kind == zmq.DEALER:
            s.setsockopt(zmq.IMMEDIATE, 1)
        s.setsockopt(zmq.RCVTIMEO, _POLL_MS)
        return s

    # liveness ------------------------------------------------------------------------------------
    def check_alive(self) -> None:
        if self._gone is not None:
            raise NodeDiedError(self.name, self._gone)
        if self._watch is not None:
            self._watch.check()
        elif clock.now() - self._last_heard > self._beat_timeout:
            # Our own receive thread may just not have run (this process was paused or busy):
            # give it a moment to drain heartbeats already waiting before calling the server dead.
            t_end = clock.now() + 0.1
            while clock.now() < t_end and clock.now() - self._last_heard > self._beat_timeout:
                time.sleep(0.005)
            if clock.now() - self._last_heard > self._beat_timeout:
                self._gone = f"no heartbeat from the server for {self._beat_timeout:.2g} s"
                raise NodeDiedError(self.name, self._gone)

    # sending ---------------------------------------------------------------------------------------
    def _send(self, sock: zmq.Socket, data: bytes, what: str, timeout: float) -> None:
        """Non-blocking send, retried while the connection is (re)establishing or the pipe is full,
        checking liveness, so a dead server is an error and never a hang."""
        deadline = None
        while True:
            try:
                sock.send(data, zmq.NOBLOCK)
                return
            except zmq.Again:
                pass
            self.check_alive()
            t = clock.now()
            deadline = deadline or t + timeout
            if t > deadline:
                raise NodeTimeout(self.name, what, timeout)
            time.sleep(0.0005)

    def _send_request(self, data: bytes) -> None:
        with self._req_lock:
            self._send(self._req_sock, _REQ + data, "sending a request", 1.0)

    def _await(self, kind: bytes, accept: Any, what: str, timeout: float) -> Any:
        """Wait on the call socket for a reply of `kind` that `accept` recognizes (returns not None);
        stale replies (of calls that timed out earlier) are dropped."""
        deadline = clock.now() + timeout
        sock = self._call_sock
        while True:
            try:
                msg = sock.recv()  # RCVTIMEO: at most _POLL_MS between liveness checks
            except zmq.Again:
                self.check_alive()
                if clock.now() > deadline:
                    raise NodeTimeout(self.name, what, timeout) from None
                continue
            if msg[:1] == kind:
                got = accept(memoryview(msg)[1:])
                if got is not None:
                    return got

    def _handshake(self) -> None:
        timeout = self.config.call_timeout
        self._send(self._call_sock, _HELLO, "connecting", timeout)
        hello = self._await(_HELLO, wire.unpack, "connecting (handshake)", timeout)
        theirs, ours = list(hello.get("fingerprint", [])), self.layouts.fingerprint()
        if theirs != ours:
            raise ConfigError(
                f"node '{self.name}': layout mismatch with server node '{hello.get('node')}' "
                f"(fingerprints {theirs} vs ours {ours}); client and server must build the node "
                "with the same class and config")
        self._last_heard = clock.now()
        self._epoch = hello.get("epoch")
        if self.ring_buffer is not None and hello.get("latest") is not None:
            self.ring_buffer.put_bytes(hello["latest"])
            self._last_seq = int(hello["seq"])

    def call(self, method: str, args: tuple, kwargs: dict) -> Any:
        cid = next(self._call_ids)
        data = _CALL + wire.pack_call(cid, method, args, kwargs)

        def mine(payload: memoryview) -> tuple | None:
            reply = wire.unpack_reply(payload)
            return reply if reply[0] == cid else None

        with self._call_lock:
            self.check_alive()
            sock, reply = self._call_sock, None
            # Fast path first (one send, one receive within RCVTIMEO): this is the latency that
            # counts, so no helper calls or string formatting unless something is slow or odd.
            try:
                sock.send(data, zmq.NOBLOCK)
            except zmq.Again:
                self._send(sock, data, f"call '{method}'", self.config.call_timeout)
            try:
                msg = sock.recv()
                if msg[:1] == _CALL:
                    reply = mine(memoryview(msg)[1:])
            except zmq.Again:
                pass
            if reply is None:
                reply = self._await(_CALL, mine, f"call '{method}'", self.config.call_timeout)
        _, ok, value = reply
        if ok:
            return value
        if isinstance(value, list) and len(value) == 3:
            raise NodeError(self.name, *map(str, value))
        raise NodeError(self.name, "RemoteError", str(value))

    # receiving -------------------------------------------------------------------------------------
    def _receive(self) -> None:
        """Owns the SUB socket: samples go into the mirror, every message counts as a heartbeat."""
        sub, rb = self._sub, self.ring_buffer
        want_fp = self._data_fp
        warned = False
        while not self._stop.is_set():
            try:
                frames = sub.recv_multipart(copy=False)  # RCVTIMEO: look at the stop flag
            except zmq.Again:
                continue
            head = frames[0].bytes
            if len(head) != _HDR.size:
                continue
            kind, fp, epoch, seq = _HDR.unpack(head)
            if epoch != self._epoch:
                self._gone = self._gone or "server restarted (connect again)"
                continue
            self._last_heard = clock.now()
            if kind == _BYE:
                self._gone = "server closed"
                continue
            if kind != _STATE or rb is None or len(frames) != 2:
                continue
            if fp != want_fp:
                if not warned:
                    log.warning("node '%s': dropping samples with a foreign layout", self.name)
                    warned = True
                continue
            if seq <= self._last_seq:  # already seeded by the handshake (or out of order)
                continue
            try:
                rb.put_bytes(frames[1].buffer)
            except RioError as e:
                log.warning("%s", e)
                continue
            self._last_seq = seq

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        if self._ctx.closed:
            return
        for s in (self._sub, self._call_sock, self._req_sock):
            s.close(linger=0)
        self._ctx.term()
        if self._watch is not None:
            self._watch.close()


class ZmqMiddleware(Middleware):
    """pyzmq over TCP: PUB/SUB for state (mirrored client-side), ROUTER/DEALER for the rest."""

    name = "zmq"
    class Config(NetworkConfig):
        #: Interface to bind. "0.0.0.0" serves other machines (they pass the address with a real host);
        #: only with `insecure = true` (no authentication yet).
        host: str = "127.0.0.1"
        #: Ports of the PUB (state) and ROUTER (requests, calls) sockets; None picks a free port.
        state_port: int | None = Field(None, ge=1, le=65535)
        rpc_port: int | None = Field(None, ge=1, le=65535)
        #: Server heartbeat period, and how long a client on another machine waits without hearing
        #: anything (heartbeat or sample) before it reports the node dead.
        heartbeat_s: float = Field(0.05, gt=0, le=1.0)
        heartbeat_timeout: float = Field(0.5, gt=0)
        #: Largest message (API call or request) a node accepts; a peer sending more is disconnected
        #: before anything is allocated. Raised to fit the node's request record where that is larger.
        max_message_bytes: int = Field(4 << 20, ge=1024)

    def make_server(self, node: Node, layouts: NodeLayouts, resources: dict[str, Any]) -> ZmqServer:
        return ZmqServer(node, layouts, self.config)

    def make_client(self, node: Node, layouts: NodeLayouts, address: dict[str, Any]) -> ZmqClient:
        return ZmqClient(node, layouts, address, self.config)


ZmqConfig = ZmqMiddleware.Config
