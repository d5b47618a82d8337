"""API calls of the shm middleware: one shared-memory message area and two wake-up pipes per client.

Why not a socket: on this class of machine a Unix-socket round trip costs about twice a pipe's, and
a socket copies every payload through the kernel twice. Here a message is written straight into
memory both processes map (the arrays' own bytes: see `rio.runtime.wire.call_message`), and only a one-byte
wake-up crosses the kernel: the "raw pipe + shared memory" transport the latency benchmark compares
against.

- Set-up: the client creates the memory (`rio.machine.host.anonymous_memory`: a memfd on Linux, so nothing
  appears in /dev/shm, and the kernel frees it with the last descriptor) and both pipes, and hands
  the node's ends over the node's Unix socket (SCM_RIGHTS). The socket is closed after that hand-over.
- Calls strictly alternate (the client holds a lock), so one area carries the call, then its reply.
  A 16-byte header holds the message length and a message counter, written last. A message that
  does not fit grows the file; the other side re-maps when a message is longer than its mapping.
- Waiting: watch the counter, yielding the CPU, for a few tens of microseconds, then block on the
  pipe. Waking a process that sleeps on the other core costs ~10-30 us here, more than the whole
  call, and each extra system call ~0.5 us. Every message also writes a wake-up byte, so a sleeping
  peer always wakes; a peer that caught the message while watching drains the byte later, before
  it next blocks.
- Memory order: watching the counter relies on x86's rule that stores become visible in program
  order. Elsewhere (ARM) the waiting side polls the pipe instead, so the message is read only after
  a system call, which orders memory on any architecture.
- A peer that dies closes its pipe ends with it, so the survivor sees a hang-up: the node's serving
  thread ends when its client goes away, and a client learns at once that its node died.
"""

from __future__ import annotations

import mmap
import os
import platform
import select
import socket
import threading
from collections.abc import Callable

from rio import clock
from rio.machine import host
from rio.runtime.wire import Message

# Header: 8 bytes reserved, u32 message length at 8, u32 count of messages written so far at 12.
# Read and written through a native-int memoryview: each field is one aligned load or store.
# (struct.pack_into zeroes its bytes first and then writes them one by one, so a peer polling the
# counter could read a count that was never written.)
_HEADER_SIZE = 16
_HELLO = b"rio-shm-calls/1"
_INITIAL_AREA = 64 * 1024
#: Whether a store-ordered CPU lets the waiting side watch the counter in memory (see module doc).
WATCH_MEMORY = platform.machine().lower() in {"x86_64", "amd64", "i386", "i686", "x86"}


class PeerGone(Exception):
    """The other end of a call channel closed (its process exited or dropped the channel)."""


def _spin_until(ready: Callable[[], bool], spin_s: float) -> bool:
    """Poll `ready()` for up to `spin_s`, yielding the CPU between tries (a pure busy loop would
    starve the peer on a 2-core machine)."""
    if ready():
        return True
    t_end = clock.now() + spin_s
    while clock.now() < t_end:
        host.yield_cpu()
        if ready():
            return True
    return False


class CallChannel:
    """One end of a call line. `send(message)` writes a message and wakes the peer; `receive()`
    waits for the peer's message and returns a memoryview of it, valid until the next `send`."""

    def __init__(self, mem_fd: int, wake_in: int, wake_out: int, watch_memory: bool = WATCH_MEMORY):
        self._fd, self._in, self._out = mem_fd, wake_in, wake_out
        self._closing = threading.Lock()
        self._watch_memory = watch_memory
        os.set_blocking(wake_in, True)  # a read returns what is pending, or sleeps for the next byte
        os.set_blocking(wake_out, False)  # a full pipe means wake-ups are pending: never wait on it
        self._poller = select.poll()
        self._poller.register(wake_in, select.POLLIN)
        self._map(os.fstat(mem_fd).st_size)
        self._count = self._length_count[1]  # last message written or seen

    def _map(self, size: int) -> None:
        # An older mapping is only dropped, never closed: a caller may still hold a view of it.
        self._mm = mmap.mmap(self._fd, size)
        self._view = memoryview(self._mm)
        self._length_count = self._view[8:16].cast("I")
        self._size = size

    # -- sending ------------------------------------------------------------------------------------
    def send(self, message: Message) -> None:
        """Write `message` (a `rio.runtime.wire` message: head bytes, then the arrays' data) and wake the peer."""
        head, arrays = message
        n = len(head)
        for a in arrays:
            n += a.nbytes
        if _HEADER_SIZE + n > self._size:
            self._grow(_HEADER_SIZE + n)
        mm, off = self._mm, _HEADER_SIZE + len(head)
        mm[_HEADER_SIZE:off] = head
        for a in arrays:  # C-contiguous arrays: their buffer is their bytes
            mm[off:off + a.nbytes] = a
            off += a.nbytes
        fields = self._length_count
        fields[0] = n
        self._count = (self._count + 1) & 0xFFFFFFFF
        fields[1] = self._count  # last: a peer that sees it sees the whole message
        try:
            os.write(self._out, b"\x01")
        except BlockingIOError:  # pipe full: the peer has wake-ups pending anyway
            pass
        except OSError as e:  # EPIPE: the peer closed its end
            raise PeerGone(str(e)) from None

    def _grow(self, need: int) -> None:
        size = max(need, 2 * self._size, os.fstat(self._fd).st_size)  # never shrink under the peer
        os.ftruncate(self._fd, size)
        self._map(size)

    # -- receiving ----------------------------------------------------------------------------------
    def receive(self, spin_s: float, poll_s: float = 0.05, on_idle: Callable[[], None] | None = None) -> memoryview:
        """Wait for the peer's next message: watch for `spin_s`, then sleep. With `on_idle`, sleep in
        steps of `poll_s` seconds and call `on_idle()` (which may raise) after each step without a
        message; without it, sleep until a message or a hang-up."""
        if not (self._watch_memory and _spin_until(self._arrived, spin_s)):
            self._block(spin_s, poll_s, on_idle)
        n = self._length_count[0]
        if _HEADER_SIZE + n > self._size:  # the peer grew the area
            self._map(os.fstat(self._fd).st_size)
            if _HEADER_SIZE + n > self._size:
                raise PeerGone(f"peer wrote a {n}-byte message into a {self._size}-byte area")
        return self._view[_HEADER_SIZE:_HEADER_SIZE + n]

    def _arrived(self) -> bool:
        count = self._length_count[1]
        if count == self._count:
            return False
        self._count = count
        return True

    def _block(self, spin_s: float, poll_s: float, on_idle: Callable[[], None] | None) -> None:
        """Sleep on the pipe until the counter moves. Each wake-up read takes every byte pending,
        including those of messages caught earlier by watching; the system call also orders the
        counter's read after it on any architecture."""
        if not self._watch_memory:  # spin on the pipe instead of the counter
            _spin_until(lambda: bool(self._poller.poll(0)), spin_s)
        timeout_ms = max(1, int(poll_s * 1000))
        while True:
            if on_idle is not None and not self._poller.poll(timeout_ms):
                on_idle()
                continue
            hung_up = not os.read(self._in, 4096)  # blocks only without on_idle: one system call
            if self._arrived():
                return
            if hung_up:
                raise PeerGone("hung up")

    def close(self) -> None:
        """Once, whoever calls it (a client's call dropping a dead channel, its close() from another
        thread): a second os.close() of these numbers would close whatever the process opened since under
        the same numbers (another node's channel, a recorder's encoder socket)."""
        with self._closing:
            fds, self._in, self._out, self._fd = (self._in, self._out, self._fd), -1, -1, -1
        for fd in fds:
            if fd < 0:
                continue
            try:
                os.close(fd)
            except OSError:
                pass
        try:
            self._length_count.release()
            self._view.release()
            self._mm.close()
        except BufferError:  # a caller still holds a view; the mapping goes with it
            pass


# -- set-up over the node's Unix socket -------------------------------------------------------------
def open_client_channel(sock_path: str, timeout_s: float) -> CallChannel:
    """Create a channel and hand its node-side ends to the node listening on `sock_path`.
    Raises OSError if the node is unreachable or does not accept it in time."""
    mem = host.anonymous_memory("rio-shm-calls", _HEADER_SIZE + _INITIAL_AREA)
    call_r, call_w = os.pipe()
    reply_r, reply_w = os.pipe()
    ok = False
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
            s.settimeout(timeout_s)
            s.connect(sock_path)
            socket.send_fds(s, [_HELLO], [mem, call_r, reply_w])
            if s.recv(1) != b"\x01":
                raise ConnectionError("node refused the call channel")
        ok = True
        return CallChannel(mem, reply_r, call_w)
    finally:
        os.close(call_r)  # the node has its own copies now; ours would hide its hang-up from us
        os.close(reply_w)
        if not ok:
            for fd in (mem, call_w, reply_r):
                os.close(fd)


def accept_channel(conn: socket.socket, timeout_s: float = 5.0) -> CallChannel:
    """Node side of `open_client_channel` on an accepted connection."""
    conn.settimeout(timeout_s)
    msg, fds, _, _ = socket.recv_fds(conn, len(_HELLO), 3)
    if msg != _HELLO or len(fds) != 3:
        for fd in fds:
            os.close(fd)
        raise ConnectionError(f"not a rio call channel request ({msg[:32]!r}, {len(fds)} descriptors)")
    for fd in fds:
        os.set_inheritable(fd, False)
    channel = CallChannel(fds[0], fds[1], fds[2])
    conn.sendall(b"\x01")
    return channel
