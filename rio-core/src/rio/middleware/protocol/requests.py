"""Request flow control at the node's end (the client's end, credits spent per request and returned by
the acknowledgements, is `rio.middleware.protocol.credits`).

Server (`RequestIntake`): a record is checked on arrival (INVALID at once, naming the field). While the
node's queue has room and nobody waits it enters at once (the OK leaves before the node loop wakes); else
it waits in a `FairQueue` (FULL at once beyond its bounds), from which `feed` moves requests round-robin
across peers as the node makes room (OK), or answers FULL after the queue's `put_timeout`. So a peer
flooding requests hears FULL, and every other peer's request takes the next free slot in turn.
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable, Hashable
from typing import Any

from rio import clock
from rio.errors import InvalidRequest
from rio.middleware.protocol.fair import FairQueue
from rio.middleware.protocol.messages import FULL, INVALID, OK, Throttled
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

