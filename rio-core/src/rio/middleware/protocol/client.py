"""The protocol's client side for one node. An adapter subclasses `NetworkClient`, supplies `_send(kind,
body)`, hands every answer (ACK, REPLY) to `_answered`, the server's HELLO answer to `_handshake` and every
state-stream message to `_on_stream`. This class does the rest:

- handshake: the protocol version and both layouts' fingerprints must match (else a ConfigError naming the
  node); the server's newest sample seeds the mirror, so the first read needs no wait.
- state stream: a sample enters the local mirror only if it is newer than the newest there (never
  backwards, never twice); one of another epoch means the server restarted: the node is gone for this client.
- liveness (`check_alive`, on every read): the server's process where the address shows it on this
  machine (exact, cheap); elsewhere any message counts, and `heartbeat_timeout` of silence reports the node
  dead by name, until the same server speaks again. BYE, an exit, another epoch or a lost link are final.
- calls, one at a time per client, each with a new id: answers of other ids (late replies of calls that
  timed out) are dropped. Requests: `CreditFlow` (`credits`): a send and no wait.
"""

from __future__ import annotations

import itertools
import logging
import queue
import threading
import time
from functools import partial
from typing import Any, ClassVar

import numpy as np

from rio import clock
from rio.errors import ConfigError, NodeDiedError, NodeError, NodeTimeout, RioError, TooManyConnections
from rio.middleware.protocol import messages as m
from rio.middleware.protocol.codecs import RecordDecoder
from rio.middleware.protocol.config import NetworkConfig
from rio.middleware.protocol.credits import CreditFlow, RequestStats
from rio.middleware.protocol.requests import ANSWER_TIMEOUT_S
from rio.runtime import wire
from rio.runtime.buffers import RequestSender, RingBuffer
from rio.runtime.node import Node
from rio.runtime.transport import ClientTransport, NodeLayouts, ProcessWatch, machine_id

log = logging.getLogger("rio.middleware.protocol")

#: How long one `_recv` waits at most: a waiting caller re-checks liveness this often.
POLL_S = 0.05


def local_process_watch(address: dict[str, Any], node: str) -> ProcessWatch | None:
    """A watch on the server process when the address says it runs where this client can see its
    pid (ServerManager stamps "pid" and "machine"); None means liveness must come from heartbeats."""
    if "pid" in address and address.get("machine") == machine_id():
        return ProcessWatch(int(address["pid"]), node)
    return None


class NetworkClient(ClientTransport):
    mw: ClassVar[str] = "network"

    def __init__(self, node: Node, layouts: NodeLayouts, address: dict[str, Any], config: NetworkConfig):
        self.name, self.layouts, self.config = node.name, layouts, config
        self._watch = local_process_watch(address, self.name)
        self._timeout = max(config.heartbeat_timeout, 5 * float(address.get("heartbeat_s", config.heartbeat_s)))
        self._last_heard = clock.now()
        #: Why the server is known to be gone for good (None while it is not).
        self._gone: str | None = None
        self._epoch: int | None = None  # set by the handshake; the stream is ignored before it
        self._seq = 0
        self._fp = layouts.data.fingerprint if layouts.data else 0
        self._foreign_warned = False
        self._stream_lock = threading.Lock()
        self._call_lock = threading.Lock()
        self._call_ids = itertools.count(1)  # next() is atomic under the GIL
        #: Decodes the samples a server sends compressed (`codecs`), made on the first one.
        self.decoder: RecordDecoder | None = None
        self.ring_buffer = RingBuffer(layouts.data, layouts.buffer_capacity) if layouts.data else None
        self.request_queue = RequestSender(layouts.request, self._send_request) if layouts.request else None
        #: Answers handed over by the adapter's receiving thread (`_answered`), taken by `_recv`.
        self._answers: dict[bytes, queue.SimpleQueue[Any]] = {m.ACK: queue.SimpleQueue(), m.REPLY: queue.SimpleQueue()}
        self._requests = CreditFlow(self.name, max(config.call_timeout, ANSWER_TIMEOUT_S),
                                    partial(self._send_parts, m.REQUEST), partial(self._recv_now, m.ACK),
                                    self.check_alive, recv_wait=partial(self._recv, m.ACK))

    # -- the adapter's part --------------------------------------------------------------------------
    def _send(self, kind: bytes, body: bytes) -> None:
        raise NotImplementedError

    def _answered(self, kind: bytes, answer: bytes | memoryview | Exception) -> None:
        """An answer of `kind` (ACK, REPLY) arrived, or the error that stands for it (the adapter's thread)."""
        self._answers[kind].put(answer)

    def _recv(self, kind: bytes, wait_s: float = POLL_S) -> bytes | memoryview | None:
        """The next answer of that kind, waiting at most `wait_s` (so a waiting caller looks at the server's
        liveness that often); None when none came. An adapter whose sockets keep the answers (zmq) reads
        them there instead."""
        try:
            got = self._answers[kind].get(timeout=wait_s) if wait_s else self._answers[kind].get_nowait()
        except queue.Empty:
            return None
        if isinstance(got, Exception):
            raise got
        return got

    def _send_parts(self, kind: bytes, *parts: bytes | memoryview) -> None:
        """Send one message of `kind` whose body is `parts` back to back (a request: its id, then its record).
        Joined here (one copy) for `_send`; an adapter that can pass the parts on with fewer copies overrides
        it (zmq: one join, handed to libzmq without another copy). A request record is a whole observation
        with its camera frames (megabytes): every copy on the way is paid in `send_request`."""
        self._send(kind, b"".join(parts))

    def _recv_now(self, kind: bytes) -> bytes | memoryview | None:
        """The next answer of that kind if one has arrived, else None at once (request acknowledgements are
        taken in this way: `send_request` never waits for the network)."""
        return self._recv(kind, 0.0)

    # -- liveness ------------------------------------------------------------------------------------
    def check_alive(self) -> None:
        if self._gone is not None:
            raise NodeDiedError(self.name, self._gone)
        if self._watch is not None:
            try:
                self._watch.check()
            except NodeDiedError as e:
                self._gone = e.detail
                raise
        elif clock.now() - self._last_heard > self._timeout:
            # Our own receiving thread may just not have run (this process was paused or busy): give it
            # a moment to take in what has already arrived before calling the server dead.
            t_end = clock.now() + 0.1
            while clock.now() < t_end and clock.now() - self._last_heard > self._timeout:
                time.sleep(0.005)
            silent = clock.now() - self._last_heard
            if silent > self._timeout:
                raise NodeDiedError(self.name, f"no heartbeat from its {self.mw} server for {silent:.2g} s")

    def _lose(self, why: str) -> None:
        """The server is gone for good (a lost connection, BYE): every later access says `why`."""
        if self._gone is None:
            self._gone = why

    def _heard(self) -> None:
        self._last_heard = clock.now()

    # -- handshake and state stream ------------------------------------------------------------------
    def _handshake(self, body: bytes | memoryview, where: str) -> None:
        try:
            hello = wire.unpack(body)
            version = hello.get("protocol")
        except (ValueError, AttributeError):
            hello, version = None, None
        if hello is not None and hello.get("refused"):  # the server runs, with no room for this connection
            raise TooManyConnections(self.name, where, str(hello["refused"]))
        if version != m.VERSION:
            raise ConfigError(f"node '{self.name}': its server at {where} speaks {self.mw} protocol {version}, "
                              f"this client {m.VERSION}: run the same rio version on both machines")
        theirs, ours = list(hello["fingerprint"]), self.layouts.fingerprint()
        if theirs != ours:
            raise ConfigError(f"node '{self.name}': layout mismatch with its server at {where} (node "
                              f"'{hello.get('node')}', fingerprints {theirs} vs ours {ours}); client and server "
                              "must build the node with the same class and config")
        with self._stream_lock:
            if self.ring_buffer is not None and hello["newest"] is not None:
                newest = hello["newest"]
                self.ring_buffer.put_bytes(self._decoded(newest) if hello.get("coded") else newest)
                self._seq = int(hello["count"])
            self._epoch = int(hello["epoch"])
        self._requests.grant(hello.get("credits"))
        self._heard()

    def _on_stream(self, head: bytes | memoryview, record: bytes | memoryview | None) -> None:
        """One state-stream message (the adapter's receiving thread)."""
        if len(head) != m.STREAM_HEAD.size or self._epoch is None:
            return
        kind, fp, epoch, seq = m.STREAM_HEAD.unpack(head)
        if epoch != self._epoch:
            self._lose("server restarted (connect again)")
            return
        self._heard()
        if kind == m.BYE:
            self._lose("server closed")
        elif kind in (m.STATE, m.CODED) and self.ring_buffer is not None and record is not None:
            if fp != self._fp:
                if not self._foreign_warned:
                    self._foreign_warned = True
                    log.warning("node '%s': dropping samples with a foreign layout", self.name)
                return
            with self._stream_lock:
                if seq <= self._seq:  # already seeded by the handshake, or out of order
                    return
                try:
                    self.ring_buffer.put_bytes(self._decoded(record) if kind == m.CODED else record)
                except (RioError, ValueError) as e:
                    log.warning("node '%s': dropped a sample: %s", self.name, e)
                    return
                self._seq = seq

    def _decoded(self, body: bytes | memoryview) -> bytearray:
        """A CODED sample's record (`codecs`), decoded once here, in the receiving thread."""
        if self.decoder is None:
            assert self.layouts.data is not None
            self.decoder = RecordDecoder(self.layouts.data)
        return self.decoder.decode(body)

    # -- calls and requests --------------------------------------------------------------------------
    def call(self, method: str, args: tuple, kwargs: dict) -> Any:
        timeout = self.config.call_timeout
        with self._call_lock:
            self.check_alive()
            cid = next(self._call_ids)
            self._send(m.CALL, wire.pack_call(cid, method, args, kwargs))
            deadline = None  # computed when first needed: the fast path is one send and one receive
            while True:
                body = self._recv(m.REPLY)
                if body is None:
                    self.check_alive()
                    deadline = deadline or clock.now() - POLL_S + timeout
                    if clock.now() > deadline:
                        raise NodeTimeout(self.name, f"API call {method}()", timeout)
                    continue
                rid, ok, value = wire.unpack_reply(body)
                if rid == cid:  # else the late reply of an earlier call that timed out
                    break
        if ok:
            return value
        raise NodeError(self.name, *m.error_fields(value))

    def _send_request(self, record: bytes | memoryview | np.ndarray) -> None:
        self._requests.send(record)

    def send_request_acknowledged(self, record: bytes, wait_s: float = ANSWER_TIMEOUT_S) -> None:
        """Send a request record and wait (up to `wait_s`) for the node's acknowledgement of it and of every
        earlier one: raises its refusal (InvalidRequest, QueueFull naming the node) as the blocking sends
        of protocol 3 did. For scripts and tests; a control loop uses `send_request`."""
        self._requests.send(record)
        self._requests.drain(wait_s)
        error = self._requests.take_error()
        if error is not None:
            raise error

    def request_stats(self, wait_s: float = 0.0) -> RequestStats:
        """This client's request counts (sent, acknowledged, refused, no credits), after taking in the
        acknowledgements that arrived (waiting up to `wait_s` for those in flight)."""
        return self._requests.drain(wait_s)

    def close(self) -> None:
        if self._watch is not None:
            self._watch.close()
            self._watch = None
