"""Shared-memory middleware: a process per node, state and requests in POSIX shared memory.

- State: the node's ring buffer *is* a shared-memory segment; clients read it in place (no copy on
  the wire, no serializer, no pickling). `get(copy=False)` is a true zero-copy read.
- Requests: a bounded queue in a second segment. Producers (any client, any process) serialize on
  `flock` of their own descriptor of that segment — a lock the kernel releases if its holder dies,
  unlike a semaphore — and wake the node through a FIFO when it sleeps waiting for requests.
- API calls: per client, a shared-memory message area and a wake-up pipe each way, handed to the
  node over a Unix socket in the manager's run directory (`shm_calls`).
- Segments and files are created and removed by the ServerManager (`prepare`/`release`), never by
  the node process, so a SIGKILLed node leaves nothing in /dev/shm.
- Memory order: the ring buffer and request queue check each slot (`rio.runtime.slot_check`), the call channel
  hands messages over through a pipe where the CPU may reorder stores (`shm_calls`), so the
  middleware is correct on ARM as on x86. Operating-system calls go through `rio.machine.host` (Linux,
  macOS; Windows is refused with a clear error).
"""

from __future__ import annotations

import logging
import mmap
import os
import select
import socket
import threading
import uuid
import weakref
from typing import Any

from rio import clock
from rio.errors import ConfigError, NodeDiedError, NodeError, NodeTimeout
from rio.machine import host
from rio.middleware.shm_calls import CallChannel, PeerGone, accept_channel, open_client_channel
from rio.runtime import wire
from rio.runtime.buffers import RequestQueue, RingBuffer
from rio.runtime.node import Node
from rio.runtime.transport import ClientTransport, Middleware, NodeLayouts, ProcessWatch, ServerTransport

log = logging.getLogger("rio.middleware.shm")

_POLL_S = 0.05  # how often a waiting call re-checks that the server lives and its deadline


# -- shared memory ----------------------------------------------------------------------------------
def _create_segment(name: str, size: int) -> None:
    os.close(host.shm_create(name, size))


class _Segment:
    """A mapping of an existing segment; keeps its own descriptor (used for flock)."""

    def __init__(self, name: str, size: int):
        self.fd = host.shm_open(name)
        if os.fstat(self.fd).st_size < size:
            os.close(self.fd)
            raise ConfigError(f"shared-memory segment '{name}' is smaller than the node's layout needs")
        self.mm = mmap.mmap(self.fd, size)

    def close(self) -> None:
        # the mapping goes with the last numpy view (closing it here would raise); the descriptor is closed
        # once: a second os.close() of the same number would close whatever the process opened since
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1


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
        if self.fd >= 0:  # once: the number may be reused by the next descriptor the process opens
            os.close(self.fd)
            self.fd = -1


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
                             lock=host.FileLock(seg.fd), notifier=notifier)
    return segments, ring, queue, notifier


#: A reply usually arrives within tens of microseconds: poll for it this long before sleeping in the
#: kernel, because waking a process that sleeps on another core costs ~10-30 us on this class of machine.
SPIN_S = float(os.environ.get("RIO_SHM_SPIN_US", "50")) * 1e-6
#: The node's serving thread polls as long for the next call after answering one (back-to-back calls).
SERVER_SPIN_S = float(os.environ.get("RIO_SHM_SERVER_SPIN_US", "50")) * 1e-6


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
        listener = self._listener
        assert listener is not None  # made by start() before it starts this thread
        while not self._closing:
            try:
                conn, _ = listener.accept()
            except OSError:
                return
            threading.Thread(target=self._serve, args=(conn,), name=f"rio-{self.name}-calls", daemon=True).start()

    def _serve(self, conn: socket.socket) -> None:
        """One thread per client: take its call channel, then wait for a call, run it, answer;
        until the client goes away."""
        try:
            with conn:
                channel = accept_channel(conn)
        except (OSError, ConnectionError) as e:
            log.warning("node '%s': refused an API connection: %s", self.name, e)
            return
        try:
            while True:
                try:
                    message = channel.receive(SERVER_SPIN_S)  # sleeps until a call or a hang-up
                except PeerGone:
                    return
                try:
                    method, args, kwargs = wire.read_call(message)
                except Exception as e:  # a malformed message is the client's bug: answer, keep serving
                    reply = wire.reply_message(False, wire.error_payload(e))
                else:
                    try:
                        reply = wire.reply_message(True, self._dispatch(method, args, kwargs))
                    except Exception as e:
                        reply = wire.reply_message(False, wire.error_payload(e))
                del message  # a view of the area the reply is about to overwrite
                try:
                    channel.send(reply)
                except PeerGone:
                    return
        finally:
            channel.close()

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
        self._req_segment = addr.get("req")
        self._channel: CallChannel | None = None
        self._lock = threading.Lock()
        _CLIENTS.add(self)

    def _after_fork(self) -> None:
        """The child of a fork gets its own call channel and request lock (see `_FlockLock.reopen`);
        sharing the parent's would interleave both processes' messages."""
        self._lock = threading.Lock()
        if self._channel is not None:
            self._channel.close()  # the child's copies only; the parent's channel is untouched
            self._channel = None
        if self.request_queue is not None and self._req_segment:
            self.request_queue.lock.reopen(host.shm_open(self._req_segment))

    def check_alive(self) -> None:
        self._watch.check()

    def _died(self, detail: str) -> NodeDiedError:
        if self._watch.dead():
            return NodeDiedError(self.name, f"server process {self._watch.pid} exited")
        return NodeDiedError(self.name, detail)

    def _connect(self) -> CallChannel:
        if self._channel is None:
            try:
                self._channel = open_client_channel(self._sock_path, min(self.call_timeout, 10.0))
            except (OSError, ConnectionError) as e:
                raise self._died(f"API socket unreachable: {e}") from None
        return self._channel

    def call(self, method: str, args: tuple, kwargs: dict) -> Any:
        with self._lock:
            self._watch.check()
            channel = self._connect()
            deadline = clock.now() + self.call_timeout

            def on_idle() -> None:
                if self._watch.dead():
                    self._drop_channel()
                    raise NodeDiedError(self.name, f"server process {self._watch.pid} exited during '{method}'")
                if clock.now() > deadline:
                    self._drop_channel()  # a late reply must not be read as the next call's
                    raise NodeTimeout(self.name, f"call '{method}'", self.call_timeout)

            try:
                channel.send(wire.call_message(method, args, kwargs))
                ok, value = wire.read_reply(channel.receive(SPIN_S, _POLL_S, on_idle))
            except PeerGone:
                self._drop_channel()
                raise self._died(f"connection closed during '{method}'") from None
            if not ok:
                raise NodeError(self.name, *value)
            return value

    def _drop_channel(self) -> None:
        channel, self._channel = self._channel, None  # taken once, though close() may race a failing call
        if channel is not None:
            channel.close()

    def close(self) -> None:
        _CLIENTS.discard(self)
        self._drop_channel()
        if self._notifier is not None:
            self._notifier.close()
        for seg in self._segments:
            seg.close()
        self._watch.close()


_CLIENTS: weakref.WeakSet[ShmClient] = weakref.WeakSet()


def _after_fork_in_child() -> None:
    for client in list(_CLIENTS):
        client._after_fork()


if hasattr(os, "register_at_fork"):  # not on Windows (no fork there)
    os.register_at_fork(after_in_child=_after_fork_in_child)


class ShmMiddleware(Middleware):
    name = "shm"

    def prepare(self, layouts: NodeLayouts, run_dir: str) -> dict[str, Any]:
        host.require_shared_memory("the shm middleware")
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
                host.shm_unlink(resources[key])
        for key in ("fifo", "sock"):
            if key in resources:
                try:
                    os.unlink(resources[key])
                except FileNotFoundError:
                    pass

    def ring_address(self, address: dict[str, Any]) -> dict[str, Any] | None:
        """Any process of this machine maps the ring buffer's segment read in place; the request queue,
        its lock and wake-up FIFO stay with the node's own clients (the fingerprint then covers the ring only)."""
        out: dict[str, Any] = {k: address[k] for k in ("data", "data_size", "sock", "pid", "machine") if k in address}
        out["fingerprint"] = [address["fingerprint"][0], 0]
        return out

    def make_server(self, node: Node, layouts: NodeLayouts, resources: dict[str, Any]) -> ShmServer:
        return ShmServer(node, layouts, resources)

    def make_client(self, node: Node, layouts: NodeLayouts, address: dict[str, Any]) -> ShmClient:
        return ShmClient(node, layouts, address, self.config.call_timeout)
