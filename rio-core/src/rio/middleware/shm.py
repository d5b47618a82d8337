"""Shared-memory middleware: a process per node, state and requests in POSIX shared memory.

- State: the node's ring buffer *is* a shared-memory segment; clients read it in place (no copy on
  the wire, no serializer, no pickling). `get(copy=False)` is a true zero-copy read.
- Requests: a bounded queue in a second segment. Producers (any client, any process) serialize on
  `flock` of their own descriptor of that segment — a lock the kernel releases if its holder dies,
  unlike a semaphore — and wake the node through a FIFO when it sleeps waiting for requests.
- API calls: a Unix stream socket in the manager's run directory, length-prefixed rio.wire frames.
- Segments and files are created and removed by the ServerManager (`prepare`/`release`), never by
  the node process, so a SIGKILLed node leaves nothing in /dev/shm.
"""

from __future__ import annotations

import _posixshmem
import fcntl
import logging
import mmap
import os
import select
import socket
import struct
import threading
import uuid
from collections.abc import Callable
from typing import Any

from .. import time as rtime
from .. import wire
from ..buffers import RequestQueue, RingBuffer
from ..errors import ConfigError, NodeDiedError, NodeError, NodeTimeout
from ..node import Node
from .base import ClientTransport, Middleware, NodeLayouts, ProcessWatch, ServerTransport

log = logging.getLogger("rio.middleware.shm")

_LEN = 4  # bytes of the frame length prefix
_POLL_S = 0.05  # how often a waiting call re-checks that the server lives


# -- shared memory ----------------------------------------------------------------------------------
def _create_segment(name: str, size: int) -> None:
    fd = _posixshmem.shm_open("/" + name, os.O_CREAT | os.O_EXCL | os.O_RDWR, mode=0o600)
    try:
        os.ftruncate(fd, size)
    finally:
        os.close(fd)


def _unlink_segment(name: str) -> None:
    try:
        _posixshmem.shm_unlink("/" + name)
    except FileNotFoundError:
        pass


class _Segment:
    """A mapping of an existing segment; keeps its own descriptor (used for flock)."""

    def __init__(self, name: str, size: int):
        self.fd = _posixshmem.shm_open("/" + name, os.O_RDWR, mode=0o600)
        if os.fstat(self.fd).st_size < size:
            os.close(self.fd)
            raise ConfigError(f"shared-memory segment '{name}' is smaller than the node's layout needs")
        self.mm = mmap.mmap(self.fd, size)

    def close(self) -> None:
        os.close(self.fd)  # the mapping goes with the last numpy view (closing it here would raise)


class _FlockLock:
    """Cross-process producer lock: flock on a private descriptor, plus a thread lock because
    threads sharing one descriptor do not exclude each other under flock."""

    def __init__(self, fd: int):
        self.fd = fd
        self._tlock = threading.Lock()

    def __enter__(self) -> None:
        self._tlock.acquire()
        fcntl.flock(self.fd, fcntl.LOCK_EX)

    def __exit__(self, *exc: Any) -> None:
        fcntl.flock(self.fd, fcntl.LOCK_UN)
        self._tlock.release()


class _FifoNotifier:
    """Cross-process wake-up on a named pipe (opened read-write so it never blocks or sees EOF)."""

    def __init__(self, path: str):
        self.fd = os.open(path, os.O_RDWR | os.O_NONBLOCK)

    def notify(self) -> None:
        try:
            os.write(self.fd, b"\x01")
        except BlockingIOError:  # pipe full: the consumer has plenty of wake-ups pending
            pass

    def clear(self) -> None:
        try:
            while os.read(self.fd, 4096):
                pass
        except BlockingIOError:
            pass

    def wait(self, timeout: float) -> bool:
        r, _, _ = select.select([self.fd], [], [], timeout)
        if r:
            self.clear()
        return bool(r)

    def close(self) -> None:
        os.close(self.fd)


def _attach(layouts: NodeLayouts, res: dict[str, Any]) -> tuple[list[_Segment], RingBuffer | None,
                                                                 RequestQueue | None, _FifoNotifier | None]:
    """Map a node's segments and lay its ring buffer and request queue over them (server and
    clients alike: both see the same memory)."""
    segments: list[_Segment] = []
    ring = queue = notifier = None
    if layouts.data is not None:
        seg = _Segment(res["data"], res["data_size"])
        segments.append(seg)
        ring = RingBuffer(layouts.data, layouts.buffer_capacity, buf=seg.mm)
    if layouts.request is not None:
        seg = _Segment(res["req"], res["req_size"])
        segments.append(seg)
        notifier = _FifoNotifier(res["fifo"])
        queue = RequestQueue(layouts.request, layouts.request_capacity, buf=seg.mm,
                             lock=_FlockLock(seg.fd), notifier=notifier)
    return segments, ring, queue, notifier


# -- framing on the API socket ----------------------------------------------------------------------
def _send_frame(sock: socket.socket, payload: bytes) -> None:
    sock.sendall(len(payload).to_bytes(_LEN, "little") + payload)


def _no_idle() -> None:
    pass


#: A reply usually arrives within tens of microseconds: poll for it this long before sleeping in the
#: kernel, because a wake-up from a blocked recv costs ~10-30 us on this class of machine.
SPIN_S = float(os.environ.get("RIO_SHM_SPIN_US", "50")) * 1e-6
#: The node's API thread polls as long for the next call after answering one (back-to-back calls).
SERVER_SPIN_S = float(os.environ.get("RIO_SHM_SERVER_SPIN_US", "50")) * 1e-6


def _recv(sock: socket.socket, n: int, on_idle: Callable[[], None], spin_s: float = 0.0) -> bytes:
    """recv() that first polls for `spin_s` (yielding the CPU between tries), then blocks, calling
    `on_idle()` each time the kernel receive timeout (SO_RCVTIMEO) expires."""
    if spin_s > 0:
        t_end = rtime.now() + spin_s
        while True:
            try:
                return sock.recv(n, socket.MSG_DONTWAIT)
            except BlockingIOError:
                if rtime.now() > t_end:
                    break
                os.sched_yield()
    while True:
        try:
            return sock.recv(n)
        except BlockingIOError:
            on_idle()


def _recv_frame(sock: socket.socket, on_idle: Callable[[], None] = _no_idle, spin_s: float = 0.0) -> bytes | None:
    """One frame, or None on EOF. Usually a single recv() for small frames."""
    buf = _recv(sock, 65536, on_idle, spin_s)
    if not buf:
        return None
    while len(buf) < _LEN:
        more = _recv(sock, 65536, on_idle)
        if not more:
            return None
        buf += more
    n = int.from_bytes(buf[:_LEN], "little")
    if len(buf) - _LEN >= n:
        return buf[_LEN:_LEN + n]
    body = bytearray(buf[_LEN:])
    while len(body) < n:
        more = _recv(sock, max(n - len(body), 65536), on_idle)
        if not more:
            return None
        body += more
    return bytes(body)


def _set_recv_timeout(sock: socket.socket, seconds: float) -> None:
    """Kernel-side receive timeout. Python's own settimeout() polls before every recv, which cost
    ~35 us per round trip here; a blocking recv with SO_RCVTIMEO costs nothing extra."""
    sec = int(seconds)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVTIMEO, struct.pack("ll", sec, int((seconds - sec) * 1e6)))


# -- server -----------------------------------------------------------------------------------------
class ShmServer(ServerTransport):
    def __init__(self, node: Node, layouts: NodeLayouts, res: dict[str, Any]):
        self.name, self.res = node.name, res
        self._segments, self.ring_buffer, self.request_queue, self._notifier = _attach(layouts, res)
        self._listener: socket.socket | None = None
        self._closing = False

    def start(self, dispatch: Any) -> dict[str, Any]:
        self._dispatch = dispatch
        self._listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self._listener.bind(self.res["sock"])
        self._listener.listen(16)
        threading.Thread(target=self._accept_loop, name=f"rio-{self.name}-api", daemon=True).start()
        return dict(self.res)

    def _accept_loop(self) -> None:
        while not self._closing:
            try:
                conn, _ = self._listener.accept()
            except OSError:
                return
            threading.Thread(target=self._serve_conn, args=(conn,), name=f"rio-{self.name}-conn", daemon=True).start()

    def _serve_conn(self, conn: socket.socket) -> None:
        """One thread per client connection, blocked in recv: one wake-up per call."""
        with conn:
            while True:
                try:
                    frame = _recv_frame(conn, spin_s=SERVER_SPIN_S)
                except OSError:
                    return
                if frame is None:
                    return
                try:
                    cid, method, args, kwargs = wire.unpack_call(frame)
                except Exception as e:  # a malformed frame is the client's bug: answer, keep serving
                    reply = wire.pack_reply(-1, False, wire.error_payload(e))
                else:
                    try:
                        reply = wire.pack_reply(cid, True, self._dispatch(method, args, kwargs))
                    except Exception as e:
                        reply = wire.pack_reply(cid, False, wire.error_payload(e))
                try:
                    _send_frame(conn, reply)
                except OSError:
                    return

    def close(self) -> None:
        self._closing = True
        if self._listener is not None:
            try:
                self._listener.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            self._listener.close()
        if self._notifier is not None:
            self._notifier.close()
        for seg in self._segments:
            seg.close()


# -- client -----------------------------------------------------------------------------------------
class ShmClient(ClientTransport):
    def __init__(self, node: Node, layouts: NodeLayouts, addr: dict[str, Any], call_timeout: float):
        self.name, self.call_timeout = node.name, call_timeout
        if addr.get("fingerprint") != layouts.fingerprint():
            raise ConfigError(f"node '{node.name}': the server's sample/request layout differs from this "
                              "client's (same node class and config on both sides?)")
        self._watch = ProcessWatch(int(addr["pid"]), node.name)
        self._segments, self.ring_buffer, self.request_queue, self._notifier = _attach(layouts, addr)
        self._sock_path = addr["sock"]
        self._sock: socket.socket | None = None
        self._lock = threading.Lock()
        self._call_id = 0

    def check_alive(self) -> None:
        self._watch.check()

    def _died(self, detail: str) -> NodeDiedError:
        if self._watch.dead():
            return NodeDiedError(self.name, f"server process {self._watch.pid} exited")
        return NodeDiedError(self.name, detail)

    def _connect(self) -> socket.socket:
        if self._sock is None:
            s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            try:
                s.connect(self._sock_path)
            except OSError as e:
                s.close()
                raise self._died(f"API socket unreachable: {e}") from None
            _set_recv_timeout(s, _POLL_S)
            self._sock = s
        return self._sock

    def call(self, method: str, args: tuple, kwargs: dict) -> Any:
        with self._lock:
            self._watch.check()
            sock = self._connect()
            self._call_id += 1
            deadline = rtime.now() + self.call_timeout

            def on_idle() -> None:
                if self._watch.dead():
                    self._drop_socket()
                    raise NodeDiedError(self.name, f"server process {self._watch.pid} exited during '{method}'")
                if rtime.now() > deadline:
                    self._drop_socket()  # a late reply must not be read as the next call's
                    raise NodeTimeout(self.name, f"call '{method}'", self.call_timeout)

            try:
                _send_frame(sock, wire.pack_call(self._call_id, method, args, kwargs))
                frame = _recv_frame(sock, on_idle, SPIN_S)
            except (BrokenPipeError, ConnectionResetError):
                frame = None
            if frame is None:
                self._drop_socket()
                raise self._died(f"connection closed during '{method}'")
            _, ok, value = wire.unpack_reply(frame)
            if not ok:
                raise NodeError(self.name, *value)
            return value

    def _drop_socket(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None

    def close(self) -> None:
        self._drop_socket()
        if self._notifier is not None:
            self._notifier.close()
        for seg in self._segments:
            seg.close()
        self._watch.close()


class ShmMiddleware(Middleware):
    name = "shm"

    def prepare(self, layouts: NodeLayouts, run_dir: str) -> dict[str, Any]:
        # The run directory is named rio-<run id>-*: carrying the run id in segment names lets a
        # person (or a test) tell which manager a /dev/shm entry belongs to.
        run_id = os.path.basename(run_dir).split("-")[1] if os.path.basename(run_dir).startswith("rio-") else "x"
        token = f"{run_id}_{uuid.uuid4().hex[:8]}"
        res: dict[str, Any] = {"fingerprint": layouts.fingerprint()}
        try:
            if layouts.data is not None:
                res["data"] = f"rio_{token}_d"
                res["data_size"] = RingBuffer.nbytes(layouts.data, layouts.buffer_capacity)
                _create_segment(res["data"], res["data_size"])
            if layouts.request is not None:
                res["req"] = f"rio_{token}_r"
                res["req_size"] = RequestQueue.nbytes(layouts.request, layouts.request_capacity)
                _create_segment(res["req"], res["req_size"])
                res["fifo"] = os.path.join(run_dir, f"{token}.fifo")
                os.mkfifo(res["fifo"], 0o600)
            res["sock"] = os.path.join(run_dir, f"{token}.sock")  # short: AF_UNIX paths max ~107 bytes
        except BaseException:
            self.release(res)
            raise
        return res

    def release(self, resources: dict[str, Any]) -> None:
        for key in ("data", "req"):
            if key in resources:
                _unlink_segment(resources[key])
        for key in ("fifo", "sock"):
            if key in resources:
                try:
                    os.unlink(resources[key])
                except FileNotFoundError:
                    pass

    def make_server(self, node: Node, layouts: NodeLayouts, resources: dict[str, Any]) -> ShmServer:
        return ShmServer(node, layouts, resources)

    def make_client(self, node: Node, layouts: NodeLayouts, address: dict[str, Any]) -> ShmClient:
        return ShmClient(node, layouts, address, self.options.call_timeout)
