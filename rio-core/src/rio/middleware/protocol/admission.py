"""Who may hold a connection to a node, for transports whose peers are connections (portal): no peer, idle or
many, locks the others out.

A connection costs the server two threads and a slot, so there are only so many (`max_connections`, and
`max_connections_per_address` from one address). Before this, 32 idle TCP connections that never said a word
took every slot for as long as they stayed open, and the next client was told the node "is not running".
Now:

- a connection must finish the protocol's handshake within `handshake_timeout_s` (HELLO; or, for a plain
  portal client, a first call or request that was served: either *establishes* it), and an established one
  must send something at least every `idle_timeout_s` (a RIO client's long poll goes out every heartbeat) —
  else it is dropped, naming why;
- when the slots are full, a newcomer takes the slot of the oldest connection that has not finished its
  handshake (a stranger gives way to a newcomer, as in `fair`), first among its own address's, then among
  all; a real client finishes its handshake within milliseconds of connecting, so strangers cannot hold it up;
- a newcomer that can take no slot is refused with the reason, "too many connections", which its client
  reports as such (`rio.errors.TooManyConnections`), never as a node that is not running.

The transport asks `admit` for each new connection, drops what it is told to, says `heard` for every message
and `left` when a connection ends; the server says `established` (`NetworkServer.vouch`); `expired` (the
server's service thread) lists what to drop for silence.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Hashable
from dataclasses import dataclass
from typing import Any

from rio import clock


@dataclass
class _Conn:
    address: str
    t_open: float
    t_heard: float
    established: bool = False


class Admission:
    def __init__(self, node: str, config: Any):
        self.node = node
        self.max_total, self.max_per_address = config.max_connections, config.max_connections_per_address
        self.handshake_s, self.idle_s = config.handshake_timeout_s, config.idle_timeout_s
        self._conns: OrderedDict[Hashable, _Conn] = OrderedDict()  # oldest first
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self._conns)

    def admit(self, peer: Hashable, address: str) -> tuple[list[tuple[Hashable, str]], str | None]:
        """A new connection `peer` from `address`: (connections to drop to make room, each with why; the
        reason it is refused, or None when it is admitted and counted)."""
        now = clock.now()
        with self._lock:
            drop: list[tuple[Hashable, str]] = []
            mine = [p for p, c in self._conns.items() if c.address == address]
            if len(mine) >= self.max_per_address:
                stranger = self._oldest_stranger(mine)
                if stranger is None:
                    return [], (f"too many connections from {address} to node '{self.node}' ({len(mine)} open, at "
                                f"most {self.max_per_address} per address): close other clients of this node, or "
                                "raise max_connections_per_address in [middleware]")
                drop.append((stranger, "gave way to a newer connection (its handshake was not finished)"))
            if len(self._conns) - len(drop) >= self.max_total:
                stranger = self._oldest_stranger([p for p in self._conns if p not in dict(drop)])
                if stranger is None:
                    return [], (f"too many connections to node '{self.node}' ({len(self._conns)} open, at most "
                                f"{self.max_total}): close other clients of this node, or raise max_connections "
                                "in [middleware]")
                drop.append((stranger, "gave way to a newer connection (its handshake was not finished)"))
            for p, _ in drop:
                self._conns.pop(p, None)
            self._conns[peer] = _Conn(address, now, now)
            return drop, None

    def _oldest_stranger(self, peers: list[Hashable]) -> Hashable | None:
        return next((p for p in peers if not self._conns[p].established), None)  # `peers`: in connection order

    def established(self, peer: Hashable) -> None:
        """`peer` finished the handshake, or was served."""
        conn = self._conns.get(peer)
        if conn is not None:
            conn.established = True

    def heard(self, peer: Hashable) -> None:
        conn = self._conns.get(peer)
        if conn is not None:
            conn.t_heard = clock.now()

    def left(self, peer: Hashable) -> None:
        with self._lock:
            self._conns.pop(peer, None)

    def expired(self) -> list[tuple[Hashable, str]]:
        """Connections to drop now, each with why: no handshake within `handshake_timeout_s`, or, established, no
        message for `idle_timeout_s`. They are forgotten here (the transport closes them)."""
        now = clock.now()
        out = []
        with self._lock:
            for peer, c in list(self._conns.items()):
                if not c.established:
                    if now - c.t_open > self.handshake_s:
                        out.append((peer, f"no handshake within handshake_timeout_s ({self.handshake_s:g} s)"))
                elif now - c.t_heard > self.idle_s:
                    out.append((peer, f"silent for idle_timeout_s ({self.idle_s:g} s)"))
            for peer, _ in out:
                self._conns.pop(peer, None)
        return out
