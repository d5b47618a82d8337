"""Request flow control, both ends in one place (credit-based flow control, where acknowledgements grant
queue slots and a client with none fails at once, would change only this module: OK already carries the
free slots).

Server (`RequestIntake`): a record is checked on arrival (INVALID at once, naming the field). While the
node's queue has room and nobody waits it enters at once (the OK leaves before the node loop wakes); else
it waits in a `FairQueue` (FULL at once beyond its bounds), from which `feed` moves requests round-robin
across peers as the node makes room (OK), or answers FULL after the queue's `put_timeout`. So a peer
flooding requests hears FULL, and every other peer's request takes the next free slot in turn.

Client (`RequestFlow`): one request in flight per client, so the node sees them in the sender's order; it
returns on OK, raises QueueFull / InvalidRequest naming the node, NodeTimeout when no answer comes.
"""

from __future__ import annotations

import itertools
import logging
import math
import threading
from collections.abc import Callable, Hashable
from typing import Any

from rio import clock
from rio.errors import InvalidRequest, NodeTimeout
from rio.middleware.protocol.fair import FairQueue
from rio.middleware.protocol.messages import FULL, INVALID, OK, REQUEST_ID, Throttled, ack_error
from rio.runtime import wire
from rio.runtime.buffers import RequestQueue

log = logging.getLogger("rio.middleware.protocol")

#: How often `feed` looks for room while requests wait (a queue has no "room again" signal).
FEED_S = 0.0005
#: How long a client waits at least for a request's answer (a server holds one up to its put timeout, 1 s).
ANSWER_TIMEOUT_S = 2.0

#: ack(peer, request id, status, a, b, tag): sends one answer.
Ack = Callable[[Hashable, int, int, Any, Any, Any], None]


class RequestIntake:
    def __init__(self, node: str, queue: RequestQueue | None, ack: Ack, waiting: FairQueue,
                 wake: Callable[[], None]):
        self.node, self.queue, self._ack, self._waiting, self._wake = node, queue, ack, waiting, wake
        self._lock = threading.Lock()  # one producer at a time: arrival order is queue order
        #: Told of every request refused FULL (the server's flood indicator).
        self.on_full: Callable[[], None] = lambda: None
        self._warn = Throttled(log)

    def take(self, peer: Hashable, rid: int, record: memoryview, tag: Any = None) -> None:
        """A request from `peer` (any transport thread): answered now, or parked for `feed`."""
        q = self.queue
        if q is None:
            return self._refuse(peer, rid, INVALID, None, "the node takes no requests", tag)
        try:
            rec = q.check_bytes(record)
        except InvalidRequest as e:
            return self._refuse(peer, rid, INVALID, e.field, e.problem, tag)
        with self._lock:
            free = q.capacity - len(q)
            if free > 0 and not len(self._waiting):
                self._ack(peer, rid, OK, free - 1, None, tag)
                q.put_record(rec)
                return None
            refused = self._waiting.put(peer, (rid, rec, clock.now() + q.put_timeout, tag))
        for item in refused:
            self._full(*item)
        self._wake()
        return None

    def feed(self) -> float:
        """Move waiting requests into the queue as room appears, round-robin across peers; FULL to those
        that waited `put_timeout`. Returns how soon to call again (inf: nothing waits)."""
        q = self.queue
        if q is None or not len(self._waiting):
            return math.inf
        now = clock.now()
        for expired in self._waiting.expire(lambda item: item[2] < now):
            self._full(*expired)
        with self._lock:
            while len(q) < q.capacity and (got := self._waiting.get(0)) is not None:
                peer, (rid, rec, _, tag) = got
                self._ack(peer, rid, OK, q.capacity - len(q) - 1, None, tag)
                q.put_record(rec)
        return FEED_S if len(self._waiting) else math.inf

    def drop(self, peer: Hashable) -> None:
        self._waiting.drop(peer)

    @property
    def waiting(self) -> int:
        return len(self._waiting)

    def close(self) -> None:
        self._waiting.close()

    def _full(self, peer: Hashable, item: tuple) -> None:
        assert self.queue is not None
        self.on_full()
        self._refuse(peer, item[0], FULL, self.queue.capacity, self.queue.put_timeout, item[3])

    def _refuse(self, peer: Hashable, rid: int, status: int, a: Any, b: Any, tag: Any) -> None:
        what = "queue full" if status == FULL else f"invalid: {a}: {b}"
        self._warn("node '%s': refused a request of peer %r (%s)", self.node, peer, what)
        self._ack(peer, rid, status, a, b, tag)


class RequestFlow:
    def __init__(self, node: str, timeout: float, send: Callable[[bytes], None],
                 recv: Callable[[], bytes | memoryview | None], alive: Callable[[], None]):
        self.node, self.timeout = node, max(timeout, ANSWER_TIMEOUT_S)
        self._send, self._recv, self._alive = send, recv, alive
        self._lock = threading.Lock()
        self._ids = itertools.count(1)

    def send(self, record: bytes) -> None:
        """Send one request record; return once the node has queued it (see the module's doc)."""
        with self._lock:
            self._alive()
            rid = next(self._ids)
            self._send(REQUEST_ID.pack(rid) + record)
            deadline = clock.now() + self.timeout
            while True:
                body = self._recv()  # waits a liveness poll at most
                if body is None:
                    self._alive()
                    if clock.now() > deadline:
                        raise NodeTimeout(self.node, "a request (no answer from the node)", self.timeout)
                    continue
                try:
                    ack = wire.unpack(body)
                    mine = ack[0] == rid  # else the late answer of a request that timed out
                    error = ack_error(self.node, ack) if mine else None
                except (ValueError, TypeError, IndexError, KeyError):
                    log.warning("node '%s': ignored a malformed answer to a request", self.node)
                    continue
                if not mine:
                    continue
                if error is not None:
                    raise error
                return
