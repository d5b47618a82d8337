"""Request flow control by credits, the client's end: `send_request` costs a local check and one send,
never a network round trip.

The server grants each client a number of credits in its handshake (`hello["credits"]`: the requests it
takes from one peer without refusing any for lack of room: `max_pending_per_peer`, the waiting room the
fair queue keeps for each peer, see `requests.RequestIntake`). A request spends one credit; its
acknowledgement (OK, FULL or INVALID) gives it back. A client with no credit left fails at once with
`NoCredits` (a `QueueFull`): its node has `credits` of its requests not yet acknowledged, so it is not
keeping up, or the link is slow.

Nothing is lost silently: an acknowledgement that refuses a request (the node's queue stayed full for its
put timeout, or the node's own check found a bad field) is kept and raised, naming the node, by the next
`send_request` (before it sends anything: that request is not sent; the refusals since the last report are
raised as one, the oldest, the rest counted); a request without an acknowledgement after `timeout` is
reported the same way (NodeTimeout). Every refusal is also counted (`stats`), for the
run summary. Acknowledgements are taken in without waiting (`recv_now`) on every send and whenever
`drain` is called.
"""

from __future__ import annotations

import itertools
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from rio import clock
from rio.errors import NoCredits, NodeTimeout, RioError
from rio.middleware.protocol.messages import FULL, INVALID, OK, REQUEST_ID, Throttled, ack_error
from rio.runtime import wire

if TYPE_CHECKING:
    import numpy as np

log = logging.getLogger("rio.middleware.protocol")

#: Credits a client assumes when its server's handshake grants none (a server of protocol 3 and older
#: never refused a peer's first request for room).
DEFAULT_CREDITS = 1


@dataclass
class RequestStats:
    """Counts of one client's requests, for the run summary: none is lost without being counted here."""

    sent: int = 0
    acknowledged: int = 0
    refused_full: int = 0
    refused_invalid: int = 0
    no_credits: int = 0
    timed_out: int = 0

    @property
    def refused(self) -> int:
        return self.refused_full + self.refused_invalid + self.timed_out


class CreditFlow:
    def __init__(self, node: str, timeout: float, send: Callable[..., None],
                 recv_now: Callable[[], bytes | memoryview | None], alive: Callable[[], None],
                 credits: int = DEFAULT_CREDITS, recv_wait: Callable[[], bytes | memoryview | None] | None = None):
        self.node, self.timeout, self.credits = node, timeout, max(int(credits), 1)
        #: `send(*parts)`: one message whose body is the parts back to back (the request's id, its record),
        #: so the transport joins them once (a record can be megabytes: an observation with its frames).
        self._send, self._recv_now, self._alive = send, recv_now, alive
        #: Waits a little for the next acknowledgement (the transport's poll), for `drain`.
        self._recv_wait = recv_wait
        self._lock = threading.Lock()
        self._ids = itertools.count(1)
        self._in_flight: dict[int, float] = {}  # request id -> when it was sent (insertion = send order)
        self._errors: list[Exception] = []  # refusals not yet reported to the sender
        self.stats = RequestStats()
        self._warn = Throttled(log)

    def grant(self, credits: Any) -> None:
        """The server's grant (its handshake); a missing or malformed one keeps the default."""
        if isinstance(credits, int) and not isinstance(credits, bool) and credits >= 1:
            self.credits = credits

    @property
    def available(self) -> int:
        return self.credits - len(self._in_flight)

    def send(self, record: bytes | memoryview | np.ndarray) -> None:
        """Send one request record now, or raise: an earlier refusal (this one not sent), NoCredits, a dead
        node. Never waits for the network."""
        with self._lock:
            self._alive()
            self._take_acks()
            self._raise_earlier()
            if len(self._in_flight) >= self.credits:
                self.stats.no_credits += 1
                oldest = clock.now() - next(iter(self._in_flight.values()))
                raise NoCredits(self.node, self.credits, oldest)
            rid = next(self._ids)
            self._in_flight[rid] = clock.now()
            try:
                self._send(REQUEST_ID.pack(rid), record)
            except BaseException:
                del self._in_flight[rid]
                raise
            self.stats.sent += 1

    def drain(self, wait_s: float = 0.0) -> RequestStats:
        """Take in the acknowledgements that have arrived (waiting up to `wait_s` for those still in flight,
        e.g. before closing); refusals are kept for the next `send`. Returns the counts."""
        t_end = clock.now() + wait_s
        while True:
            with self._lock:
                self._take_acks()
                if not self._in_flight or clock.now() >= t_end:
                    return self.stats
                if self._recv_wait is not None:  # wakes as the acknowledgement arrives
                    body = self._recv_wait()
                    if body is not None:
                        self._take(body)
                    continue
            clock.precise_wait(min(t_end, clock.now() + 0.001))

    def take_error(self) -> Exception | None:
        """The oldest refusal not yet reported (forgetting all of them: see `_raise_earlier`), for a caller
        reporting it its own way."""
        with self._lock:
            self._take_acks()
            error = self._errors[0] if self._errors else None
            self._errors.clear()
            return error

    # -- inside the lock -----------------------------------------------------------------------------
    def _take(self, body: bytes | memoryview) -> None:
        try:
            ack = wire.unpack(body)
            rid, status = int(ack[0]), ack[1]
            error = ack_error(self.node, ack)
        except (ValueError, TypeError, IndexError, KeyError):
            self._warn("node '%s': ignored a malformed answer to a request", self.node)
            return
        if self._in_flight.pop(rid, None) is None:
            return  # a request already reported as timed out
        self.stats.acknowledged += 1
        if status == OK:
            return
        self.stats.refused_full += status == FULL
        self.stats.refused_invalid += status == INVALID or status not in (OK, FULL)
        self._errors.append(error if error is not None else RioError(f"node '{self.node}': request refused"))

    def _take_acks(self) -> None:
        while (body := self._recv_now()) is not None:
            self._take(body)
        if self._in_flight:
            t = clock.now()
            for rid, t_sent in list(self._in_flight.items()):
                if t - t_sent <= self.timeout:
                    break  # in send order: the rest are younger
                del self._in_flight[rid]
                self.stats.timed_out += 1
                self._errors.append(NodeTimeout(self.node, "a request's acknowledgement", self.timeout))

    def _raise_earlier(self) -> None:
        """Raise the oldest refusal not yet reported; it stands for all of them (the others are counted in
        `stats` and named in a note), so one stall costs the sender one error, not one per request."""
        if not self._errors:
            return
        error, more = self._errors[0], len(self._errors) - 1
        self._errors.clear()
        self._warn("node '%s': an earlier request was refused: %s", self.node, error)
        if hasattr(error, "add_note"):  # Python 3.11+
            error.add_note("(an earlier request's refusal, reported by the next send_request, which was not sent"
                           + (f"; {more} more refused since, counted in request_stats()" if more else "") + ")")
        raise error
