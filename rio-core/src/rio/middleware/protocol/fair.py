"""Fair scheduling of work that peers send a node (API calls, requests waiting for room).

Each peer has its own queue, bounded (`per_peer`), and all queues together are bounded (`total`); work is
taken round-robin across peers, so one peer's flood waits behind its own work, never in front of another
peer's: with n peers waiting, a newcomer's item is taken within n turns. When the total bound is reached,
someone gives way (their newest item is refused) to the newcomer: a stranger (a peer `known` does not
vouch for: it never finished a handshake nor was served) to a known peer, else the peer holding the most
if it holds at least two more than the newcomer. So neither many flooding peers nor a swarm of made-up
ones keeps a real client out. Refused items go back to the caller, who answers them (TooManyCalls,
QueueFull): nothing is dropped without its sender hearing of it.
"""

from __future__ import annotations

import queue
import threading
from collections import OrderedDict, deque
from collections.abc import Callable, Hashable
from typing import Any

from rio import clock


class FairQueue:
    def __init__(self, per_peer: int, total: int, known: Callable[[Hashable], bool] = lambda peer: False):
        self.per_peer, self.total, self.known = per_peer, total, known
        self._queues: OrderedDict[Hashable, deque[Any]] = OrderedDict()  # in turn order
        self._n = 0
        self._closed = False
        self._lock = threading.Lock()
        #: One token per item queued (and one on close) wakes `get`: a SimpleQueue hands over ~2 us faster
        #: than a Condition. Tokens of items that left otherwise (refused, dropped) only cost a look.
        self._tokens: queue.SimpleQueue[None] = queue.SimpleQueue()

    def __len__(self) -> int:
        return self._n

    def put(self, peer: Hashable, item: Any) -> tuple[Hashable, Any] | None:
        """Queue `item` for `peer`; returns what was refused instead, (peer, item), or None."""
        with self._lock:
            q = self._queues.get(peer)
            mine = 0 if q is None else len(q)
            if mine >= self.per_peer or self._closed:
                return peer, item
            refused = None
            if self._n >= self.total:
                victim = self._victim(mine, self.known(peer))
                if victim is None:
                    return peer, item
                refused = victim, self._queues[victim].pop()
                self._n -= 1
                if not self._queues[victim]:
                    del self._queues[victim]
                q = self._queues.get(peer)
            if q is None:
                self._queues[peer] = deque((item,))
            else:
                q.append(item)
            self._n += 1
        self._tokens.put(None)
        return refused

    def _victim(self, mine: int, known: bool) -> Hashable | None:
        """Who gives way to a newcomer holding `mine` items (None: nobody, the newcomer is refused)."""
        strangers = [p for p in self._queues if not self.known(p)] if known else []
        biggest = max(strangers or self._queues, key=lambda p: len(self._queues[p]))
        return biggest if strangers or len(self._queues[biggest]) >= mine + 2 else None

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
                    self._n -= 1
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
                    self._n -= 1
                if not q:
                    del self._queues[peer]
        return out

    def drop(self, peer: Hashable) -> list[Any]:
        """Remove and return a peer's waiting items (it has left: its work is not done for nobody)."""
        with self._lock:
            q = self._queues.pop(peer, None) or deque()
            self._n -= len(q)
            return list(q)

    def close(self) -> list[tuple[Hashable, Any]]:
        """Refuse from now on and wake every waiting `get`; returns what was still waiting."""
        with self._lock:
            self._closed = True
            left = [(p, item) for p, q in self._queues.items() for item in q]
            self._queues.clear()
            self._n = 0
        self._tokens.put(None)
        return left
