"""The portal middleware's server: portal's wire format (`wire`) on our own threads, carrying RIO's network
protocol (`rio.middleware.protocol` decides what to answer; this module moves the bytes).

Methods (each one `bytes` argument and result): `hello`, `req` (a raw record; answered `TAKEN` or with the
protocol's acknowledgement), `call` (`wire.pack_call` -> `wire.pack_reply`), and `poll(seq)`, the state
stream for a request/reply transport: answered at once with the stream's messages after `seq` (the newest
that fit `max_batch_bytes`), else parked until the next sample or heartbeat (one per connection).

A peer is a connection (`wire.Link`): its own reader and writer threads, so a peer that stalls mid-frame or
stops reading holds up only those. A message is at most the node's message limit, checked on the length
prefix before anything is allocated; a broken frame (bad handshake or length) disconnects the peer, logged
with its address; a well-framed message we do not accept (not one `bytes` argument, an unknown method) is
answered with an error. Connections are admitted by the protocol (`NetworkServer.admit`: per-address and
total limits, handshake and idle timeouts, strangers giving way to newcomers); a refused one is told why in an
error frame (request number 0: "too many connections ..."), which the client reports as such. When a
connection ends, its waiting calls and requests go too.
"""

from __future__ import annotations

import collections
import logging
import socket
import threading
import time
from typing import TYPE_CHECKING, Any

import rio.middleware.portal.wire as pw
from rio.middleware.protocol import NetworkServer
from rio.middleware.protocol.memory import release_large_buffers
from rio.middleware.protocol.messages import CALL, HELLO, OK, STREAM_HEAD
from rio.runtime.node import Node
from rio.runtime.transport import NodeLayouts

if TYPE_CHECKING:
    from rio.middleware.portal import PortalConfig

log = logging.getLogger("rio.middleware.portal")

TAKEN = b"\x01"  # the answer to a request that entered the node's queue (what portal clients expect)
_SEND_TIMEOUT_S = 30.0  # a peer that takes longer than this to take one answer is dropped
_ACCEPT_WAKE_S = 0.2  # how often the accept thread looks at its stop flag
#: A refused connection is told why, then given this long to read it before it is closed ...
_REFUSAL_S = 1.0
#: ... by one of at most this many threads (beyond, a refused connection is closed without a word).
_REFUSERS = 8


class PortalServer(NetworkServer):
    mw = "portal"
    config: PortalConfig

    def __init__(self, node: Node, layouts: NodeLayouts, config: PortalConfig):
        super().__init__(node, layouts, config)
        # The newest samples' stream messages (seq, header, record) for polls: the ring's slots get overwritten.
        self._recent: collections.deque[tuple[int, bytes, bytes]] = collections.deque(
            maxlen=max(layouts.buffer_capacity - 1, 1))
        self._lock = threading.Lock()  # guards _recent, _parked, _links
        self._parked: list[tuple[pw.Link, int, int]] = []  # long polls waiting: link, reqnum, seq
        self._links: set[pw.Link] = set()
        self._listener: socket.socket | None = None
        self._refusers = threading.BoundedSemaphore(_REFUSERS)

    def _open(self) -> dict[str, Any]:
        release_large_buffers()
        host = self.config.host
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self._listener = socket.create_server((host, self.config.port or 0), family=family, backlog=64)
        self._listener.settimeout(_ACCEPT_WAKE_S)
        self._spawn(self._accept_loop, "accept")
        shown = host if host not in ("0.0.0.0", "::", "") else socket.gethostname()
        return {"host": shown, "port": self._listener.getsockname()[1]}

    def _send(self, peer: Any, kind: bytes, body: bytes, tag: Any = None) -> None:
        peer.send(pw.reply_frame(tag, body))

    def _disconnect(self, peer: Any, why: str) -> None:
        peer.close(why, logging.INFO)

    def _ack(self, peer: Any, rid: int, status: int, a: Any, b: Any, tag: Any) -> None:
        if status == OK:  # what a portal client expects: one byte
            self.vouch(peer, new=False)
            peer.send(pw.reply_frame(tag, TAKEN))
        else:
            super()._ack(peer, rid, status, a, b, tag)

    def _broadcast(self, head: bytes, record: bytes | None) -> None:
        with self._lock:
            if record is not None:
                self._recent.append((STREAM_HEAD.unpack(head)[3], head, record))
            due, self._parked = self._parked, []
            answers = [(link, reqnum, self._batch(seq) or [head]) for link, reqnum, seq in due]
        for link, reqnum, parts in answers:
            link.polling = False
            link.send(pw.reply_frame(reqnum, *parts))

    def _batch(self, seq: int) -> list[bytes]:
        """The stream's messages after `seq`, the newest that fit `max_batch_bytes` (at least one), oldest
        first. Under _lock."""
        parts: list[bytes] = []
        size = 0
        for s, head, record in reversed(self._recent):
            if s <= seq or (parts and size + len(record) > self.config.max_batch_bytes):
                break
            parts += [record, head]
            size += len(record)
        return parts[::-1]

    def _shut(self, busy: bool) -> None:
        with self._lock:
            links = list(self._links)
        for link in links:
            link.close("the node is stopping")
        for link in links:
            if link.reader is not None:
                link.reader.join(2.0)  # (it joins its writer)
        if self._listener is not None:
            self._listener.close()

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
            if self._stop.is_set():
                sock.close()
                continue
            link = pw.Link(sock, f"{peer[0]}:{peer[1]}", self.name, _SEND_TIMEOUT_S)  # no thread runs yet
            refused = self.admit(link, str(peer[0]))
            if refused is not None:
                self._refuse_connection(sock, refused)
                continue
            with self._lock:
                self._links.add(link)
            link.start(threading.Thread(target=self._serve, args=(link,), name=f"rio-{self.name}-portal-conn",
                                        daemon=True))

    def _refuse_connection(self, sock: socket.socket, why: str) -> None:
        """Tell a refused connection why (an error frame, request number 0), let it read that, close it."""
        if not self._refusers.acquire(blocking=False):  # a flood of connections: no word for each
            sock.close()
            return

        def refuse() -> None:
            try:
                sock.settimeout(_REFUSAL_S)
                sock.sendall(pw.error_frame(0, pw.STATUS_REFUSED, why))
                sock.shutdown(socket.SHUT_WR)
                deadline = time.monotonic() + _REFUSAL_S
                while time.monotonic() < deadline and sock.recv(1 << 16):  # until it has read and closed
                    pass
            except OSError:
                pass
            finally:
                sock.close()
                self._refusers.release()

        threading.Thread(target=refuse, name=f"rio-{self.name}-portal-refuse", daemon=True).start()

    def _serve(self, link: pw.Link) -> None:
        """The connection's reader: handshake, then frames until the peer leaves or breaks the framing."""
        why, level = "the client left", logging.DEBUG
        try:
            pw.read_handshake(link.recv_into)
            while not link.closed:
                link.wait_for_room()
                self._on_frame(link, pw.read_frame(link.recv_into, self.max_message_bytes))
        except pw.FrameError as e:
            why, level = str(e), logging.WARNING
        except OSError as e:  # ConnectionError, a send timeout, a reset
            why = f"{type(e).__name__}: {e}"
        except Exception as e:  # a bug here must not end the node: drop this peer, serve the others
            log.exception("node '%s': while serving %s", self.name, link)
            why, level = f"{type(e).__name__}: {e}", logging.ERROR
        finally:
            link.close(why, level)
            self.peer_gone(link)
            if link.writer is not None:
                link.writer.join(1.0)
            link.sock.close()
            with self._lock:
                self._links.discard(link)

    def _on_frame(self, link: pw.Link, body: bytearray) -> None:
        self.heard(link)
        try:
            reqnum, method, arg = pw.parse_request(body)
        except pw.MessageError as e:
            return self._refuse(link, pw.reqnum_of(body), pw.STATUS_MALFORMED, str(e))
        if method == b"call":
            self.on_message(link, CALL, arg, reqnum)
        elif method == b"req":
            self.take_request(link, reqnum, arg, reqnum)
        elif method == b"poll":
            if len(arg) != 8:
                return self._refuse(link, reqnum, pw.STATUS_MALFORMED, "poll takes a u64 sequence number")
            self._poll(link, reqnum, int.from_bytes(arg, "little"))
        elif method == b"hello":
            self.on_message(link, HELLO, arg, reqnum)
        else:
            self._refuse(link, reqnum, pw.STATUS_UNKNOWN_METHOD, f"unknown method {method!r}")
        return None

    def _refuse(self, link: pw.Link, reqnum: int, status: int, why: str) -> None:
        self._warn("node '%s': refused a message from %s: %s", self.name, link, why)
        link.send(pw.error_frame(reqnum, status, why))

    def _poll(self, link: pw.Link, reqnum: int, seq: int) -> None:
        """Answer at once if the stream has messages after `seq`, else park until it has."""
        with self._lock:
            parts = self._batch(seq)
            if not parts and not link.polling:
                link.polling = True
                self._parked.append((link, reqnum, seq))
                return
        if parts:
            link.send(pw.reply_frame(reqnum, *parts))
        else:
            self._refuse(link, reqnum, pw.STATUS_REFUSED, "one long poll at a time")
