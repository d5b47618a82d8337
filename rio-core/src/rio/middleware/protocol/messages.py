"""The protocol's messages: a kind (one byte) and a body. Transports carry the kind their own way (zmq as
the first byte of the frame, zenoh in the key expression, portal in the method name); the bodies are the
same everywhere. Nothing here is pickled: fixed binary headers, raw layout records, msgpack (`rio.runtime.wire`).

Client -> server, each answered to that client only:
- HELLO (empty) -> HELLO: msgpack map {protocol, node, fingerprint, epoch, count, newest, heartbeat_s,
  credits} (credits: the requests a client may have unacknowledged, `credits`).
- REQUEST: request id (u64) + one raw record of the node's request layout -> ACK: msgpack
  [id, status, a, b]: OK (a: free slots left), FULL (a, b: capacity, seconds waited), INVALID (a, b:
  field or None, problem). Nothing is dropped without its sender hearing why.
- CALL: `wire.pack_call` (call id first) -> REPLY: `wire.pack_reply` with the same id.

Server -> every client (the state stream): a 20-byte header (kind STATE / CODED / BEAT / BYE, data-layout
fingerprint u32, epoch u32, sequence number u64), then for STATE the record, for CODED the record with its
image fields compressed (`codecs`). The epoch is random per
server start, so a restarted server is a new server; sequence numbers only grow within one epoch.
"""

from __future__ import annotations

import logging
import struct
from typing import Any

import msgpack

from rio import clock
from rio.errors import InvalidRequest, QueueFull
from rio.runtime import wire

#: Checked at the handshake: a server of another version answers differently, or not at all.
VERSION = 4
HELLO, REQUEST, ACK, CALL, REPLY = b"h", b"r", b"a", b"c", b"y"
STATE, BEAT, BYE = b"S", b"H", b"B"
#: A state-stream sample whose image fields are compressed (`codecs`: one self-delimiting body).
CODED = b"Z"
STREAM_HEAD = struct.Struct("<c3xIIQ")
REQUEST_ID = struct.Struct("<Q")
OK, FULL, INVALID = 0, 1, 2


def pack_ack(rid: int, status: int, a: Any = None, b: Any = None) -> bytes:
    return wire.pack([rid, status, a, b])


def ack_error(node: str, ack: list) -> Exception | None:
    """The error a refused request stands for (None for OK): QueueFull / InvalidRequest naming the node."""
    status = ack[1]
    if status == OK:
        return None
    if status == FULL:
        return QueueFull(node, int(ack[2]), float(ack[3]))
    field = None if ack[2] is None else str(ack[2])
    return InvalidRequest(node, field, str(ack[3]) if status == INVALID else f"refused ({ack!r:.80})")


def call_id(body: bytes | memoryview) -> int:
    """The id of a call (its msgpack array's first element) without decoding its arguments; -1 (which no
    caller awaits) when the body is not a call."""
    try:
        unpacker = msgpack.Unpacker(max_buffer_size=len(body) + 1)
        unpacker.feed(body)
        unpacker.read_array_header()
        cid = unpacker.unpack()
    except Exception:
        return -1
    return cid if isinstance(cid, int) else -1


def error_fields(value: Any) -> tuple[str, str, str]:
    """(type, message, traceback) of an error reply, tolerating a malformed one."""
    if isinstance(value, list) and len(value) == 3:
        return str(value[0]), str(value[1]), str(value[2])
    return "RemoteError", str(value), ""


class Throttled:
    """A warning logged at most once per `period` s, debug otherwise: a flood must not flood the log."""

    def __init__(self, log: logging.Logger, period: float = 5.0):
        self.log, self.period, self._next = log, period, 0.0

    def __call__(self, msg: str, *args: Any) -> None:
        t = clock.now()
        if t >= self._next:
            self._next = t + self.period
            self.log.warning(msg, *args)
        else:
            self.log.debug(msg, *args)
