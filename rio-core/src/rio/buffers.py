"""Ring buffer (published state) and request queue (commands), laid over any writable memory.

Both work on a plain bytearray (thread middleware, network mirrors) or a shared-memory mapping (shm
middleware) with the same code, because a slot is one record of the node's `Layout`.

Ring buffer: one writer, any number of lock-free readers. The writer fills slot `count % N` and only
then bumps `count`; a reader copies slot `count-1` and re-reads `count` afterwards: if the writer may
have lapped onto the slot during the copy, it retries. Request queue: many producers under a lock,
one consumer; a full queue makes `put` wait (bounded) instead of dropping a command silently.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Mapping
from typing import Any, Protocol

import numpy as np

from . import clock
from .errors import QueueFull, RioError
from .layout import TIMESTAMP, Layout

_HEADER = 64  # bytes; keeps slots cache-line aligned


class Lock(Protocol):
    def __enter__(self) -> Any: ...
    def __exit__(self, *exc: Any) -> Any: ...


class Notifier(Protocol):
    """Wakes a consumer blocked on an empty queue."""

    def notify(self) -> None: ...
    def wait(self, timeout: float) -> bool: ...
    def clear(self) -> None: ...


class ThreadNotifier:
    """In-process wake-up (threading.Event)."""

    def __init__(self) -> None:
        self._ev = threading.Event()

    def notify(self) -> None:
        self._ev.set()

    def wait(self, timeout: float) -> bool:
        return self._ev.wait(timeout)

    def clear(self) -> None:
        self._ev.clear()


def _nbytes(layout: Layout, capacity: int) -> int:
    return _HEADER + capacity * layout.itemsize


class RingBuffer:
    """Latest-N samples of a node, each with a timestamp from `rio.clock.now()`."""

    def __init__(self, layout: Layout, capacity: int = 64, buf: Any = None,
                 on_put: Callable[[np.ndarray], None] | None = None):
        if capacity < 2:
            raise ValueError("ring buffer capacity must be >= 2")
        self.layout, self.capacity = layout, capacity
        self.buf = bytearray(self.nbytes(layout, capacity)) if buf is None else buf
        self._count = np.ndarray((1,), np.uint64, buffer=self.buf, offset=0)
        self._slots = np.ndarray((capacity,), layout.dtype, buffer=self.buf, offset=_HEADER)
        #: Called with each new record after it is stored (network middlewares send it from here).
        self.on_put = on_put

    nbytes = staticmethod(_nbytes)

    @property
    def count(self) -> int:
        """Samples written since creation (monotonic; also tells a reader whether anything is new)."""
        return int(self._count[0])

    # -- writer -------------------------------------------------------------------------------------
    def put(self, values: Mapping[str, Any]) -> None:
        """Validate and append one sample; the timestamp is filled with `now()` when absent."""
        self.put_record(self.layout.encode(values, fill_timestamp=clock.now(), check_finite=False))

    def put_record(self, rec: np.ndarray) -> None:
        c = int(self._count[0])
        self._slots[c % self.capacity] = rec
        self._count[0] = c + 1
        if self.on_put is not None:
            self.on_put(rec)

    def put_bytes(self, data: bytes | memoryview) -> None:
        self.put_record(self.layout.decode_bytes(data))

    # -- readers ------------------------------------------------------------------------------------
    def _require(self, k: int) -> int:
        c = int(self._count[0])
        if c == 0:
            raise RioError(f"node '{self.layout.owner}' has published nothing yet")
        if not 1 <= k < self.capacity:
            raise ValueError(f"k must be in [1, {self.capacity - 1}] for node '{self.layout.owner}'")
        return c

    def get_record(self) -> np.ndarray:
        """Copy of the newest record (torn-read safe)."""
        while True:
            c = self._require(1)
            rec = self._slots[(c - 1) % self.capacity].copy()
            if int(self._count[0]) - c < self.capacity - 1:
                return rec

    def get(self, out: dict[str, np.ndarray] | None = None, *, copy: bool = True) -> dict[str, Any]:
        """Newest sample as a dict. `out` fills preallocated arrays; `copy=False` returns zero-copy
        read-only views into the buffer, valid until the writer laps the ring (capacity-1 samples)."""
        if not copy:
            c = self._require(1)
            view = self._slots[(c - 1) % self.capacity]
            d = self.layout.to_dict(view, copy=False)
            for v in d.values():
                if isinstance(v, np.ndarray):
                    v.flags.writeable = False
            return d
        rec = self.get_record()
        if out is None:
            return self.layout.to_dict(rec, copy=False)
        for n in self.layout.names:
            if n in out:
                np.copyto(out[n], rec[n])
            else:
                out[n] = rec[n]
        return out

    def get_last_k(self, k: int, out: dict[str, np.ndarray] | None = None) -> dict[str, Any]:
        """The k newest samples, oldest first, each field with a leading axis of k. Before k samples
        exist, the oldest is repeated (its timestamps show it), so shapes are fixed from the start."""
        while True:
            c = self._require(k)
            idx = [max(c - k + i, 0) % self.capacity for i in range(k)]
            recs = self._slots[idx]  # fancy indexing copies
            if int(self._count[0]) - c < self.capacity - k:
                break
        if out is None:
            return self.layout.to_dict(recs, copy=False)
        for n in self.layout.names:
            if n in out:
                np.copyto(out[n], recs[n])
            else:
                out[n] = recs[n]
        return out


class RequestQueue:
    """Bounded multi-producer / single-consumer queue of validated requests."""

    def __init__(self, layout: Layout, capacity: int = 64, buf: Any = None, *,
                 lock: Lock | None = None, notifier: Notifier | None = None,
                 put_timeout: float = 1.0):
        self.layout, self.capacity, self.put_timeout = layout, capacity, put_timeout
        self.buf = bytearray(self.nbytes(layout, capacity)) if buf is None else buf
        hdr = np.ndarray((3,), np.uint64, buffer=self.buf, offset=0)
        self._hdr = hdr  # [head (consumer), tail (producers), rejected]
        self._slots = np.ndarray((capacity,), layout.dtype, buffer=self.buf, offset=_HEADER)
        self.lock = lock if lock is not None else threading.Lock()
        self.notifier = notifier if notifier is not None else ThreadNotifier()

    nbytes = staticmethod(_nbytes)

    def __len__(self) -> int:
        return int(self._hdr[1]) - int(self._hdr[0])

    # -- producers ----------------------------------------------------------------------------------
    def put(self, values: Mapping[str, Any]) -> None:
        """Validate (keys, shapes, dtypes, finite) and enqueue; raises InvalidRequest naming the field."""
        self.put_record(self.layout.encode(values, fill_timestamp=clock.now()))

    def put_record(self, rec: np.ndarray) -> None:
        deadline = None
        while True:
            with self.lock:
                head, tail = int(self._hdr[0]), int(self._hdr[1])
                if tail - head < self.capacity:
                    self._slots[tail % self.capacity] = rec
                    self._hdr[1] = tail + 1
                    break
            deadline = deadline or clock.now() + self.put_timeout
            if clock.now() > deadline:
                raise QueueFull(self.layout.owner, self.capacity, self.put_timeout)
            os.sched_yield()
        self.notifier.notify()

    def put_bytes(self, data: bytes | memoryview) -> None:
        """Enqueue a record that crossed a boundary; re-checked for NaN/inf on this side."""
        rec = self.layout.decode_bytes(data)
        try:
            self.layout.check_record(rec)
        except Exception:
            self._hdr[2] += 1
            raise
        self.put_record(rec)

    # -- consumer -----------------------------------------------------------------------------------
    def get_all(self) -> list[dict[str, Any]]:
        """Every pending request, oldest first (empty list when none)."""
        head, tail = int(self._hdr[0]), int(self._hdr[1])
        if tail == head:
            return []
        idx = [i % self.capacity for i in range(head, tail)]
        recs = self._slots[idx]
        self._hdr[0] = tail
        return [self.layout.to_dict(r, copy=False) for r in recs]

    def get(self) -> dict[str, Any] | None:
        """Oldest pending request, or None."""
        head, tail = int(self._hdr[0]), int(self._hdr[1])
        if tail == head:
            return None
        rec = self._slots[head % self.capacity].copy()
        self._hdr[0] = head + 1
        return self.layout.to_dict(rec, copy=False)

    def wait(self, timeout: float, spin_s: float = 20e-6) -> bool:
        """Block until a request is pending or `timeout` passes: spin briefly, then sleep on the
        notifier (spinning alone stalls the producer on a 2-core machine)."""
        t_spin = clock.now() + spin_s
        while True:
            if len(self):
                return True
            if clock.now() > t_spin:
                break
            os.sched_yield()
        self.notifier.clear()
        if len(self):
            return True
        self.notifier.wait(timeout)
        return len(self) > 0

    @property
    def rejected(self) -> int:
        return int(self._hdr[2])


class RequestSender:
    """Client side of a request queue on a network: validate here, send the record's bytes."""

    def __init__(self, layout: Layout, send: Callable[[bytes], None]):
        self.layout, self._send = layout, send

    def put(self, values: Mapping[str, Any]) -> None:
        self._send(self.layout.encode(values, fill_timestamp=clock.now()).tobytes())


__all__ = ["RingBuffer", "RequestQueue", "RequestSender", "ThreadNotifier", "TIMESTAMP"]
