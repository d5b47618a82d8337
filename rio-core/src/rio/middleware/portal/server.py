"""The portal middleware's server: portal's wire format (`wire`) on our own threads, carrying RIO's network
protocol (`rio.middleware.protocol`: the protocol decides what to answer; this module moves the bytes).

Methods a client calls (each one `bytes` argument and result): `hello`, `req` (a raw record; its answer
`OK` or the protocol's acknowledgement), `call` (`wire.pack_call` -> `wire.pack_reply`), and `poll(seq)`,
the state stream for a request/reply transport: answered at once with the stream's messages newer than
`seq` (the newest that fit `max_batch_bytes`), else parked until the next sample or heartbeat (one parked
poll per connection). A peer is a connection: it has a reader thread (frames in) and a writer thread
(answers out), so a peer that stalls mid-frame or stops reading holds up only its own two threads.

Limits on what one peer can cost: a message is at most the node's message limit (checked on the length
prefix, before anything is allocated for the body); its reader stops reading (TCP then makes the peer wait)
while more than `_BACKLOG_BYTES` of its answers wait to be sent; a send that takes longer than
`_SEND_TIMEOUT_S` drops the peer; at most `_MAX_CONNECTIONS` connections; the protocol bounds its calls
and waiting requests. When a connection ends, its waiting calls and requests are dropped. A broken frame
(bad handshake or length) disconnects the peer, logged once with its address; a well-framed message we do
not accept (not one `bytes` argument, an unknown method) is answered with an error. Either way the node
keeps serving everyone else.
"""

from __future__ import annotations

import collections
import logging
import socket
import threading
import time
from typing import TYPE_CHECKING, Any

from rio.middleware.portal import wire as pw
from rio.middleware.protocol import NetworkServer
from rio.middleware.protocol.messages import CALL, HELLO, OK, STREAM_HEAD
from rio.runtime.node import Node
from rio.runtime.transport import NodeLayouts

if TYPE_CHECKING:
    from rio.middleware.portal import PortalConfig

log = logging.getLogger("rio.middleware.portal")

TAKEN = b"\x01"  # the answer to a request that entered the node's queue (what portal clients expect)
_SEND_TIMEOUT_S = 30.0  # a peer that takes longer than this to take one answer is dropped
_BACKLOG_BYTES = 1 << 20  # a connection's reader waits while this much of its answers is unsent
_MAX_CONNECTIONS = 32
_ACCEPT_WAKE_S = 0.2  # how often the accept thread looks at its stop flag


class _Conn:
    """One client connection: its socket, the answers waiting for its writer thread."""

    def __init__(self, sock: socket.socket, peer: Any, node: str):
        self.sock, self.peer, self.node = sock, f"{peer[0]}:{peer[1]}", node
        self.closed = False
        self.polling = False  # a long poll of this connection is parked
        self.refused = False  # a refused message was logged (once per connection)
        self._out: collections.deque[bytes] = collections.deque()
        self._out_bytes = 0
        self._cv = threading.Condition()

    def __repr__(self) -> str:
        return self.peer

    def recv_into(self, view: memoryview) -> int:
        while True:
            try:
                return self.sock.recv_into(view)
            except TimeoutError:  # the socket timeout bounds sends; an idle client is fine
                if self.closed:
                    raise ConnectionError("closed") from None

    def send(self, frame: bytes) -> None:
        with self._cv:
            if self.closed:  # the client is gone: the answer is dropped
                return
            self._out.append(frame)
            self._out_bytes += len(frame)
            self._cv.notify_all()

    def wait_for_room(self) -> None:
        """Back-pressure: read nothing more from a peer that does not take its answers."""
        with self._cv:
            while self._out_bytes > _BACKLOG_BYTES and not self.closed:
                self._cv.wait()

    def write_loop(self) -> None:
        while True:
            with self._cv:
                while not self._out and not self.closed:
                    self._cv.wait()
                if self.closed:
                    return
                frame = self._out.popleft()
            try:
                self.sock.sendall(frame)
            except OSError as e:
                self.close(f"send failed ({type(e).__name__}: {e})")
                return
            with self._cv:
                self._out_bytes -= len(frame)
                self._cv.notify_all()

    def close(self, why: str, level: int = logging.DEBUG) -> None:
        """Drop the peer (once): its unsent answers are discarded, both threads wake up and end."""
        with self._cv:
            if self.closed:
                return
            self.closed = True
            self._out.clear()
            self._cv.notify_all()
        log.log(level, "node '%s': closed the connection from %s: %s", self.node, self.peer, why)
        try:
            self.sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass


class PortalServer(NetworkServer):
    mw = "portal"

    def __init__(self, node: Node, layouts: NodeLayouts, config: PortalConfig):
        super().__init__(node, layouts, config)
        # The newest samples' stream messages (seq, header, record) for polls: the ring's slots get overwritten.
        self._recent: collections.deque[tuple[int, bytes, bytes]] = collections.deque(
            maxlen=max(layouts.buffer_capacity - 1, 1))
        self._cond = threading.Condition()  # guards _recent, _parked, _conns
        self._parked: list[tuple[_Conn, int, int]] = []  # long polls waiting: conn, reqnum, seq
        self._conns: set[_Conn] = set()
        self._listener: socket.socket | None = None

    # -- the protocol's transport --------------------------------------------------------------------
    def _open(self) -> dict[str, Any]:
        host = self.config.host
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self._listener = socket.create_server((host, self.config.port or 0), family=family, backlog=64)
        self._listener.settimeout(_ACCEPT_WAKE_S)
        self._spawn(self._accept_loop, "accept")
        shown = host if host not in ("0.0.0.0", "::", "") else socket.gethostname()
        return {"host": shown, "port": self._listener.getsockname()[1]}

    def _send(self, peer: Any, kind: bytes, body: bytes, tag: Any = None) -> None:
        peer.send(pw.reply_frame(tag, body))

    def _ack(self, peer: Any, rid: int, status: int, a: Any, b: Any, tag: Any) -> None:
        if status == OK:  # what a portal client expects: one byte
            self.vouch(peer)
            peer.send(pw.reply_frame(tag, TAKEN))
        else:
            super()._ack(peer, rid, status, a, b, tag)

    def _broadcast(self, head: bytes, record: bytes | None) -> None:
        with self._cond:
            if record is not None:
                self._recent.append((STREAM_HEAD.unpack(head)[3], head, record))
            due, self._parked = self._parked, []
            answers = [(conn, reqnum, self._batch(seq) or [head]) for conn, reqnum, seq in due]
        for conn, reqnum, parts in answers:
            conn.polling = False
            conn.send(pw.reply_frame(reqnum, *parts))

    def _batch(self, seq: int) -> list[bytes]:
        """The stream's messages after `seq`, the newest that fit `max_batch_bytes` (at least one), oldest
        first. Under _cond."""
        parts: list[bytes] = []
        size = 0
        for s, head, record in reversed(self._recent):
            if s <= seq or (parts and size + len(record) > self.config.max_batch_bytes):
                break
            parts += [record, head]
            size += len(record)
        return parts[::-1]

    def _shut(self, busy: bool) -> None:
        with self._cond:
            conns = list(self._conns)
        for conn in conns:
            conn.close("the node is stopping")
        if self._listener is not None:
            self._listener.close()

    # -- connections ----------------------------------------------------------------------------------
    def _accept_loop(self) -> None:
        assert self._listener is not None
        while not self._stop.is_set():
            try:
                sock, peer = self._listener.accept()
            except TimeoutError:
                continue
            except OSError as e:  # e.g. out of file descriptors: keep serving the connections we have
                if not self._stop.is_set():
                    log.warning("node '%s': accept failed: %s", self.name, e)
                time.sleep(_ACCEPT_WAKE_S)
                continue
            conn = _Conn(sock, peer, self.name)
            with self._cond:
                full = len(self._conns) >= _MAX_CONNECTIONS or self._stop.is_set()
                if not full:
                    self._conns.add(conn)
            if full:
                log.warning("node '%s': refused a connection from %s (%d connections open)",
                            self.name, conn.peer, _MAX_CONNECTIONS)
                sock.close()
                continue
            sock.settimeout(_SEND_TIMEOUT_S)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)  # small answers leave at once
            threading.Thread(target=self._serve, args=(conn,), name=f"rio-{self.name}-portal-conn",
                             daemon=True).start()

    def _serve(self, conn: _Conn) -> None:
        """The connection's reader: handshake, then frames until the peer leaves or breaks the framing."""
        writer = threading.Thread(target=conn.write_loop, name=f"rio-{self.name}-portal-send", daemon=True)
        writer.start()
        why, level = "the client left", logging.DEBUG
        try:
            pw.read_handshake(conn.recv_into)
            while not conn.closed:
                conn.wait_for_room()
                self._on_frame(conn, pw.read_frame(conn.recv_into, self.max_message_bytes))
        except pw.FrameError as e:
            why, level = str(e), logging.WARNING
        except OSError as e:  # ConnectionError, a send timeout, a reset
            why = f"{type(e).__name__}: {e}"
        except Exception as e:  # a bug here must not end the node: drop this peer, serve the others
            log.exception("node '%s': while serving %s", self.name, conn.peer)
            why, level = f"{type(e).__name__}: {e}", logging.ERROR
        finally:
            conn.close(why, level)
            self.peer_gone(conn)
            writer.join(1.0)
            conn.sock.close()
            with self._cond:
                self._conns.discard(conn)

    def _on_frame(self, conn: _Conn, body: bytearray) -> None:
        try:
            reqnum, method, arg = pw.parse_request(body)
        except pw.MessageError as e:
            return self._refuse(conn, pw.reqnum_of(body), pw.STATUS_MALFORMED, str(e))
        if method == b"call":
            self.on_message(conn, CALL, arg, reqnum)
        elif method == b"req":
            self.take_request(conn, reqnum, arg, reqnum)
        elif method == b"poll" and len(arg) == 8:
            self._poll(conn, reqnum, int.from_bytes(arg, "little"))
        elif method == b"hello":
            self.on_message(conn, HELLO, arg, reqnum)
        else:
            self._refuse(conn, reqnum, pw.STATUS_UNKNOWN_METHOD if method != b"poll" else pw.STATUS_MALFORMED,
                         f"unknown method {method!r}" if method != b"poll" else "poll takes a u64 sequence number")
        return None

    def _refuse(self, conn: _Conn, reqnum: int, status: int, why: str) -> None:
        if not conn.refused:
            conn.refused = True
            log.warning("node '%s': refused a message from %s: %s (not logged again for this connection)",
                        self.name, conn.peer, why)
        conn.send(pw.error_frame(reqnum, status, why))

    def _poll(self, conn: _Conn, reqnum: int, seq: int) -> None:
        """Answer at once if the stream has messages after `seq`, else park until it has."""
        with self._cond:
            parts = self._batch(seq)
            if not parts and not conn.polling:
                conn.polling = True
                self._parked.append((conn, reqnum, seq))
                return
        if parts:
            conn.send(pw.reply_frame(reqnum, *parts))
        else:
            self._refuse(conn, reqnum, pw.STATUS_REFUSED, "one long poll at a time")
