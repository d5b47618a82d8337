"""The portal middleware's server: portal's wire format (`portal_wire`), served by our own threads.

Threads, and why:
- one accept thread; per connection a reader thread (frames in) and a writer thread (answers out), so a
  peer that stalls mid-frame or stops reading holds up only its own two threads;
- one API thread (calls run one at a time, like the node lock makes them anyway), one request thread
  (records enter the RequestQueue in arrival order; a full queue makes it wait up to the queue's
  put timeout) and one poll thread that answers parked long polls. A slow call therefore never
  delays a poll or a request, of any client: heartbeats keep flowing.

Limits on what one peer can cost: a message is at most `max_message_bytes` (checked on the length
prefix, before anything is allocated for the body); a connection has at most
`max_pending_per_connection` calls, requests and long polls waiting (more are answered with an error
at once); its reader stops reading (TCP then makes the peer wait) while more than `max_message_bytes`
of its arguments wait for a worker or more than `_BACKLOG_BYTES` of its answers wait to be sent; a
send that takes longer than `_SEND_TIMEOUT_S` drops the peer; at most `_MAX_CONNECTIONS` connections.
Calls are not run for a client that has left, nor after waiting longer than `call_timeout` (their
caller has given up). A broken frame (bad handshake or length) disconnects the peer, logged once with
its address; a well-framed message we do not accept (not one `bytes` argument, an unknown method) is
answered with an error. Either way the node keeps serving everyone else.
"""

from __future__ import annotations

import collections
import logging
import queue
import socket
import struct
import threading
import time
from typing import TYPE_CHECKING, Any

from rio import clock
from rio.errors import InvalidRequest, QueueFull
from rio.middleware import portal_wire as pw
from rio.runtime import wire
from rio.runtime.buffers import RequestQueue, RingBuffer
from rio.runtime.node import Node
from rio.runtime.transport import NodeLayouts, ServerTransport, warn_if_exposed

if TYPE_CHECKING:
    from rio.middleware.portal import PortalConfig

log = logging.getLogger("rio.middleware.portal")

OK = b"\x01"  # the answer to a request that entered the node's queue
_POLL_WAIT_S = 0.08  # long-poll wait: one answer (the heartbeat) at least every ~100 ms
_SEND_TIMEOUT_S = 30.0  # a peer that takes longer than this to take one answer is dropped
_BACKLOG_BYTES = 1 << 20  # a connection's reader waits while this much of its answers is unsent
_MAX_CONNECTIONS = 32
_ACCEPT_WAKE_S = 0.2  # how often the accept thread looks at its stop flag


class _Conn:
    """One client connection: its socket, the answers waiting for its writer thread, its pending work."""

    def __init__(self, sock: socket.socket, peer: Any, node: str, max_pending_bytes: int):
        self.sock, self.peer, self.node = sock, f"{peer[0]}:{peer[1]}", node
        self.closed = False
        self.pending = 0  # calls, requests and parked polls not answered yet
        self._pending_bytes = 0  # the size of their arguments
        self._max_pending_bytes = max_pending_bytes
        self._out: collections.deque[bytes] = collections.deque()
        self._out_bytes = 0
        self._cv = threading.Condition()
        self.refused = False  # a refused message was logged (once per connection)

    def recv_into(self, view: memoryview) -> int:
        while True:
            try:
                return self.sock.recv_into(view)
            except TimeoutError:  # the socket timeout bounds sends; an idle client is fine
                if self.closed:
                    raise ConnectionError("closed") from None

    def admit(self, limit: int, size: int) -> bool:
        """Count one more pending message (its argument: `size` bytes), unless `limit` are pending already."""
        with self._cv:
            if self.pending >= limit:
                return False
            self.pending += 1
            self._pending_bytes += size
            return True

    def answer(self, frame: bytes | None, size: int = 0) -> None:
        """Answer an admitted message of `size` bytes (frame None: nothing to send, e.g. the client left)."""
        with self._cv:
            self.pending -= 1
            self._pending_bytes -= size
            self._cv.notify_all()
        if frame is not None:
            self.send(frame)

    def send(self, frame: bytes) -> None:
        with self._cv:
            if self.closed:  # the client is gone: the answer is dropped
                return
            self._out.append(frame)
            self._out_bytes += len(frame)
            self._cv.notify_all()

    def wait_for_room(self) -> None:
        """Back-pressure: read nothing more from a peer that does not take its answers, or whose pending
        work holds more than `max_pending_bytes` (TCP then makes the peer wait)."""
        with self._cv:
            while (self._out_bytes > _BACKLOG_BYTES or self._pending_bytes > self._max_pending_bytes) \
                    and not self.closed:
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


_Parked = tuple[_Conn, int, int, float]  # a long poll waiting for samples: conn, reqnum, since, deadline


class PortalServer(ServerTransport):
    def __init__(self, node: Node, layouts: NodeLayouts, config: PortalConfig):
        self.name, self.layouts, self.config = node.name, layouts, config
        self.ring_buffer = (RingBuffer(layouts.data, layouts.buffer_capacity, on_put=self._on_put)
                            if layouts.data is not None else None)
        self.request_queue = (RequestQueue(layouts.request, layouts.request_capacity)
                              if layouts.request is not None else None)
        self.max_message_bytes = config.message_limit(layouts)
        # Raw bytes of the newest samples, kept for the long polls (the ring's slots get overwritten).
        self._recent: collections.deque[bytes] = collections.deque(maxlen=max(layouts.buffer_capacity - 1, 1))
        self._count = 0
        self._cond = threading.Condition()  # guards _recent, _count, _parked, _closing
        self._parked: list[_Parked] = []
        self._closing = False
        self._conns: set[_Conn] = set()
        self._calls: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._requests: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._threads: list[threading.Thread] = []
        self._listener: socket.socket | None = None
        self._dispatch: Any = None

    # node side: called by the ring buffer in the node's writer thread
    def _on_put(self, rec: Any) -> None:
        data = rec.tobytes()
        with self._cond:
            self._recent.append(data)
            self._count += 1
            if self._parked:  # wake the poll thread only when a long poll waits for this
                self._cond.notify_all()

    # -- lifecycle --------------------------------------------------------------------------------------
    def start(self, dispatch: Any) -> dict[str, Any]:
        self._dispatch = dispatch
        warn_if_exposed(self.config, self.name, log)
        host = self.config.host
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self._listener = socket.create_server((host, self.config.port or 0), family=family, backlog=64)
        self._listener.settimeout(_ACCEPT_WAKE_S)
        for what, target, args in (("accept", self._accept_loop, ()), ("poll", self._poll_loop, ()),
                                   ("api", self._work, (self._calls, self._run_call)),
                                   ("req", self._work, (self._requests, self._run_request))):
            t = threading.Thread(target=target, args=args, name=f"rio-{self.name}-portal-{what}", daemon=True)
            t.start()
            self._threads.append(t)
        port = self._listener.getsockname()[1]
        shown = host if host not in ("0.0.0.0", "::", "") else socket.gethostname()
        return {"host": shown, "port": port}

    def close(self) -> None:
        with self._cond:
            if self._closing:
                return
            self._closing = True
            self._cond.notify_all()
        self._calls.put(None)
        self._requests.put(None)
        with self._cond:
            conns = list(self._conns)
        for conn in conns:
            conn.close("the node is stopping")
        deadline = clock.now() + 2.0
        for t in self._threads:
            t.join(max(deadline - clock.now(), 0.0))
        busy = [t.name for t in self._threads if t.is_alive()]
        if busy:  # an API call still running, or a request waiting for room in a full queue
            log.warning("node '%s': portal server threads still busy at close: %s", self.name, ", ".join(busy))
        if self._listener is not None:
            self._listener.close()

    # -- connections ----------------------------------------------------------------------------------
    def _accept_loop(self) -> None:
        assert self._listener is not None
        while not self._closing:
            try:
                sock, peer = self._listener.accept()
            except TimeoutError:
                continue
            except OSError as e:  # e.g. out of file descriptors: keep serving the connections we have
                log.warning("node '%s': accept failed: %s", self.name, e)
                time.sleep(_ACCEPT_WAKE_S)
                continue
            conn = _Conn(sock, peer, self.name, self.max_message_bytes)
            with self._cond:
                full = len(self._conns) >= _MAX_CONNECTIONS or self._closing
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
                self._on_message(conn, pw.read_frame(conn.recv_into, self.max_message_bytes))
        except pw.FrameError as e:
            why, level = str(e), logging.WARNING
        except OSError as e:  # ConnectionError, a send timeout, a reset
            why = f"{type(e).__name__}: {e}"
        except Exception as e:  # a bug here must not end the node: drop this peer, serve the others
            log.exception("node '%s': while serving %s", self.name, conn.peer)
            why, level = f"{type(e).__name__}: {e}", logging.ERROR
        finally:
            conn.close(why, level)
            writer.join(1.0)
            conn.sock.close()
            with self._cond:
                self._conns.discard(conn)

    def _on_message(self, conn: _Conn, body: bytearray) -> None:
        try:
            reqnum, method, arg = pw.parse_request(body)
        except pw.MessageError as e:
            self._refuse(conn, pw.reqnum_of(body), pw.STATUS_MALFORMED, str(e))
            return
        limit = self.config.max_pending_per_connection
        if method == b"hello":
            conn.send(pw.reply_frame(reqnum, self._hello()))
        elif method not in (b"poll", b"req", b"call"):
            self._refuse(conn, reqnum, pw.STATUS_UNKNOWN_METHOD, f"unknown method {method!r}")
        elif method == b"poll" and len(arg) != 8:
            self._refuse(conn, reqnum, pw.STATUS_MALFORMED, "poll takes a u64 sample count")
        elif not conn.admit(limit, len(arg) if method != b"poll" else 0):
            self._refuse(conn, reqnum, pw.STATUS_REFUSED,
                         f"node '{self.name}' is busy: {limit} messages of this connection are pending")
        elif method == b"poll":
            self._poll(conn, reqnum, int.from_bytes(arg, "little"))
        else:
            (self._requests if method == b"req" else self._calls).put((conn, reqnum, arg, clock.now()))

    def _refuse(self, conn: _Conn, reqnum: int, status: int, why: str) -> None:
        if not conn.refused:
            conn.refused = True
            log.warning("node '%s': refused a message from %s: %s (not logged again for this connection)",
                        self.name, conn.peer, why)
        conn.send(pw.error_frame(reqnum, status, why))

    # -- hello and long polls ---------------------------------------------------------------------------
    def _hello(self) -> bytes:
        with self._cond:
            newest = self._recent[-1] if self._recent else None
            count = self._count
        return wire.pack({"fingerprint": self.layouts.fingerprint(), "count": count, "newest": newest})

    def _poll(self, conn: _Conn, reqnum: int, since: int) -> None:
        """Answer at once if samples newer than count `since` exist, else park until some do or the
        wait runs out (the poll thread answers it then)."""
        with self._cond:
            if self._count <= since:
                self._parked.append((conn, reqnum, since, clock.now() + _POLL_WAIT_S))
                self._cond.notify_all()
                return
            picked = self._pick(since)
        conn.answer(pw.reply_frame(reqnum, self._batch(*picked)))

    def _pick(self, since: int) -> tuple[int, list[bytes]]:
        """(count, the samples after count `since`, newest first up to max_batch_bytes). Under _cond."""
        count = self._count
        new = min(max(count - since, 0), len(self._recent))
        picked: list[bytes] = []
        size = 0
        for data in reversed(self._recent):
            if len(picked) == new or (picked and size + len(data) > self.config.max_batch_bytes):
                break
            picked.append(data)
            size += len(data)
        return count, picked

    @staticmethod
    def _batch(count: int, picked: list[bytes]) -> bytes:
        """A poll answer: count u64, n u32, the records oldest first."""
        return b"".join([struct.pack("<QI", count, len(picked)), *reversed(picked)])

    def _poll_loop(self) -> None:
        while True:
            with self._cond:
                if self._closing:
                    return
                now = clock.now()
                due: list[_Parked] = []
                waiting: list[_Parked] = []
                for p in self._parked:
                    (due if p[2] < self._count or p[3] <= now else waiting).append(p)
                self._parked = waiting
                if not due:
                    self._cond.wait(min((p[3] for p in waiting), default=now + 1.0) - now)
                    continue
                answers = [(conn, reqnum, self._pick(since)) for conn, reqnum, since, _ in due]
            for conn, reqnum, picked in answers:
                conn.answer(pw.reply_frame(reqnum, self._batch(*picked)))

    # -- calls and requests -----------------------------------------------------------------------------
    def _work(self, jobs: queue.SimpleQueue[Any], run: Any) -> None:
        """One worker: jobs in arrival order; the work of a client that has left is not done for nobody."""
        while (job := jobs.get()) is not None:
            conn, reqnum, arg, t_in = job
            if conn.closed:
                conn.answer(None, len(arg))
                continue
            try:
                frame = run(reqnum, arg, t_in)
            except Exception as e:  # a bug here must not stop the worker
                log.exception("node '%s': while answering %s", self.name, conn.peer)
                frame = pw.error_frame(reqnum, pw.STATUS_REFUSED, f"server error: {type(e).__name__}")
            conn.answer(frame, len(arg))

    def _run_call(self, reqnum: int, arg: memoryview, t_in: float) -> bytes:
        waited = clock.now() - t_in
        if waited > self.config.call_timeout:  # its caller has given up (NodeTimeout): do not run it late
            return pw.error_frame(reqnum, pw.STATUS_REFUSED, f"not run: waited {waited:.3g} s behind other calls")
        try:
            call_id, method, args, kwargs = wire.unpack_call(arg)
        except ValueError as e:
            return pw.reply_frame(reqnum, wire.pack_reply(-1, False, wire.remote_error_payload(e)))
        try:
            return pw.reply_frame(reqnum, wire.pack_reply(call_id, True, self._dispatch(method, args, kwargs)))
        except BaseException as e:  # SystemExit from node code too: it must not end this thread
            # The client gets the message only: a traceback would show this machine's paths.
            log.info("node '%s': API call %s() raised", self.name, method, exc_info=True)
            return pw.reply_frame(reqnum, wire.pack_reply(call_id, False, wire.remote_error_payload(e)))

    def _run_request(self, reqnum: int, record: memoryview, t_in: float) -> bytes:
        """OK once the record is in the node's queue; else why not, as `wire.pack([kind, *fields])`."""
        rq = self.request_queue
        try:
            if rq is None:
                raise InvalidRequest(self.name, None, "this node takes no requests")
            rq.put_bytes(record)
            return pw.reply_frame(reqnum, OK)
        except InvalidRequest as e:
            log.warning("%s", e)
            return pw.reply_frame(reqnum, wire.pack(["InvalidRequest", e.field, e.problem]))
        except QueueFull as e:
            log.warning("%s", e)
            assert rq is not None
            return pw.reply_frame(reqnum, wire.pack(["QueueFull", rq.capacity, rq.put_timeout]))
