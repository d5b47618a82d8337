"""ZeroMQ middleware: a process per node, reachable over TCP (one machine or several).

Server sockets (bound to loopback unless `host` says otherwise):
- PUB (`state_port`): every published sample as two frames, a 20-byte header (kind, data-layout
  fingerprint, server epoch, sample sequence number) and the record's raw bytes; plus a heartbeat every
  `heartbeat_s` from its own thread, so a client on another machine notices a dead server even when
  the node publishes nothing. A "bye" goes out on a clean shutdown.
- ROUTER (`rpc_port`): the handshake, requests (raw record bytes) and API calls (`rio.runtime.wire` msgpack).
  One thread owns the socket (zmq sockets are not thread-safe) and never runs node code: it answers
  handshakes, enqueues requests and answers each one at once (taken / queue full / invalid / no
  requests: nothing is dropped silently), and hands API calls to the API thread through a bounded
  queue (at most `_CALLS_PER_PEER` per zmq peer and `_CALLS_QUEUED` in all; beyond that a call is
  answered "too many calls queued" at once). So a stranger's slow or numerous calls never stall
  another client's requests or handshake. The API thread sends its replies back through an inproc
  socket that the ROUTER thread forwards; a reply for a peer that has gone is dropped by zmq.
  A message larger than `max_message_bytes` disconnects its sender before anything is allocated.
  Errors going back to a peer carry the exception's type and message (absolute paths cut,
  `wire.remote_error_payload`); the traceback stays in the server's debug log.

Authentication (`keys` in the config, `rio.machine.keys`): both server sockets are CURVE servers with this
machine's key pair, and a ZAP handler admits only the clients whose public key is in this machine's
`peers/`: others get no state, no requests in and no calls. The address names the server machine's
`identity`; a client takes that machine's public key from its *own* `peers/` (never from the
network) and authenticates with its own key pair, and fails with a ConfigError that says
"authentication" when the two sides disagree. Without keys: plain TCP, as `NetworkConfig` allows it
(loopback, or `insecure = true`).

Client: a SUB socket drained by a receive thread into a local ring-buffer mirror (reads never block
and never touch the network), one DEALER for calls and the handshake, and a second DEALER for
requests, so `send_request` is never queued behind a slow API call. The SUB connects *before* the
handshake and samples carry sequence numbers: the handshake seeds the mirror with the newest sample
(zmq's slow joiner would otherwise leave it empty) and the receive thread drops anything not newer,
so the mirror never goes backwards or holds duplicates. `send_request` waits for the server's answer
(a few bytes): QueueFull after the queue stayed full for `_PUT_TIMEOUT` (as the shared-memory queue
does), InvalidRequest when the server refuses the record, NodeTimeout when no answer comes.

Nothing from the network is unpickled: samples and requests are fixed-size records checked against
the layout, calls and the handshake are msgpack via `rio.runtime.wire`.
"""

from __future__ import annotations

import itertools
import logging
import os
import queue
import socket
import struct
import threading
import time
from typing import TYPE_CHECKING, Any

import msgpack
import zmq
from pydantic import Field

from rio import clock
from rio.errors import ConfigError, InvalidRequest, NodeDiedError, NodeError, NodeTimeout, QueueFull, RioError
from rio.runtime import wire
from rio.runtime.buffers import RequestQueue, RequestSender, RingBuffer
from rio.runtime.node import Node
from rio.runtime.transport import (
    ClientTransport,
    Middleware,
    NetworkConfig,
    NodeLayouts,
    ServerTransport,
    local_process_watch,
    warn_if_exposed,
)

if TYPE_CHECKING:
    from rio.station.model import MachineSection

log = logging.getLogger("rio.middleware.zmq")

# PUB header: kind, 3 pad bytes, data-layout fingerprint (u32), server epoch (u32, random per
# server start: a restarted server on the same port is a different server), sequence number (u64).
_HDR = struct.Struct("<c3xIIQ")
_STATE, _BEAT, _BYE = b"S", b"H", b"B"
# ROUTER/DEALER messages are one frame (after the ROUTER's identity): a kind byte, then the body.
# One frame rather than two: every frame costs a little on both sides of the latency-critical call.
_HELLO, _REQ, _CALL = b"h", b"r", b"c"
#: Version of the messages below, checked at the handshake (a server of another version answers
#: requests differently, or not at all).
_PROTOCOL = 2
# A request is _REQ, its number (u32) and the record's bytes; its answer is _REQ, the same number
# and one status byte, then (not taken) msgpack details.
_SEQ = struct.Struct("<I")
_TAKEN, _FULL, _INVALID, _NO_REQUESTS = b"k", b"f", b"i", b"n"
#: How long `send_request` retries a full queue before QueueFull (RequestQueue's own put timeout), and
#: waits for the server's answer to one request before NodeTimeout.
_PUT_TIMEOUT = 1.0
_REQUEST_TIMEOUT = 2.0

#: Bytes of samples a PUB/SUB pipe may hold: a few camera frames, or ~1000 small samples. A slow
#: reader then gets recent samples instead of a growing backlog (the PUB drops beyond it).
_HWM_BYTES = 4 << 20
_POLL_MS = 50  # how often blocking loops look at their stop flag / the server's liveness
#: Messages of one peer the ROUTER holds before TCP pushes back (bounds a flood to this x the max size).
_ROUTER_HWM = 16
#: API calls waiting or running, per zmq peer and in all; beyond either the call is refused at once.
_CALLS_PER_PEER = 8
_CALLS_QUEUED = 64
#: Messages the ROUTER thread takes in a row before it forwards the API thread's replies.
_BATCH = 64
_WILDCARD = ("0.0.0.0", "*", "", "::")
#: Handshake failures a client's monitor reports when the two sides' authentication disagree.
_AUTH_EVENTS = (zmq.EVENT_HANDSHAKE_FAILED_AUTH | zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL
                | zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL)


def _hwm(msg_bytes: int) -> int:
    return max(2, min(1000, _HWM_BYTES // max(msg_bytes, 1)))


def _call_id(payload: bytes | memoryview) -> int:
    """The id of a call (the first element of its msgpack array) without decoding its arguments;
    -1 (never awaited) when the message is not a call."""
    try:
        unpacker = msgpack.Unpacker(max_buffer_size=len(payload) + 1)
        unpacker.feed(payload)
        unpacker.read_array_header()
        cid = unpacker.unpack()
    except Exception:
        return -1
    return cid if isinstance(cid, int) else -1


class _Throttled:
    """A warning logged at most once per `period` s (a flood of bad messages must not flood the log)."""

    def __init__(self, period: float = 5.0):
        self.period, self._next = period, 0.0

    def __call__(self, msg: str, *args: Any) -> None:
        t = clock.now()
        if t >= self._next:
            self._next = t + self.period
            log.warning(msg, *args)
        else:
            log.debug(msg, *args)


# -- server ------------------------------------------------------------------------------------------
class ZmqServer(ServerTransport):
    def __init__(self, node: Node, layouts: NodeLayouts, config: ZmqConfig):
        self.name, self.layouts, self.config = node.name, layouts, config
        self._keys = config.machine_keys()
        self._data_fp = layouts.data.fingerprint if layouts.data else 0
        self._epoch = int.from_bytes(os.urandom(4), "little")
        self.ring_buffer = (RingBuffer(layouts.data, layouts.buffer_capacity, on_put=self._publish)
                            if layouts.data else None)
        self.request_queue = (RequestQueue(layouts.request, layouts.request_capacity)
                              if layouts.request else None)
        self._ctx = zmq.Context(io_threads=1)
        self._auth: Any = None  # the ZAP handler (zmq.auth.thread.ThreadAuthenticator), started by start()
        self._pub = self._ctx.socket(zmq.PUB)
        self._pub.setsockopt(zmq.LINGER, 0)
        self._pub.setsockopt(zmq.SNDHWM, _hwm(layouts.data.itemsize if layouts.data else 64))
        self._router = self._ctx.socket(zmq.ROUTER)
        self._router.setsockopt(zmq.LINGER, 0)
        # A peer cannot make the node allocate what it claims: libzmq disconnects a peer whose message
        # header announces more than this, before reading it; and a flooding peer is throttled by TCP once
        # `_ROUTER_HWM` of its messages wait (the rpc thread drains real clients' few messages at once).
        self.max_message_bytes = config.message_limit(layouts)
        self._router.setsockopt(zmq.MAXMSGSIZE, self.max_message_bytes)
        self._router.setsockopt(zmq.RCVHWM, _ROUTER_HWM)
        if self._keys is not None:
            public, secret = self._keys.curve_keypair()
            for s in (self._pub, self._router):
                s.curve_secretkey, s.curve_publickey = secret, public
                s.curve_server = True
                # Fail closed: with a ZAP domain and ZAP_ENFORCE_DOMAIN, libzmq refuses every client while
                # no ZAP handler answers (without them a CURVE server admits any key). The domain is the
                # one `start` configures ("*"); libzmq builds without the option still have the handler.
                s.zap_domain = b"*"
                try:
                    s.setsockopt(zmq.ZAP_ENFORCE_DOMAIN, 1)
                except (AttributeError, zmq.ZMQError):
                    pass
        # The API thread's replies, forwarded to the ROUTER by its own thread.
        endpoint = f"inproc://rio-zmq-replies-{id(self):x}"
        self._replies_in = self._ctx.socket(zmq.PULL)
        self._replies_in.setsockopt(zmq.LINGER, 0)
        self._replies_in.bind(endpoint)
        self._replies_out = self._ctx.socket(zmq.PUSH)
        self._replies_out.setsockopt(zmq.LINGER, 0)
        self._replies_out.connect(endpoint)
        # Calls for the API thread (None: stop), and how many each peer has waiting or running.
        self._calls: queue.SimpleQueue[tuple[bytes, bytes, float] | None] = queue.SimpleQueue()
        self._queued: dict[bytes, int] = {}
        self._n_queued = 0
        self._queued_lock = threading.Lock()
        self._warn = _Throttled()
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
        if self._keys is not None:
            # Before binding: the first client already meets the handler (this machine's peers/ only).
            from zmq.auth.thread import ThreadAuthenticator

            self._auth = ThreadAuthenticator(self._ctx, log=logging.getLogger("rio.middleware.zmq.auth"))
            self._auth.start()
            self._auth.configure_curve(domain="*", location=str(self._keys.dir / "peers"))
        try:
            state_port = self._bind(self._pub, self.config.state_port, "state_port")
            rpc_port = self._bind(self._router, self.config.rpc_port, "rpc_port")
        except BaseException:
            if self._auth is not None:
                self._auth.stop()
                self._auth = None
            raise
        for target, what in ((self._serve_rpc, "rpc"), (self._run_calls, "api"), (self._beat, "heartbeat")):
            t = threading.Thread(target=target, name=f"rio-zmq-{self.name}-{what}", daemon=True)
            t.start()
            self._threads.append(t)
        host = self.config.host
        address = {
            "host": "127.0.0.1" if host in _WILDCARD else host,
            "state_port": state_port,
            "rpc_port": rpc_port,
            "hostname": socket.gethostname(),
            "heartbeat_s": self.config.heartbeat_s,
        }
        if self._keys is not None:
            address["identity"] = self._keys.identity
        return address

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
                          "seq": last[0] if last else 0, "latest": last[1] if last else None,
                          "protocol": _PROTOCOL})

    def _serve_rpc(self) -> None:
        """Owns the ROUTER: answers handshakes and requests, queues API calls, forwards their replies.
        Runs no node code, so it is never stalled by a call."""
        router, replies = self._router, self._replies_in
        poller = zmq.Poller()
        poller.register(router, zmq.POLLIN)
        poller.register(replies, zmq.POLLIN)
        while not self._stop.is_set():
            try:
                ready = dict(poller.poll(_POLL_MS))
            except zmq.ZMQError:  # the context is going away
                return
            if replies in ready:
                self._forward_replies()
            if router not in ready:
                continue
            for _ in range(_BATCH):
                try:
                    msg = router.recv_multipart(zmq.NOBLOCK)
                except zmq.Again:
                    break
                try:
                    self._on_message(msg)
                except Exception:  # never let one bad message end the thread
                    log.exception("node '%s': while handling a zmq message", self.name)

    def _forward_replies(self) -> None:
        replies, router = self._replies_in, self._router
        while True:
            try:
                msg = replies.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            try:  # ROUTER_MANDATORY off: a reply for a peer that has gone (or reads nothing) is dropped
                router.send_multipart(msg, zmq.NOBLOCK)
            except zmq.ZMQError:
                pass

    def _on_message(self, msg: list[bytes]) -> None:
        if len(msg) != 2:
            self._warn("node '%s': ignored a zmq message of %d frames", self.name, len(msg))
            return
        ident, data = msg
        kind = data[:1]
        if kind == _REQ:
            self._on_request(ident, data)
        elif kind == _CALL:
            self._queue_call(ident, data)
        elif kind == _HELLO:
            self._router.send_multipart([ident, _HELLO + self._hello()])
        else:
            self._warn("node '%s': ignored a zmq message of unknown kind %r", self.name, kind)

    def _on_request(self, ident: bytes, data: bytes) -> None:
        """Answer a request (`_REQ`, its number, the record): taken, queue full, invalid, or no requests."""
        head = data[:1 + _SEQ.size]
        queue = self.request_queue
        if queue is None:
            status = _NO_REQUESTS
        elif len(head) < 1 + _SEQ.size:
            status = _INVALID + wire.pack([None, "malformed request message"])
        # The rpc thread is the queue's only producer: a queue with room now takes the record at once,
        # and a full one is answered at once (the client retries) instead of stalling this thread.
        elif len(queue) >= queue.capacity:
            status = _FULL + wire.pack([queue.capacity])
        else:
            body = memoryview(data)[1 + _SEQ.size:]
            try:
                layout = queue.layout
                rec = layout.decode_bytes(body)
                layout.check_record(rec)
            except InvalidRequest:
                try:
                    queue.put_bytes(body)  # raises the same error again, and counts the rejection
                except InvalidRequest as e:
                    log.debug("%s", e)
                    status = _INVALID + wire.pack([e.field, e.problem])
                else:  # cannot happen: the same checks passed this time
                    status = _TAKEN
            else:
                # Answer first, then enqueue (which wakes the node loop): the record is checked and the
                # queue has room, so it cannot fail, and the answer does not wait for the node's thread.
                self._router.send_multipart([ident, head + _TAKEN])
                queue.put_record(rec)
                return
        self._router.send_multipart([ident, head + status])

    def _queue_call(self, ident: bytes, data: bytes) -> None:
        with self._queued_lock:
            mine, total = self._queued.get(ident, 0), self._n_queued
            if mine < _CALLS_PER_PEER and total < _CALLS_QUEUED:
                self._queued[ident] = mine + 1
                self._n_queued = total + 1
                self._calls.put((ident, data, clock.now()))
                return
        self._warn("node '%s': refused an API call: too many calls queued (%d from that peer, %d in all)",
                   self.name, mine, total)
        reply = wire.pack_reply(_call_id(memoryview(data)[1:]), False,
                                ["TooManyCalls", f"too many calls queued (at most {_CALLS_PER_PEER} per client, "
                                 f"{_CALLS_QUEUED} in all): try again later", ""])
        self._router.send_multipart([ident, _CALL + reply])

    def _run_calls(self) -> None:
        """The API thread: runs queued calls one at a time (the Dispatcher serializes them with the
        node loop anyway), and hands each reply to the ROUTER thread."""
        out = self._replies_out
        while True:
            item = self._calls.get()
            if item is None or self._stop.is_set():
                return
            ident, data, t_queued = item
            try:
                if clock.now() - t_queued > self.config.call_timeout:
                    # its caller has given up (NodeTimeout): running it now would only delay the calls
                    # behind it, so a slow call cannot pile up work for clients that have gone
                    log.debug("node '%s': skipped a call that waited past call_timeout", self.name)
                    continue
                reply = self._call(memoryview(data)[1:])
            finally:
                with self._queued_lock:
                    self._n_queued -= 1
                    n = self._queued.pop(ident, 1) - 1
                    if n > 0:
                        self._queued[ident] = n
            try:
                out.send_multipart([ident, _CALL + reply], zmq.NOBLOCK)
            except zmq.ZMQError:  # the rpc thread is gone (closing) or far behind: the client times out
                log.debug("node '%s': dropped an API reply", self.name)

    def _call(self, payload: bytes | memoryview) -> bytes:
        try:
            call_id, method, args, kwargs = wire.unpack_call(payload)
        except Exception as e:  # cannot even tell which call: id -1 is never awaited
            return wire.pack_reply(-1, False, wire.remote_error_payload(e))
        try:
            return wire.pack_reply(call_id, True, self._dispatch(method, args, kwargs))
        except Exception as e:
            log.debug("node '%s': call '%s' raised", self.name, method, exc_info=True)
            return wire.pack_reply(call_id, False, wire.remote_error_payload(e))

    def close(self) -> None:
        if self._closed:
            return
        self._send_control(_BYE)  # remote clients learn at once instead of after the timeout
        with self._pub_lock:
            self._closed = True
        self._stop.set()
        self._calls.put(None)  # wakes the API thread (after the call it runs, if any)
        for t in self._threads:
            t.join(timeout=2.0)
        if any(t.is_alive() for t in self._threads):
            # A call still running in the node holds the API thread (and its socket); the process is
            # ending anyway, so leave the sockets, the ZAP handler and the context to it.
            log.warning("node '%s': an API call was still running at shutdown", self.name)
            return
        self._pub.close(linger=200)  # let the "bye" leave
        for s in (self._router, self._replies_in, self._replies_out):
            s.close(linger=0)
        if self._auth is not None:  # after the sockets: never a bound CURVE socket without its handler
            self._auth.stop()
            self._auth = None
        self._ctx.term()


# -- client ------------------------------------------------------------------------------------------
class ZmqClient(ClientTransport):
    def __init__(self, node: Node, layouts: NodeLayouts, address: dict[str, Any], config: ZmqConfig):
        self.name, self.layouts, self.config = node.name, layouts, config
        try:
            host, state_port, rpc_port = address["host"], int(address["state_port"]), int(address["rpc_port"])
        except (KeyError, TypeError, ValueError) as e:
            raise ConfigError(f"node '{self.name}': zmq address needs host, state_port, rpc_port; got {address}") from e
        self._where = f"{host}:{rpc_port}"
        curve = self._curve(address)  # before anything is started: a mismatch is a config error
        self._data_fp = layouts.data.fingerprint if layouts.data else 0
        self._watch = local_process_watch(address, self.name)
        self._beat_timeout = max(config.heartbeat_timeout, 5 * float(address.get("heartbeat_s", 0.05)))
        self._last_heard = clock.now()
        #: Why the server is known to be gone; sticky: a server that comes back is a new server
        #: (new sequence numbers, maybe a new layout), so the client must connect again.
        self._gone: str | None = None
        self._epoch: int | None = None
        self._last_seq = 0
        self._req_seq = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

        self.ring_buffer = RingBuffer(layouts.data, layouts.buffer_capacity) if layouts.data else None
        self._ctx = zmq.Context(io_threads=1)
        self._sub = self._socket(zmq.SUB, curve)
        self._sub.setsockopt(zmq.RCVHWM, _hwm(layouts.data.itemsize if layouts.data else 64))
        self._sub.setsockopt(zmq.SUBSCRIBE, b"")
        self._call_sock = self._socket(zmq.DEALER, curve)
        self._req_sock = self._socket(zmq.DEALER, curve)
        self._req_sock.setsockopt(zmq.SNDHWM, max(layouts.request_capacity, 2))
        self._call_lock, self._req_lock = threading.Lock(), threading.Lock()
        self._call_ids = itertools.count(1)  # next() is atomic under the GIL
        try:
            self._sub.connect(f"tcp://{host}:{state_port}")  # before the handshake: see module doc
            # Watch the call socket's handshake: a refused key is an error now, not a hang.
            monitor = self._call_sock.get_monitor_socket(_AUTH_EVENTS)
            try:
                self._call_sock.connect(f"tcp://{host}:{rpc_port}")
                self._req_sock.connect(f"tcp://{host}:{rpc_port}")
                self._handshake(monitor, curve is not None)
            finally:
                self._call_sock.disable_monitor()
                monitor.close(linger=0)
        except BaseException:
            self.close()
            raise
        self.request_queue = RequestSender(layouts.request, self._send_request) if layouts.request else None
        self._thread = threading.Thread(target=self._receive, name=f"rio-zmq-{self.name}-sub", daemon=True)
        self._thread.start()

    def _curve(self, address: dict[str, Any]) -> tuple[bytes, bytes, bytes] | None:
        """(server public key, our public key, our secret key) when the node authenticates, else None;
        ConfigError when this station and the node's server disagree on authentication."""
        keys = self.config.machine_keys()
        server = address.get("identity")
        if server is None and keys is None:
            return None
        if keys is None:
            raise ConfigError(
                f"node '{self.name}': its server (machine '{server}') requires authentication, and this "
                "station names no keys: set keys = \"<this machine's keys directory>\" in [middleware] "
                "(made by `rio keys generate`)")
        if server is None:
            raise ConfigError(
                f"node '{self.name}': its server at {self._where} runs without authentication but this "
                f"station names keys ({keys.dir}): refusing an unauthenticated link; start the node with the "
                "same station file (its [middleware] keys)")
        ours, secret = keys.curve_keypair()
        return keys.peer(str(server)), ours, secret  # the server's key from our own peers/, never the network

    def _socket(self, kind: int, curve: tuple[bytes, bytes, bytes] | None = None) -> zmq.Socket:
        s = self._ctx.socket(kind)
        s.setsockopt(zmq.LINGER, 0)
        # Queue only on live connections: a command must not wait in a buffer and be delivered to
        # a server that comes back later.
        if kind == zmq.DEALER:
            s.setsockopt(zmq.IMMEDIATE, 1)
        s.setsockopt(zmq.RCVTIMEO, _POLL_MS)
        if curve is not None:
            s.curve_serverkey, s.curve_publickey, s.curve_secretkey = curve
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
        """Send one request and wait for the server's answer; a full queue is retried for `_PUT_TIMEOUT`."""
        with self._req_lock:
            self.check_alive()
            full_since = None
            while True:
                self._req_seq = seq = (self._req_seq + 1) & 0xFFFFFFFF
                head = _REQ + _SEQ.pack(seq)
                status = self._request_once(head, data)
                if status == _TAKEN:
                    return
                kind = status[:1]
                try:
                    detail: Any = wire.unpack(status[1:]) if len(status) > 1 else [None, None]
                    if kind == _FULL:
                        capacity = int(detail[0])
                    elif kind == _INVALID:
                        field, problem = None if detail[0] is None else str(detail[0]), str(detail[1])
                except (ValueError, TypeError, IndexError):
                    kind = b"?"
                if kind == _FULL:
                    t = clock.now()
                    full_since = full_since or t
                    if t - full_since > _PUT_TIMEOUT:
                        raise QueueFull(self.name, capacity, _PUT_TIMEOUT)
                    time.sleep(0.001)
                    continue
                if kind == _INVALID:
                    raise InvalidRequest(self.name, field, problem)
                if kind == _NO_REQUESTS:
                    raise InvalidRequest(self.name, None, "its server takes no requests")
                raise NodeError(self.name, "ProtocolError", f"unreadable answer {status[:16]!r} to a request")

    def _request_once(self, head: bytes, data: bytes) -> bytes:
        """The server's answer (status byte, details) to one request."""
        sock = self._req_sock
        msg = head + data
        try:
            sock.send(msg, zmq.NOBLOCK)
        except zmq.Again:
            self._send(sock, msg, "sending a request", _REQUEST_TIMEOUT)
        deadline = None
        while True:
            try:
                answer = sock.recv()  # RCVTIMEO: at most _POLL_MS between liveness checks
            except zmq.Again:
                self.check_alive()
                t = clock.now()
                deadline = deadline or t + _REQUEST_TIMEOUT
                if t > deadline:
                    raise NodeTimeout(self.name, "a request (no answer from the server)", _REQUEST_TIMEOUT) from None
                continue
            if answer[:len(head)] == head:  # else: the late answer to a request that timed out
                return answer[len(head):]

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

    def _auth_failed(self, monitor: zmq.Socket, keyed: bool) -> None:
        """Raise ConfigError when the call socket's monitor reports a failed handshake (a refused key,
        a wrong server key, or one side with keys and the other without)."""
        from zmq.utils.monitor import recv_monitor_message

        try:
            event = recv_monitor_message(monitor, zmq.NOBLOCK)
        except zmq.Again:
            return
        ev = event["event"]
        if not keyed:
            why = ("the server requires authentication and this station names no keys: set keys = "
                   "\"<this machine's keys directory>\" in [middleware] (made by `rio keys generate`)")
        elif ev == zmq.EVENT_HANDSHAKE_FAILED_AUTH:
            why = ("the server refused this machine's key: the server's machine must hold this machine's "
                   "public key in its keys directory's peers/ (`rio keys add`, copy the directories, restart the node)")
        elif ev == zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL:
            why = "the server runs without keys (both sides must use the same station file's [middleware] keys)"
        else:
            why = ("the server did not accept the handshake: the server's public key in this machine's peers/ "
                   "is not the server's, or the server runs without keys")
        raise ConfigError(f"node '{self.name}': authentication with its server at {self._where} failed: {why}")

    def _handshake(self, monitor: zmq.Socket, curve: bool) -> None:
        timeout = self.config.call_timeout
        sock = self._call_sock
        poller = zmq.Poller()
        poller.register(sock, zmq.POLLIN)
        poller.register(monitor, zmq.POLLIN)
        deadline = clock.now() + timeout
        sent, hello = False, None
        while hello is None:
            if not sent:
                try:
                    sock.send(_HELLO, zmq.NOBLOCK)
                    sent = True
                except zmq.Again:  # not connected yet (IMMEDIATE): nothing is queued
                    pass
            ready = dict(poller.poll(5 if not sent else _POLL_MS))
            if monitor in ready:
                self._auth_failed(monitor, curve)
            if sock in ready:
                try:
                    msg = sock.recv(zmq.NOBLOCK)
                except zmq.Again:
                    msg = b""
                if msg[:1] == _HELLO:
                    hello = wire.unpack(memoryview(msg)[1:])
                    break
            try:
                self.check_alive()
            except NodeDiedError:
                if self._watch is not None:
                    raise
                raise NodeDiedError(self.name, f"no answer from {self._where} within {self._beat_timeout:.2g} s "
                                    "(not running, unreachable" + (", or authentication failing)" if curve else ")")
                                    ) from None
            if clock.now() > deadline:
                raise NodeTimeout(self.name, "connecting (handshake" + (
                    "; is authentication failing?)" if curve else ")"), timeout)
        if not isinstance(hello, dict) or hello.get("protocol") != _PROTOCOL:
            got = hello.get("protocol") if isinstance(hello, dict) else None
            raise ConfigError(f"node '{self.name}': its server at {self._where} speaks zmq protocol {got}, this "
                              f"client {_PROTOCOL}: run the same rio version on both machines")
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
        #: only with `keys` (CURVE: authenticated and encrypted) or `insecure = true`.
        host: str = "127.0.0.1"
        #: Ports of the PUB (state) and ROUTER (requests, calls) sockets; None picks a free port.
        state_port: int | None = Field(None, ge=1, le=65535)
        rpc_port: int | None = Field(None, ge=1, le=65535)
        #: Server heartbeat period, and how long a client on another machine waits without hearing
        #: anything (heartbeat or sample) before it reports the node dead.
        heartbeat_s: float = Field(0.05, gt=0, le=1.0)
        heartbeat_timeout: float = Field(0.5, gt=0)

    def placed(self, node: str, index: int, machine: str, section: MachineSection
               ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Two fixed ports per node from the machine's `port`; the identity is the machine's name, whose
        key a client takes from its own `peers/`."""
        state_port = section.port + 2 * index
        options = {"host": section.bind or section.address, "state_port": state_port, "rpc_port": state_port + 1}
        address = {"host": section.address, "state_port": state_port, "rpc_port": state_port + 1,
                   "heartbeat_s": self.config.heartbeat_s}
        if self.config.keys is not None:
            address["identity"] = machine
        return options, address

    def make_server(self, node: Node, layouts: NodeLayouts, resources: dict[str, Any]) -> ZmqServer:
        return ZmqServer(node, layouts, self.config)

    def make_client(self, node: Node, layouts: NodeLayouts, address: dict[str, Any]) -> ZmqClient:
        return ZmqClient(node, layouts, address, self.config)


ZmqConfig = ZmqMiddleware.Config
