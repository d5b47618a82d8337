"""Fair scheduling of work that peers send a node (API calls, requests waiting for room).

Each peer has its own queue, bounded (`per_peer`), and all queues together are bounded (`total` items, and
`max_bytes` of what they hold: a node's memory for its peers is bounded whatever their number); work is
taken round-robin across peers, so one peer's flood waits behind its own work, never in front of another
peer's: with n peers waiting, a newcomer's item is taken within n turns. When a total bound is reached,
someone gives way (their newest item is refused) to the newcomer: a stranger (a peer `known` does not
vouch for: it never finished a handshake nor was served) to a known peer, else the peer holding the most
(items, or bytes) if it holds at least two items more than the newcomer (or more bytes than the newcomer
would). So neither many flooding peers nor a swarm of made-up ones keeps a real client out. Refused items
go back to the caller, who answers them (TooManyCalls, QueueFull): nothing is dropped without its sender
hearing of it.
"""

from __future__ import annotations

import math
import queue
import threading
from collections import OrderedDict, deque
from collections.abc import Callable, Hashable
from typing import Any

from rio import clock


class FairQueue:
    """`size(item)`: the bytes an item holds (for `max_bytes`)."""

    def __init__(self, per_peer: int, total: int, known: Callable[[Hashable], bool] = lambda peer: False,
                 max_bytes: float = math.inf, size: Callable[[Any], int] = lambda item: 0):
        self.per_peer, self.total, self.known = per_peer, total, known
        self.max_bytes, self.size = max_bytes, size
        self._queues: OrderedDict[Hashable, deque[Any]] = OrderedDict()  # in turn order
        self._bytes: dict[Hashable, int] = {}  # what each peer's queued items hold
        self._n = 0
        self.nbytes = 0
        self._closed = False
        self._lock = threading.Lock()
        #: One token per item queued (and one on close) wakes `get`: a SimpleQueue hands over ~2 us faster
        #: than a Condition. Tokens of items that left otherwise (refused, dropped) only cost a look.
        self._tokens: queue.SimpleQueue[None] = queue.SimpleQueue()

    def __len__(self) -> int:
        return self._n

    def put(self, peer: Hashable, item: Any) -> list[tuple[Hashable, Any]]:
        """Queue `item` for `peer`; returns what was refused instead, [(peer, item), ...]: the newcomer's item,
        or items others gave way with (empty when nothing was)."""
        size = self.size(item)
        with self._lock:
            q = self._queues.get(peer)
            mine = 0 if q is None else len(q)
            if mine >= self.per_peer or self._closed or size > self.max_bytes:
                return [(peer, item)]
            refused: list[tuple[Hashable, Any]] = []
            known = self.known(peer)
            while self._n >= self.total or self.nbytes + size > self.max_bytes:
                victim = self._victim(peer, mine, self._bytes.get(peer, 0) + size, known,
                                      by_bytes=self._n < self.total)
                if victim is None:
                    return [*refused, (peer, item)]
                refused.append((victim, self._pop_newest(victim)))
            q = self._queues.get(peer)
            if q is None:
                self._queues[peer] = deque((item,))
            else:
                q.append(item)
            self._n += 1
            self._bytes[peer] = self._bytes.get(peer, 0) + size
            self.nbytes += size
        self._tokens.put(None)
        return refused

    def _victim(self, peer: Hashable, mine: int, mine_bytes: int, known: bool, by_bytes: bool) -> Hashable | None:
        """Who gives way to `peer`, a newcomer holding `mine` items (and `mine_bytes` with its new one): None,
        nobody (the newcomer is refused)."""
        others = [p for p in self._queues if p != peer]
        strangers = [p for p in others if not self.known(p)] if known else []
        if by_bytes:
            biggest = max(strangers or others, key=lambda p: self._bytes.get(p, 0), default=None)
            fair = biggest is not None and self._bytes.get(biggest, 0) > mine_bytes
        else:
            biggest = max(strangers or others, key=lambda p: len(self._queues[p]), default=None)
            fair = biggest is not None and len(self._queues[biggest]) >= mine + 2
        return biggest if biggest is not None and (strangers or fair) else None

    def _pop_newest(self, peer: Hashable) -> Any:
        """(Under the lock.) Remove and return `peer`'s newest item."""
        q = self._queues[peer]
        item = q.pop()
        self._forget(peer, item)
        if not q:
            del self._queues[peer]
        return item

    def _forget(self, peer: Hashable, item: Any) -> None:
        """(Under the lock.) An item of `peer` left the queue: its count and bytes."""
        self._n -= 1
        size = self.size(item)
        self.nbytes -= size
        left = self._bytes.get(peer, 0) - size
        if left > 0:
            self._bytes[peer] = left
        else:
            self._bytes.pop(peer, None)

    def get(self, timeout: float | None = None) -> tuple[Hashable, Any] | None:
        """The next item in turn, (peer, item); None when closed, or after `timeout` with nothing."""
        deadline = None if timeout is None else clock.now() + timeout
        while True:
            try:
                self._tokens.get(timeout=None if deadline is None else max(deadline - clock.now(), 0.0))
            except queue.Empty:
                return None
            with self._lock:
                if self._closed:
                    self._tokens.put(None)  # for the next waiter
                    return None
                for peer, q in self._queues.items():  # the first in turn (if any)
                    item = q.popleft()
                    self._forget(peer, item)
                    if q:
                        self._queues.move_to_end(peer)  # its next item waits for everyone else's turn
                    else:
                        del self._queues[peer]
                    return peer, item
                # no item: the token of one that left otherwise

    def expire(self, older: Callable[[Any], bool]) -> list[tuple[Hashable, Any]]:
        """Remove and return the items for which `older(item)` is true (each peer's queue is in arrival
        order, so its expired items are at its front)."""
        out = []
        with self._lock:
            for peer in list(self._queues):
                q = self._queues[peer]
                while q and older(q[0]):
                    out.append((peer, q.popleft()))
                    self._forget(peer, out[-1][1])
                if not q:
                    del self._queues[peer]
        return out

    def drop(self, peer: Hashable) -> list[Any]:
        """Remove and return a peer's waiting items (it has left: its work is not done for nobody)."""
        with self._lock:
            q = self._queues.pop(peer, None) or deque()
            for item in q:
                self._forget(peer, item)
            return list(q)

    def close(self) -> list[tuple[Hashable, Any]]:
        """Refuse from now on and wake every waiting `get`; returns what was still waiting."""
        with self._lock:
            self._closed = True
            left = [(p, item) for p, q in self._queues.items() for item in q]
            self._queues.clear()
            self._bytes.clear()
            self._n = self.nbytes = 0
        self._tokens.put(None)
        return left
