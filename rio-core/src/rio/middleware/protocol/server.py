"""The protocol's server side for one node. An adapter (zmq, zenoh, portal) subclasses `NetworkServer`,
supplies the transport (`_open`, `_send`, `_broadcast`, `_shut`), hands every message it receives to
`on_message` with the peer it came from, and says `peer_gone` when a peer has left.

This class answers handshakes, takes requests (`RequestIntake`) and queues API calls fairly (`FairQueue`:
beyond `max_pending_per_peer` per peer or `max_pending` in all a call is answered TooManyCalls at once) for
one API thread. That thread runs no call whose caller has given up (it waited past `call_timeout`: running
it would only delay the calls behind it) nor those of a peer that has left. Samples are published with the
server's epoch and their sequence number, image fields compressed once when the node serves other machines
(`codecs`); heartbeats go out every `heartbeat_s` from a thread of their own,
so a client hears from a live server while the node publishes nothing or runs a slow call; a clean close
says BYE. An error reply carries the exception's type and message only (`wire.remote_error_payload`).
"""

from __future__ import annotations

import logging
import os
import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any, ClassVar

from rio import clock
from rio.middleware.protocol import messages as m
from rio.middleware.protocol.codecs import encoder_for
from rio.middleware.protocol.config import NetworkConfig, warn_if_exposed
from rio.middleware.protocol.fair import FairQueue
from rio.middleware.protocol.requests import RequestIntake
from rio.runtime import wire
from rio.runtime.buffers import RequestQueue, RingBuffer
from rio.runtime.node import Node
from rio.runtime.transport import NodeLayouts, ServerTransport

log = logging.getLogger("rio.middleware.protocol")

_KNOWN_MAX = 1024  # peers remembered as known (the most recently seen)


class NetworkServer(ServerTransport):
    mw: ClassVar[str] = "network"  # the middleware's name, for thread names and messages

    def __init__(self, node: Node, layouts: NodeLayouts, config: NetworkConfig):
        self.name, self.layouts, self.config = node.name, layouts, config
        self.max_message_bytes = config.message_limit(layouts)
        self._fp = layouts.data.fingerprint if layouts.data else 0
        self._epoch = int.from_bytes(os.urandom(4), "little")
        self._last: tuple[int, bytes] | None = None  # the newest sample (seq, record), for handshakes
        self._stream_lock = threading.Lock()  # the node loop, SDK callbacks and the heartbeat share the stream
        self.ring_buffer = RingBuffer(layouts.data, layouts.buffer_capacity, on_put=self._publish) \
            if layouts.data else None
        self.request_queue = RequestQueue(layouts.request, layouts.request_capacity) if layouts.request else None
        self._stop, self._wake = threading.Event(), threading.Event()
        self._known: OrderedDict[Hashable, None] = OrderedDict()  # peers that finished a handshake
        self._known_lock = threading.Lock()
        per, total = config.max_pending_per_peer, config.max_pending
        self._calls = FairQueue(per, total, self._knows)
        self._intake = RequestIntake(self.name, self.request_queue, self._ack, FairQueue(per, total, self._knows),
                                     self._wake.set)
        self._warn = m.Throttled(log)
        #: Compresses image fields once per sample when the node serves other machines (`codecs`).
        self.encoder = encoder_for(node, layouts.data, linked=bool(config.exposed()))
        self._threads: list[threading.Thread] = []
        self._dispatch: Callable[[str, list, dict], Any] | None = None
        self.closed = False

    # -- the adapter's part --------------------------------------------------------------------------
    def _open(self) -> dict[str, Any]:
        """Bind and start receiving; return the address clients connect to."""
        raise NotImplementedError

    def _send(self, peer: Hashable, kind: bytes, body: bytes, tag: Any = None) -> None:
        """One message to one peer, from any thread (`tag`: what came in with the message it answers)."""
        raise NotImplementedError

    def _broadcast(self, head: bytes, record: bytes | None) -> None:
        """A state-stream message (a header, and the record for STATE) to every client."""
        raise NotImplementedError

    def _shut(self, busy: bool) -> None:
        """Release the transport (`busy`: an API call still runs in its thread)."""

    def _spawn(self, target: Callable[[], None], what: str) -> None:
        t = threading.Thread(target=target, name=f"rio-{self.name}-{self.mw}-{what}", daemon=True)
        t.start()
        self._threads.append(t)

    # -- lifecycle -----------------------------------------------------------------------------------
    def start(self, dispatch: Any) -> dict[str, Any]:
        self._dispatch = dispatch
        warn_if_exposed(self.config, self.name, log)
        address = self._open()
        self._spawn(self._serve_calls, "api")
        self._spawn(self._service, "beat")
        return {**address, "heartbeat_s": self.config.heartbeat_s}

    def close(self) -> None:
        if self.closed:
            return
        self._send_control(m.BYE)  # clients learn at once instead of after their heartbeat timeout
        with self._stream_lock:
            self.closed = True
        self._stop.set()
        self._wake.set()
        self._calls.close()
        self._intake.close()
        for t in self._threads:
            t.join(timeout=2.0)
        busy = any(t.is_alive() for t in self._threads)
        if busy:
            log.warning("node '%s': an API call was still running at shutdown", self.name)
        self._shut(busy)

    # -- receiving -----------------------------------------------------------------------------------
    def on_message(self, peer: Hashable, kind: bytes, body: bytes | memoryview, tag: Any = None) -> None:
        """A message from `peer` (a transport thread): never blocks on the node."""
        if kind == m.CALL:
            refused = self._calls.put(peer, (body, clock.now(), tag))
            if refused is not None:
                self._too_many(*refused)
        elif kind == m.REQUEST and len(body) >= m.REQUEST_ID.size:
            self.take_request(peer, m.REQUEST_ID.unpack_from(body)[0], memoryview(body)[m.REQUEST_ID.size:], tag)
        elif kind == m.HELLO:
            self.vouch(peer)
            self._send(peer, m.HELLO, self.hello(), tag)
        else:  # a request without an id has nobody to answer
            self._warn("node '%s': ignored a message of kind %r from %r", self.name, kind, peer)

    def take_request(self, peer: Hashable, rid: int, record: memoryview, tag: Any = None) -> None:
        self._intake.take(peer, rid, record, tag)

    def peer_gone(self, peer: Hashable) -> None:
        """Its waiting calls and requests are not run nor queued for nobody."""
        self._calls.drop(peer)
        self._intake.drop(peer)

    def vouch(self, peer: Hashable, new: bool = True) -> None:
        """`peer` finished a handshake (`new`), or, known already, was served again: it outranks strangers."""
        with self._known_lock:
            if peer in self._known:
                self._known.move_to_end(peer)
            elif new:
                self._known[peer] = None
                if len(self._known) > _KNOWN_MAX:
                    self._known.popitem(last=False)

    def _knows(self, peer: Hashable) -> bool:
        return peer in self._known

    def hello(self) -> bytes:
        last = self._last
        return wire.pack({"protocol": m.VERSION, "node": self.name, "fingerprint": self.layouts.fingerprint(),
                          "epoch": self._epoch, "count": last[0] if last else 0, "newest": last[1] if last else None,
                          "heartbeat_s": self.config.heartbeat_s, "credits": self.config.max_pending_per_peer,
                          "coded": self.encoder is not None})

    def _ack(self, peer: Hashable, rid: int, status: int, a: Any, b: Any, tag: Any) -> None:
        if status == m.OK:
            self.vouch(peer, new=False)
        self._send(peer, m.ACK, m.pack_ack(rid, status, a, b), tag)

    def _too_many(self, peer: Hashable, item: tuple) -> None:
        per, total = self.config.max_pending_per_peer, self.config.max_pending
        self._warn("node '%s': refused an API call of %r: too many calls queued", self.name, peer)
        self._send(peer, m.REPLY, wire.pack_reply(m.call_id(item[0]), False, [
            "TooManyCalls", f"too many calls queued (at most {per} per client, {total} in all): try again later",
            ""]), item[2])

    # -- threads -------------------------------------------------------------------------------------
    def _serve_calls(self) -> None:
        """The API thread: calls in turn across peers, one at a time (the node's lock serializes them with
        its loop anyway), so a slow call delays calls only, never requests or the stream."""
        timeout = self.config.call_timeout
        while (got := self._calls.get()) is not None:
            peer, (body, t_in, tag) = got
            waited = clock.now() - t_in
            if waited > timeout:  # its caller has given up: say so (to nobody, usually) and move on
                log.debug("node '%s': skipped a call of %r that waited %.3g s", self.name, peer, waited)
                reply = wire.pack_reply(m.call_id(body), False, ["Skipped", f"not run: waited {waited:.3g} s, "
                                                                 f"past call_timeout ({timeout:.3g} s)", ""])
            else:
                reply = self._run(body)
                self.vouch(peer, new=False)
            try:
                self._send(peer, m.REPLY, reply, tag)
            except Exception:  # the transport is closing, or the peer has gone
                log.debug("node '%s': dropped an API reply to %r", self.name, peer, exc_info=True)

    def _run(self, body: bytes | memoryview) -> bytes:
        try:
            cid, method, args, kwargs = wire.unpack_call(body)
        except ValueError as e:  # cannot even tell which call: id -1 is never awaited
            return wire.pack_reply(-1, False, wire.remote_error_payload(e))
        assert self._dispatch is not None
        try:
            return wire.pack_reply(cid, True, self._dispatch(method, args, kwargs))
        except (Exception, SystemExit) as e:  # SystemExit from node code too: it must not end this thread
            log.debug("node '%s': call '%s' raised", self.name, method, exc_info=True)
            return wire.pack_reply(cid, False, wire.remote_error_payload(e))

    def _service(self) -> None:
        """Heartbeats every `heartbeat_s`, and waiting requests moved into the node's queue as it makes room."""
        period = self.config.heartbeat_s
        t_beat = clock.now() + period
        while not self._stop.is_set():
            self._wake.clear()
            wait = self._intake.feed()
            t = clock.now()
            if t >= t_beat:
                t_beat = t + period
                try:
                    self._send_control(m.BEAT)
                except Exception:  # keep beating: one failed send is no reason to look dead
                    log.exception("node '%s': heartbeat failed", self.name)
            self._wake.wait(min(wait, t_beat - t))

    # -- the state stream ----------------------------------------------------------------------------
    def _publish(self, rec: Any) -> None:
        """RingBuffer.on_put: send the new record right after it is stored (the node loop's thread)."""
        kind, data = (m.STATE, rec.tobytes()) if self.encoder is None else (m.CODED, self.encoder.encode(rec))
        with self._stream_lock:
            if not self.closed:
                seq = self.ring_buffer.count
                self._last = (seq, data)
                self._broadcast(m.STREAM_HEAD.pack(kind, self._fp, self._epoch, seq), data)

    def _send_control(self, kind: bytes) -> None:
        """A heartbeat (BEAT) or a goodbye (BYE) on the state stream."""
        with self._stream_lock:
            if not self.closed:
                seq = self._last[0] if self._last else 0
                self._broadcast(m.STREAM_HEAD.pack(kind, self._fp, self._epoch, seq), None)
