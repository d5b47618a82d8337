"""ZeroMQ middleware: a node reachable over TCP, on one machine or across several. It carries RIO's
network protocol (`rio.middleware.protocol`) and authenticates; the protocol does the rest.

Server sockets (bound to loopback unless `host` says otherwise): a PUB (`state_port`) for the state
stream, two frames per message (the stream header, the record); a ROUTER (`rpc_port`) for everything a
client sends, one frame per message after the ROUTER's identity: the kind byte, then the body. One thread
owns the ROUTER (zmq sockets are not thread-safe) and runs no node code; answers from other threads (API
replies, acknowledgements of requests that waited) reach it through an inproc socket. A message larger than
the limit disconnects its sender before anything is allocated (MAXMSGSIZE); a flooding peer is throttled
by TCP once `_ROUTER_HWM` of its messages wait. A peer is a zmq identity.

What the node holds for its peers is bounded in total, not per peer only (50 peers sending messages under
the size cap took a node from 67 MB to 443 MB, and 1.5 GB after they left): libzmq keeps, per connection, the
message it is reading and `_ROUTER_HWM` read ones (each up to the message limit), so connections are admitted
by the protocol (`NetworkServer.admit`, `Admission`: `max_connections`, `max_connections_per_address`, a
stranger that never said HELLO gives way to a newcomer and is closed after `handshake_timeout_s`; an idle
client costs nothing here and is never closed for it). The ROUTER's monitor says when a connection is
accepted or ends (its file descriptor), each message which connection it came from (SRCFD); a connection is
closed by shutting its socket down, which libzmq then tears down itself. Messages are taken without a copy;
what waits for the node is bounded by the protocol's `max_pending_bytes`. Large buffers go back to the
system when freed (`rio.middleware.protocol.memory`), so a flood's memory is returned once it is over.

Authentication (`keys`, `rio.machine.keys`): both server sockets are CURVE servers with this machine's
key pair, and a ZAP handler admits only the clients whose public key is in this machine's `peers/`. The
address names the server machine's `identity`; a client takes that machine's public key from its *own*
`peers/` (never from the network) and fails with a ConfigError saying "authentication" when the two sides
disagree. Without keys: plain TCP, as `NetworkConfig` allows it (loopback, or `insecure = true`).

Client: a SUB socket, connected before the handshake (zmq's slow joiner: the handshake seeds the mirror),
drained by a thread; one DEALER for the handshake and calls and another for requests, so a request never
waits behind a slow call.
"""

from __future__ import annotations

import logging
import math
import os
import socket
import threading
import time
from typing import TYPE_CHECKING, Any, cast

import zmq
from pydantic import Field

from rio import clock
from rio.errors import ConfigError, NodeDiedError, NodeTimeout
from rio.middleware.protocol import NetworkClient, NetworkConfig, NetworkServer
from rio.middleware.protocol.client import POLL_S
from rio.middleware.protocol.memory import release_large_buffers
from rio.middleware.protocol.messages import ACK, HELLO, REQUEST
from rio.runtime.node import Node
from rio.runtime.transport import Middleware, NodeLayouts

if TYPE_CHECKING:
    from rio.station.model import MachineSection

log = logging.getLogger("rio.middleware.zmq")

#: Bytes of samples a PUB/SUB pipe may hold: a few camera frames, or ~1000 small samples. A slow
#: reader then gets recent samples instead of a growing backlog (the PUB drops beyond it).
_HWM_BYTES = 4 << 20
_POLL_MS = int(POLL_S * 1000)
#: Messages of one connection the ROUTER holds before TCP pushes back (with the one it is reading, at most
#: this + 1 message limits per connection).
_ROUTER_HWM = 2
#: Messages the ROUTER thread takes in a row before it forwards other threads' answers.
_BATCH = 64
#: Refused connections kept open for the client's HELLO, to tell it why (beyond: closed without a word) ...
_REFUSED_MAX = 16
#: ... for at most this long (s), and this long after the answer, so that it leaves before the close.
_REFUSAL_S = 1.0
_WILDCARD = ("0.0.0.0", "*", "", "::")
#: Handshake failures a client's monitor reports when the two sides' authentication disagree.
_AUTH_EVENTS = (zmq.EVENT_HANDSHAKE_FAILED_AUTH | zmq.EVENT_HANDSHAKE_FAILED_PROTOCOL
                | zmq.EVENT_HANDSHAKE_FAILED_NO_DETAIL)


def _hwm(msg_bytes: int) -> int:
    return max(2, min(1000, _HWM_BYTES // max(msg_bytes, 1)))


class ZmqServer(NetworkServer):
    mw = "zmq"
    config: ZmqConfig

    def __init__(self, node: Node, layouts: NodeLayouts, config: ZmqConfig):
        super().__init__(node, layouts, config)
        self._keys = config.machine_keys()
        self._ctx = zmq.Context(io_threads=1)
        self._auth: Any = None  # the ZAP handler (zmq.auth.thread.ThreadAuthenticator), started by _open()
        self._pub = self._socket(zmq.PUB, zmq.SNDHWM, _hwm(layouts.data.itemsize if layouts.data else 64))
        self._router = self._socket(zmq.ROUTER, zmq.RCVHWM, _ROUTER_HWM)
        self._router.setsockopt(zmq.MAXMSGSIZE, self.max_message_bytes)  # checked on the message's header
        if self._keys is not None:
            public, secret = self._keys.curve_keypair()
            for s in (self._pub, self._router):
                s.curve_secretkey, s.curve_publickey = secret, public
                s.curve_server = True
                # Fail closed: with a ZAP domain and ZAP_ENFORCE_DOMAIN, libzmq refuses every client while
                # no ZAP handler answers (without them a CURVE server admits any key). libzmq builds
                # without the option still have the handler.
                s.zap_domain = b"*"
                try:
                    s.setsockopt(zmq.ZAP_ENFORCE_DOMAIN, 1)
                except (AttributeError, zmq.ZMQError):
                    pass
        endpoint = f"inproc://rio-zmq-answers-{id(self):x}"
        self._answers_in = self._socket(zmq.PULL)
        self._answers_in.bind(endpoint)
        self._answers_out = self._socket(zmq.PUSH)
        self._answers_out.connect(endpoint)
        self._answers_lock = threading.Lock()  # the API and service threads share the PUSH
        self._rpc_thread: int | None = None
        self._monitor: zmq.Socket | None = None
        self._conns: dict[int, Any] = {}  # file descriptor -> the peer's (host, port), while connected
        self.admission.idle_s = math.inf  # an idle zmq connection holds nothing: only strangers are timed out
        self._fd_of: dict[Any, int] = {}  # identity -> the file descriptor of its connection
        self._refused: dict[int, tuple[str, float]] = {}  # fd of a refused connection -> (why, when to close it)

    def _socket(self, kind: int, option: int | None = None, value: int = 0) -> zmq.Socket:
        s = self._ctx.socket(kind)
        s.setsockopt(zmq.LINGER, 0)
        if option is not None:
            s.setsockopt(option, value)
        return s

    def _bind(self, sock: zmq.Socket, port: int | None, what: str) -> int:
        host = self.config.host
        try:
            sock.bind(f"tcp://{host}:{'*' if port is None else port}")
        except zmq.ZMQError as e:
            raise ConfigError(f"node '{self.name}': zmq cannot bind {what} to {host}:{port}: {e}") from e
        return int(sock.getsockopt_string(zmq.LAST_ENDPOINT).rsplit(":", 1)[1])

    def _open(self) -> dict[str, Any]:
        release_large_buffers()
        self._monitor = self._router.get_monitor_socket(zmq.EVENT_ACCEPTED | zmq.EVENT_DISCONNECTED)
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
        self._spawn(self._serve_rpc, "rpc")
        host = self.config.host
        address = {"host": "127.0.0.1" if host in _WILDCARD else host, "state_port": state_port,
                   "rpc_port": rpc_port, "hostname": socket.gethostname()}
        if self._keys is not None:
            address["identity"] = self._keys.identity
        return address

    def _broadcast(self, head: bytes, record: bytes | None) -> None:
        if record is None:
            self._pub.send(head)
        else:
            self._pub.send_multipart([head, record], copy=False)

    def _send(self, peer: Any, kind: bytes, body: bytes, tag: Any = None) -> None:
        try:
            if threading.get_ident() == self._rpc_thread:
                self._router.send_multipart([peer, kind + body], zmq.NOBLOCK)
                return
            with self._answers_lock:
                if not self.closed:
                    self._answers_out.send_multipart([peer, kind + body], zmq.NOBLOCK)
        except zmq.ZMQError:  # ROUTER_MANDATORY off: an answer for a peer that has gone (or reads nothing)
            log.debug("node '%s': dropped an answer to %r", self.name, peer)  # is dropped

    def _serve_rpc(self) -> None:
        """Owns the ROUTER: admits connections, hands every message to the protocol, forwards other threads'
        answers."""
        self._rpc_thread = threading.get_ident()
        router, answers, monitor = self._router, self._answers_in, self._monitor
        poller = zmq.Poller()
        poller.register(router, zmq.POLLIN)
        poller.register(answers, zmq.POLLIN)
        if monitor is not None:
            poller.register(monitor, zmq.POLLIN)
        while not self._stop.is_set():
            try:
                ready = dict(poller.poll(_POLL_MS))
            except zmq.ZMQError:  # the context is going away
                return
            if monitor is not None and monitor in ready:  # first: a connection is admitted before it is heard
                self._connections(monitor)
            while answers in ready:
                try:
                    self._router.send_multipart(answers.recv_multipart(zmq.NOBLOCK), zmq.NOBLOCK)
                except zmq.Again:
                    break
                except zmq.ZMQError:
                    pass
            for _ in range(_BATCH if router in ready else 0):
                try:
                    msg = router.recv_multipart(zmq.NOBLOCK, copy=False)  # no copy of a large message
                except zmq.Again:
                    break
                if len(msg) != 2:
                    self._warn("node '%s': ignored a zmq message of %d frames", self.name, len(msg))
                    continue
                peer, body = msg[0].bytes, msg[1].buffer
                try:
                    fd = msg[1].get(zmq.SRCFD)
                except zmq.ZMQError:  # a libzmq without the property: connections are not told apart
                    fd = None
                if fd is not None and fd in self._refused:
                    self._on_refused(fd, peer, bytes(body[:1]))
                    continue
                if fd is not None:
                    self._fd_of[peer] = fd
                self.heard(peer)
                try:
                    self.on_message(peer, bytes(body[:1]), body[1:])
                except Exception:  # never let one bad message end the thread
                    log.exception("node '%s': while handling a zmq message", self.name)
            if self._refused:
                self._close_refused()

    # -- connections (rio.middleware.protocol.admission) ---------------------------------------------
    def _connections(self, monitor: zmq.Socket) -> None:
        """The ROUTER's monitor: admit each accepted connection, forget each that ended."""
        from zmq.utils.monitor import recv_monitor_message

        while True:
            try:
                event = recv_monitor_message(monitor, zmq.NOBLOCK)
            except zmq.Again:
                return
            except zmq.ZMQError:  # the context is going away
                return
            fd = int(event["value"])
            if event["event"] == zmq.EVENT_ACCEPTED:
                where = _peer_of(fd)
                if where is None:  # gone already: its DISCONNECTED follows
                    continue
                self._conns[fd] = where
                why = self.admit(fd, where[0])
                if why is None:
                    continue
                if len(self._refused) < _REFUSED_MAX:  # its client hears why in the answer to its HELLO
                    self._refused[fd] = (why, clock.now() + self.admission.handshake_s)
                else:
                    self._disconnect(fd, "refused")
            elif event["event"] == zmq.EVENT_DISCONNECTED:
                self._conns.pop(fd, None)
                self._refused.pop(fd, None)
                self.admission.left(fd)
                for peer in [p for p, f in self._fd_of.items() if f == fd]:  # bounded by the connections open
                    del self._fd_of[peer]

    def _on_refused(self, fd: int, peer: bytes, kind: bytes) -> None:
        """A message on a refused connection: a HELLO is told why (TooManyConnections at its client), anything
        else is dropped; the connection is closed `_REFUSAL_S` later."""
        why, _ = self._refused[fd]
        if kind == HELLO:
            self._send(peer, HELLO, self.refusal(why))
        else:
            self._warn("node '%s': dropped a message on a refused connection from %s", self.name, self._conns.get(fd))
        self._refused[fd] = (why, min(self._refused[fd][1], clock.now() + _REFUSAL_S))

    def _close_refused(self) -> None:
        now = clock.now()
        for fd in [fd for fd, (_, t) in self._refused.items() if t <= now]:
            del self._refused[fd]
            self._disconnect(fd, "refused")

    def heard(self, peer: Any) -> None:
        fd = self._fd_of.get(peer)
        if fd is not None:
            self.admission.heard(fd)

    def vouch(self, peer: Any, new: bool = True) -> None:
        super().vouch(peer, new)
        fd = self._fd_of.get(peer)
        if fd is not None:
            self.admission.established(fd)

    def _disconnect(self, peer: Any, why: str) -> None:
        """Shut the connection's socket down (`peer`: its file descriptor)."""
        where = self._conns.get(peer)
        if where is not None:
            _peer_of(peer, shut_down_if=where)

    def _shut(self, busy: bool) -> None:
        if busy:  # a call still running may yet send through these sockets: the process ends them
            return
        self._pub.close(linger=200)  # let the "bye" leave
        if self._monitor is not None:
            self._router.disable_monitor()
            self._monitor.close(linger=0)
        for s in (self._router, self._answers_in, self._answers_out):
            s.close(linger=0)
        if self._auth is not None:  # after the sockets: never a bound CURVE socket without its handler
            self._auth.stop()
            self._auth = None
        self._ctx.term()


def _peer_of(fd: int, shut_down_if: tuple[str, int] | None = None) -> tuple[str, int] | None:
    """(host, port) of the peer of socket `fd` (a duplicate of it is asked), None when it is gone. With
    `shut_down_if`, the socket is shut down if its peer is still that one (the number may have been reused);
    libzmq owns the descriptor, sees the connection end and closes it itself."""
    try:
        with socket.socket(fileno=os.dup(fd)) as s:
            peer = s.getpeername()[:2]
            if shut_down_if is not None and peer == shut_down_if:
                s.shutdown(socket.SHUT_RDWR)
            return peer
    except OSError:
        return None


class ZmqClient(NetworkClient):
    mw = "zmq"
    config: ZmqConfig

    def __init__(self, node: Node, layouts: NodeLayouts, address: dict[str, Any], config: ZmqConfig):
        try:
            host, state_port, rpc_port = address["host"], int(address["state_port"]), int(address["rpc_port"])
        except (KeyError, TypeError, ValueError) as e:
            raise ConfigError(f"node '{node.name}': zmq address needs host, state_port, rpc_port; got {address}") from e
        super().__init__(node, layouts, address, config)
        self._where = f"{host}:{rpc_port}"
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._ctx = zmq.Context(io_threads=1)
        try:
            curve = self._curve(address)  # before connecting: a mismatch is a config error
            self._sub = self._socket(zmq.SUB, curve)
            self._sub.setsockopt(zmq.RCVHWM, _hwm(layouts.data.itemsize if layouts.data else 64))
            self._sub.setsockopt(zmq.SUBSCRIBE, b"")
            self._call_sock = self._socket(zmq.DEALER, curve)
            self._req_sock = self._socket(zmq.DEALER, curve)
            self._req_sock.setsockopt(zmq.SNDHWM, max(layouts.request_capacity, 2))
            self._sub.connect(f"tcp://{host}:{state_port}")  # before the handshake: see the module's doc
            # Watch the call socket's handshake: a refused key is an error now, not a hang.
            monitor = self._call_sock.get_monitor_socket(_AUTH_EVENTS)
            try:
                self._call_sock.connect(f"tcp://{host}:{rpc_port}")
                self._req_sock.connect(f"tcp://{host}:{rpc_port}")
                self._hello(monitor, curve is not None)
                self._send(HELLO, b"", self._req_sock)  # the request socket is a peer of its own: known too
            finally:
                self._call_sock.disable_monitor()
                monitor.close(linger=0)
        except BaseException:
            self.close()
            raise
        self._thread = threading.Thread(target=self._receive, name=f"rio-{self.name}-zmq-sub", daemon=True)
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

    def _socket(self, kind: int, curve: tuple[bytes, bytes, bytes] | None) -> zmq.Socket:
        s = self._ctx.socket(kind)
        s.setsockopt(zmq.LINGER, 0)
        if kind == zmq.DEALER:  # queue only on live connections: a command must not wait in a buffer
            s.setsockopt(zmq.IMMEDIATE, 1)  # and reach a server that comes back later
        s.setsockopt(zmq.RCVTIMEO, _POLL_MS)
        if curve is not None:
            s.curve_serverkey, s.curve_publickey, s.curve_secretkey = curve
        return s

    def _send(self, kind: bytes, body: bytes | memoryview, sock: zmq.Socket | None = None) -> None:
        self._send_parts(kind, body, sock=sock)

    def _send_parts(self, kind: bytes, *parts: bytes | memoryview, sock: zmq.Socket | None = None) -> None:
        """Non-blocking, retried while the connection is (re)establishing or the pipe is full, checking
        liveness: a dead server is an error, never a hang. The message is joined once and handed to libzmq
        without a copy of its own (`copy=False`: pyzmq still copies a message under its copy threshold,
        64 kB), so a request of megabytes (an observation with its camera frames) is copied once here, not
        three times (the id's prefix, the kind's, libzmq's)."""
        sock = sock or (self._req_sock if kind == REQUEST else self._call_sock)
        msg = b"".join((kind, *parts))
        deadline = None
        while True:
            try:
                sock.send(msg, zmq.NOBLOCK, copy=False)
                return
            except zmq.Again:
                pass
            self.check_alive()
            t = clock.now()
            deadline = deadline or t + self.config.call_timeout
            if t > deadline:
                raise NodeTimeout(self.name, "sending (the server takes nothing)", self.config.call_timeout)
            time.sleep(0.0005)

    def _recv(self, kind: bytes, wait_s: float = POLL_S) -> memoryview | None:
        """From the socket (its RCVTIMEO is the wait: `POLL_S`)."""
        sock, t_end = (self._req_sock if kind == ACK else self._call_sock), 0.0
        while True:
            try:
                msg = sock.recv()  # RCVTIMEO: at most a liveness poll
            except zmq.Again:
                return None
            if msg[:1] == kind:
                return memoryview(msg)[1:]
            t_end = t_end or clock.now() + POLL_S
            if clock.now() > t_end:  # only strays arrive (answers to a handshake of long ago)
                return None

    def _recv_now(self, kind: bytes) -> memoryview | None:
        """The next answer if one is there. Asked first (ZMQ_EVENTS): every `send_request` looks for
        acknowledgements, mostly finding none, and a `recv` that finds none raises (an exception built each
        time) after releasing the GIL, which another thread (the state stream's receiver) may then hold for
        a while; asking does neither."""
        sock = self._req_sock if kind == ACK else self._call_sock
        while cast(int, sock.getsockopt(zmq.EVENTS)) & zmq.POLLIN:
            try:
                msg = sock.recv(zmq.NOBLOCK)
            except zmq.Again:
                return None
            if msg[:1] == kind:  # else a stray (an answer to a handshake of long ago)
                return memoryview(msg)[1:]
        return None

    def _auth_failed(self, monitor: zmq.Socket, keyed: bool) -> None:
        """Raise ConfigError when the call socket's monitor reports a failed handshake (a refused key,
        a wrong server key, or one side with keys and the other without)."""
        from zmq.utils.monitor import recv_monitor_message

        try:
            ev = recv_monitor_message(monitor, zmq.NOBLOCK)["event"]
        except zmq.Again:
            return
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

    def _hello(self, monitor: zmq.Socket, curve: bool) -> None:
        timeout = self.config.connect_timeout
        sock = self._call_sock
        poller = zmq.Poller()
        poller.register(sock, zmq.POLLIN)
        poller.register(monitor, zmq.POLLIN)
        deadline = clock.now() + timeout
        sent = False
        while True:
            if not sent:
                try:
                    sock.send(HELLO, zmq.NOBLOCK)
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
                if msg[:1] == HELLO:
                    return self._handshake(memoryview(msg)[1:], self._where)
            try:
                self.check_alive()
            except NodeDiedError:
                if self._watch is not None:
                    raise
                raise NodeDiedError(self.name, f"no answer from {self._where} within {self._timeout:.2g} s "
                                    "(not running, unreachable" + (", or authentication failing)" if curve else ")")
                                    ) from None
            if clock.now() > deadline:
                raise NodeTimeout(self.name, "connecting (handshake" + (
                    "; is authentication failing?)" if curve else ")"), timeout)

    def _receive(self) -> None:
        """Owns the SUB socket: every message goes to the protocol's stream."""
        sub, on_stream = self._sub, self._on_stream
        while not self._stop.is_set():
            try:
                frames = sub.recv_multipart(copy=False)  # RCVTIMEO: look at the stop flag
            except zmq.Again:
                continue
            on_stream(frames[0].bytes, frames[1].buffer if len(frames) == 2 else None)

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        if not self._ctx.closed:
            self._ctx.destroy(linger=0)  # every socket it made, however far __init__ got
        super().close()


class ZmqMiddleware(Middleware):
    """pyzmq over TCP: PUB/SUB for the state stream (mirrored client-side), ROUTER/DEALER for the rest."""

    name = "zmq"

    class Config(NetworkConfig):
        #: Ports of the PUB (state) and ROUTER (requests, calls) sockets; None picks a free port.
        state_port: int | None = Field(None, ge=1, le=65535)
        rpc_port: int | None = Field(None, ge=1, le=65535)

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
