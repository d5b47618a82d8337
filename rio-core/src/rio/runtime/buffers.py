"""Ring buffer (published state) and request queue (commands), laid over any writable memory.

Both work on a plain bytearray (thread middleware, network mirrors) or a shared-memory mapping (shm
middleware) with the same code, because a slot is one record of the node's `Layout`.

Ring buffer: one writer, any number of lock-free readers. The writer fills slot `count % N`, checks
it (`rio.runtime.slot_check`: sequence number + checksum) and only then bumps `count`; a reader copies slot
`count-1` and keeps the copy only if the check says it is exactly sample `count-1`, else reads again.
A reader's copies go to buffers recycled once nothing references them (`rio.runtime.recycle`): a camera frame
read at every control tick costs a copy, not a copy plus page faults.
The check, not the order in which memory becomes visible, is what makes a read safe, so the same code
is correct on x86 and on ARM (see `rio.runtime.slot_check` for the argument). Request queue: many producers under
a lock, one consumer that takes only checked, complete slots; a full queue makes `put` wait (bounded)
instead of dropping a command silently.

Memory: a 64-byte header, the slots, then one 16-byte check per slot (8-byte aligned).
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping
from typing import Any, Protocol

import numpy as np

from rio import clock
from rio.errors import QueueFull, RioError
from rio.machine import host
from rio.runtime import slot_check
from rio.runtime.layout import TIMESTAMP, Layout
from rio.runtime.recycle import BufferPool

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


#: A reader that finds no consistent sample for this long gives up (only a corrupted segment, or a
#: writer that outruns every copy, can keep it from finding one).
_CONSISTENT_S = 1.0
#: How long `RingBuffer.find` waits for a sample another process has published to become visible here
#: (microseconds on any CPU; the margin covers a reader descheduled between two looks).
_VISIBLE_S = 0.02


def _check_offset(layout: Layout, capacity: int) -> int:
    return _HEADER + -(-capacity * layout.itemsize // _HEADER) * _HEADER


def _nbytes(layout: Layout, capacity: int) -> int:
    return _check_offset(layout, capacity) + capacity * 8 * slot_check.CHECK_WORDS


class _Slots:
    """The slot records, their raw bytes and their checks, over one buffer."""

    def __init__(self, layout: Layout, capacity: int, buf: Any):
        self.records = np.ndarray((capacity,), layout.dtype, buffer=buf, offset=_HEADER)
        self.raw = np.ndarray((capacity, layout.itemsize), np.uint8, buffer=buf, offset=_HEADER)
        self.checks = slot_check.checks_view(buf, capacity, _check_offset(layout, capacity))
        self.dtype, self.capacity = layout.dtype, capacity
        #: where a reader's copies go: recycled once nothing holds them (no page faults per camera frame)
        self._copies = BufferPool(layout.itemsize)

    def write(self, seq: int, rec: np.ndarray) -> None:
        i = seq % self.capacity
        self.records[i] = rec
        slot_check.write_check(self.checks, i, seq, self.raw[i])

    def read(self, seq: int) -> np.ndarray | None:
        """A copy of sample `seq` as a record, or None if the slot does not hold it (yet, or any more)."""
        i = seq % self.capacity
        raw = self._copies.take()
        np.copyto(raw, self.raw[i])
        return raw.view(self.dtype)[0] if slot_check.matches(self.checks, i, seq, raw) else None

    def view(self, seq: int) -> np.ndarray | None:
        """Sample `seq` in place (no copy), if its slot holds it now (checked over the live bytes)."""
        i = seq % self.capacity
        return self.records[i] if slot_check.in_place(self.checks, i, seq, self.raw[i]) else None

    def read_many(self, seqs: list[int]) -> np.ndarray | None:
        idx = [q % self.capacity for q in seqs]
        raw = self.raw[idx]  # fancy indexing copies
        for row, (i, q) in enumerate(zip(idx, seqs, strict=True)):
            if not slot_check.matches(self.checks, i, q, raw[row]):
                return None
        return raw.view(self.dtype).reshape(len(seqs))


class _Retry:
    """Pacing of a reader's retries: spin, then yield the CPU; give up after `_CONSISTENT_S`."""

    __slots__ = ("tries", "deadline", "owner")

    def __init__(self, owner: str):
        self.tries, self.deadline, self.owner = 0, 0.0, owner

    def again(self) -> None:
        self.tries += 1
        if self.tries % 16:
            return
        now = clock.now()
        if self.deadline == 0.0:
            self.deadline = now + _CONSISTENT_S
        elif now > self.deadline:
            raise RioError(f"node '{self.owner}': no consistent sample in its buffer for {_CONSISTENT_S:.0f} s "
                           "(its shared memory was overwritten by something else?)")
        host.yield_cpu()


class RingBuffer:
    """Latest-N samples of a node, each with a timestamp from `rio.clock.now()`."""

    def __init__(self, layout: Layout, capacity: int = 64, buf: Any = None,
                 on_put: Callable[[np.ndarray], None] | None = None):
        if capacity < 2:
            raise ValueError("ring buffer capacity must be >= 2")
        self.layout, self.capacity = layout, capacity
        self.buf = bytearray(self.nbytes(layout, capacity)) if buf is None else buf
        self._count = np.ndarray((1,), np.uint64, buffer=self.buf, offset=0)
        self._slots = _Slots(layout, capacity, self.buf)
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
        self._slots.write(c, rec)
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
        """Copy of the newest record (checked against its slot check: never torn, never stale)."""
        retry = _Retry(self.layout.owner)
        while True:
            c = self._require(1)
            rec = self._slots.read(c - 1)
            if rec is not None:
                return rec
            retry.again()

    def get(self, out: dict[str, np.ndarray] | None = None, *, copy: bool = True) -> dict[str, Any]:
        """Newest sample as a dict. `out` fills preallocated arrays; `copy=False` returns zero-copy
        read-only views into the buffer (checked when taken), valid until the
        writer laps the ring (capacity-1 samples)."""
        if not copy:
            retry = _Retry(self.layout.owner)
            while True:
                c = self._require(1)
                i = (c - 1) % self.capacity
                if slot_check.in_place(self._slots.checks, i, c - 1, self._slots.raw[i]):
                    break
                retry.again()
            d = self.layout.to_dict(self._slots.records[i], copy=False)
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

    def find(self, timestamp: float) -> dict[str, Any] | None:
        """The sample stamped exactly `timestamp` (a checked copy, like `get()`), or None when the ring
        no longer holds it: overwritten by the writer (it keeps capacity-1 samples), or never written.

        Slots are located by an unchecked peek at their timestamps; only the copy is trusted, and only if
        its slot check says it is that very sample, so a slot rewritten during the copy is reported as gone
        (None), never returned. A sample this process does not see yet (memory order) is waited for briefly."""
        found = self._search(timestamp, self._slots.read)
        return None if found is None else self.layout.to_dict(found[0], copy=False)

    def find_view(self, timestamp: float) -> tuple[dict[str, Any], int] | None:
        """`find` without the copy: read-only views into the slot of the sample stamped `timestamp`, and its
        sequence number. Checked when taken; the views stay that sample only while `holds(seq)`, so a reader
        asks that after using them and drops what it computed if not (a reader's optimistic lock)."""
        found = self._search(timestamp, self._slots.view)
        if found is None:
            return None
        d = self.layout.to_dict(found[0], copy=False)
        for v in d.values():
            if isinstance(v, np.ndarray):
                v.flags.writeable = False
        return d, found[1]

    def holds(self, seq: int) -> bool:
        """Whether sample `seq`'s slot is untouched so far: the writer starts on the sample that replaces it,
        `seq + capacity`, only once `count` has reached that."""
        return int(self._count[0]) < seq + self.capacity

    def _search(self, timestamp: float, take: Callable[[int], Any]) -> tuple[Any, int] | None:
        stamps = self._slots.records[TIMESTAMP]
        n = self.capacity
        deadline = 0.0
        while True:
            c = int(self._count[0])
            oldest = max(c - n + 1, 0)  # the slot of c - n may be being rewritten with sample c
            for seq in range(c - 1, oldest - 1, -1):
                t = float(stamps[seq % n])
                if t < timestamp:
                    break
                if t == timestamp:
                    rec = take(seq)
                    if rec is not None:
                        return rec, seq
                    if seq < int(self._count[0]) - n + 1:
                        return None  # overwritten while we copied it
                    break  # written, not yet visible here: look again
            else:
                if c:  # every live sample is newer: it was overwritten
                    return None
            now = clock.now()
            deadline = deadline or now + _VISIBLE_S
            if now > deadline:
                return None
            host.yield_cpu()

    def get_last_k(self, k: int, out: dict[str, np.ndarray] | None = None) -> dict[str, Any]:
        """The k newest samples, oldest first, each field with a leading axis of k. Before k samples
        exist, the oldest is repeated (its timestamps show it), so shapes are fixed from the start."""
        retry = _Retry(self.layout.owner)
        while True:
            c = self._require(k)
            recs = self._slots.read_many([max(c - k + i, 0) for i in range(k)])
            if recs is not None:
                break
            retry.again()
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
        self._slots = _Slots(layout, capacity, self.buf)
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
                    self._slots.write(tail, rec)
                    self._hdr[1] = tail + 1
                    break
            deadline = deadline or clock.now() + self.put_timeout
            if clock.now() > deadline:
                raise QueueFull(self.layout.owner, self.capacity, self.put_timeout)
            host.yield_cpu()
        self.notifier.notify()

    def put_bytes(self, data: bytes | memoryview) -> None:
        """Enqueue a record that crossed a boundary; re-checked for NaN/inf on this side."""
        self.put_record(self.check_bytes(data))

    def check_bytes(self, data: bytes | memoryview) -> np.ndarray:
        """The record in `data` (a view of it), checked as `put_bytes` checks it; a refusal is counted
        (`rejected`) and raised as InvalidRequest naming the field. For a producer that enqueues later."""
        try:
            rec = self.layout.decode_bytes(data)
            self.layout.check_record(rec)
        except Exception:
            self._hdr[2] += 1
            raise
        return rec

    # -- consumer -----------------------------------------------------------------------------------
    def get_all(self) -> list[dict[str, Any]]:
        """Every pending request, oldest first (empty list when none). A request whose slot is not
        yet fully visible to this process (its check does not match) waits for the next call."""
        head, tail = int(self._hdr[0]), int(self._hdr[1])
        out = []
        for seq in range(head, tail):
            rec = self._slots.read(seq)
            if rec is None:
                break
            out.append(self.layout.to_dict(rec, copy=False))
        if out:
            self._hdr[0] = head + len(out)  # only after the copies were checked (see rio.runtime.slot_check)
        return out

    def get(self) -> dict[str, Any] | None:
        """Oldest pending request, or None."""
        head, tail = int(self._hdr[0]), int(self._hdr[1])
        if tail == head:
            return None
        rec = self._slots.read(head)
        if rec is None:
            return None
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
            host.yield_cpu()
        self.notifier.clear()
        if len(self):
            return True
        self.notifier.wait(timeout)
        return len(self) > 0

    @property
    def rejected(self) -> int:
        return int(self._hdr[2])


class RequestSender:
    """Client side of a request queue on a network: check the values here and hand on the checked record's own
    memory, not a `tobytes()` copy (the transport joins it with the request's id once, the only copy after the
    check). A record can be megabytes: an observation with its camera frames."""

    def __init__(self, layout: Layout, send: Callable[[np.ndarray], None]):
        self.layout, self._send = layout, send

    def put(self, values: Mapping[str, Any]) -> None:
        rec = self.layout.encode(values, fill_timestamp=clock.now())
        self._send(rec.reshape(1).view(np.uint8))  # a fresh record, never written again: no copy needed


__all__ = ["RingBuffer", "RequestQueue", "RequestSender", "ThreadNotifier", "TIMESTAMP"]
