"""Portal's wire format (danijar's portal 3.8), restricted to what RIO sends: one `bytes` per message, and
`Link`, one connection of either end. Written from the format, not from portal's code.

- A connection starts with the client sending the 16 bytes ``portal_handshake``.
- Then every message, both ways, is a u64 length (little-endian, as every integer here) and a body.
- Request body: reqnum u64, method-name length u64, the name, then the arguments in portal's
  ``packlib`` form: buffer count u64, one u64 size per buffer, a msgpack tree (the argument tuple with
  leaves as None), msgpack leaf specs, the leaves. RIO's requests carry one argument, a `bytes` leaf:
  tree ``[None]``, specs ``[["bytes"]]``.
- Reply body: the request's reqnum u64, a status u64, then packlib of the result (status 0; RIO's
  results are one `bytes` leaf: tree ``None``) or a utf-8 error text (any other status).

Anything else a portal peer may send (str, None, numpy arrays, shared-memory arrays) is refused as
malformed: nothing here decodes a leaf, allocates by a peer's numbers before checking them, or touches
shared memory.
"""

from __future__ import annotations

import collections
import logging
import socket
import struct
import threading
from collections.abc import Callable

import msgpack

log = logging.getLogger("rio.middleware.portal")

HANDSHAKE = b"portal_handshake"
#: Smallest body either way: a reqnum and a second u64 (method-name length, or status).
MIN_BODY = 16
#: Reply statuses for errors (portal uses 1..4 for its own; any non-zero is an error to a client).
STATUS_MALFORMED, STATUS_UNKNOWN_METHOD, STATUS_REFUSED = 2, 3, 4

_ARGS_TREE = msgpack.packb([None])  # the argument tuple: one positional argument
_RESULT_TREE = msgpack.packb(None)  # the result: one leaf
_SPECS = msgpack.packb([["bytes"]])
_U64 = struct.Struct("<Q")
_HEAD = struct.Struct("<3Q")  # length, reqnum, name length / status
_SIZES = struct.Struct("<4Q")  # buffer count (3), tree, specs, leaf sizes
_MAX_METHOD = 64
_BACKLOG_BYTES = 1 << 20  # a link reads nothing more while this much of its answers is unsent


class FrameError(ValueError):
    """The byte stream breaks the framing (bad handshake or length): the connection cannot go on."""


class MessageError(ValueError):
    """A well-framed message that is not one `bytes` argument (or result); the stream is still in sync."""


def _packlib(tree: bytes, leaf: bytes | memoryview) -> list[bytes | memoryview]:
    return [_SIZES.pack(3, len(tree), len(_SPECS), len(leaf)), tree, _SPECS, leaf]


def request_frame(reqnum: int, method: bytes, arg: bytes | memoryview) -> bytes:
    """The whole message (length prefix included) calling `method(arg)`."""
    parts = [method, *_packlib(_ARGS_TREE, arg)]
    size = MIN_BODY + sum(len(p) for p in parts)
    return b"".join([_HEAD.pack(size, reqnum, len(method)), *parts])


def reply_frame(reqnum: int, *result: bytes | memoryview) -> bytes:
    """The whole answer returning the concatenation of `result` (one copy, here)."""
    n = sum(len(p) for p in result)
    head = [_SIZES.pack(3, len(_RESULT_TREE), len(_SPECS), n), _RESULT_TREE, _SPECS]
    return b"".join([_HEAD.pack(MIN_BODY + sum(len(p) for p in head) + n, reqnum, 0), *head, *result])


def error_frame(reqnum: int, status: int, text: str) -> bytes:
    data = text.encode()
    return _HEAD.pack(MIN_BODY + len(data), reqnum, status) + data


def read_handshake(recv_into: Callable[[memoryview], int]) -> None:
    got = bytes(_fill(recv_into, bytearray(len(HANDSHAKE))))
    if got != HANDSHAKE:
        raise FrameError(f"bad handshake {got!r}")


def read_frame(recv_into: Callable[[memoryview], int], max_bytes: int) -> bytearray:
    """The next message body. The length is checked before anything is allocated for the body, so a
    peer cannot make this side reserve more than `max_bytes`. Raises FrameError on a bad length,
    ConnectionError when the peer closes (`recv_into` returned 0)."""
    n = _U64.unpack(_fill(recv_into, bytearray(8)))[0]
    if not MIN_BODY <= n <= max_bytes:
        raise FrameError(f"message length {n} outside {MIN_BODY}..{max_bytes}")
    return _fill(recv_into, bytearray(n))


def _fill(recv_into: Callable[[memoryview], int], buf: bytearray) -> bytearray:
    view, pos = memoryview(buf), 0
    while pos < len(buf):
        k = recv_into(view[pos:])
        if k == 0:
            raise ConnectionError("connection closed by the peer")
        pos += k
    return buf


def _one_leaf(buf: memoryview, tree: bytes) -> memoryview:
    """The single `bytes` leaf of a packlib buffer whose tree must be `tree`; MessageError otherwise."""
    if len(buf) < _SIZES.size:
        raise MessageError("truncated arguments")
    count, t, s, n = _SIZES.unpack_from(buf)
    start = _SIZES.size + t + s
    if count != 3 or start + n != len(buf) or buf[_SIZES.size:_SIZES.size + t] != tree \
            or buf[_SIZES.size + t:start] != _SPECS:
        raise MessageError("only a single bytes value is accepted")
    return buf[start:]


def parse_request(body: bytearray) -> tuple[int, bytes, memoryview]:
    """(reqnum, method name, the argument) of a request body from `read_frame`. Raises MessageError
    (after which the reqnum, `reqnum_of(body)`, can still be answered)."""
    view = memoryview(body)
    name_len = _U64.unpack_from(body, 8)[0]
    if name_len > _MAX_METHOD or MIN_BODY + name_len > len(body):
        raise MessageError("malformed method name")
    method = bytes(view[MIN_BODY:MIN_BODY + name_len])
    return reqnum_of(body), method, _one_leaf(view[MIN_BODY + name_len:], _ARGS_TREE)


def reqnum_of(body: bytearray) -> int:
    return _U64.unpack_from(body)[0]


def parse_reply(body: bytearray) -> tuple[int, str | None, memoryview | None]:
    """(reqnum, error text or None, the result or None) of a reply body from `read_frame`."""
    reqnum, status = struct.unpack_from("<2Q", body)
    if status:
        return reqnum, bytes(body[MIN_BODY:]).decode("utf-8", "replace"), None
    try:
        return reqnum, None, _one_leaf(memoryview(body)[MIN_BODY:], _RESULT_TREE)
    except MessageError as e:
        return reqnum, f"malformed reply: {e}", None


class Link:
    """One portal connection, at either end; its owner reads frames in a thread of its own. A server's link
    sends through a writer thread, so a peer that stops reading holds up that thread only (never the node
    or another peer); a client's (`writer=False`) sends from the calling thread (one thread switch less per
    call, measured ~8 us). A send taking longer than the socket's timeout drops the connection."""

    def __init__(self, sock: socket.socket, peer: str, node: str, send_timeout: float,
                 heard: Callable[[], None] = lambda: None, writer: bool = True):
        self.sock, self.peer, self.node, self.heard = sock, peer, node, heard
        sock.settimeout(send_timeout)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)  # small answers leave at once
        self.closed = False
        self.polling = False  # (the server's: a long poll of this link is parked)
        self._out: collections.deque[bytes] = collections.deque()
        self._out_bytes = 0
        self._cv = threading.Condition()
        self._send_lock = threading.Lock()
        self.writer: threading.Thread | None = None
        if writer:  # started by `start()`: a server admits the connection first
            self.writer = threading.Thread(target=self._write_loop, name=f"rio-{node}-portal-send", daemon=True)
        self.reader: threading.Thread | None = None  # its owner's, that reads frames

    def start(self, reader: threading.Thread | None = None) -> None:
        """Start the writer thread (a server's link) and the owner's `reader`."""
        if self.writer is not None:
            self.writer.start()
        self.reader = reader
        if reader is not None:
            reader.start()

    def __repr__(self) -> str:
        return self.peer

    def recv_into(self, view: memoryview) -> int:
        while True:
            try:
                k = self.sock.recv_into(view)
            except TimeoutError:  # the socket timeout bounds sends; an idle peer is fine
                if self.closed:
                    raise ConnectionError("closed") from None
                continue
            self.heard()  # any bytes count: a large answer on a slow link is not silence
            return k

    def wait_for_room(self) -> None:
        """A server's back-pressure: read nothing more from a peer that does not take its answers (TCP then
        makes it wait). Never at a client: its own large sends would stop it reading the answers."""
        with self._cv:
            while self._out_bytes > _BACKLOG_BYTES and not self.closed:
                self._cv.wait()

    def send(self, frame: bytes) -> None:
        if self.writer is None:
            with self._send_lock:  # (not _cv: close() must not wait for a send to a peer that stopped reading)
                try:
                    if not self.closed:
                        self.sock.sendall(frame)
                except OSError as e:  # a partial frame: the connection is unusable (the reader then says so)
                    self.close(f"send failed ({type(e).__name__}: {e})")
            return
        with self._cv:
            if self.closed:  # the peer is gone: the frame is dropped
                return
            self._out.append(frame)
            self._out_bytes += len(frame)
            self._cv.notify_all()

    def _write_loop(self) -> None:
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
        """Drop the connection (once): unsent frames are discarded, the reader and the writer wake up."""
        with self._cv:
            if self.closed:
                return
            self.closed = True
            self._out.clear()
            self._cv.notify_all()
        log.log(level, "node '%s': closed the portal connection with %s: %s", self.node, self.peer, why)
        try:
            self.sock.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
