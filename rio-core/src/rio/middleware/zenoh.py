"""Zenoh middleware: a node reachable through eclipse-zenoh 1.x, on one machine or across many.

Key expressions, under `rio/<station>/<node>`:

- `state`        server -> clients: each new sample as the raw bytes of one layout record.
- `req/<cid>`    client `<cid>` -> server: a request: an 8-byte request id, then the raw bytes of one
                 record (re-checked there).
- `ack/<cid>`    server -> client `<cid>`: each request's answer (queued, queue full, invalid, takes no
                 requests), matched by request id: `send_request` waits for it, so nothing is dropped
                 silently. Answered from zenoh's callback thread (a full queue: from its own thread),
                 never behind an API call.
- `call/<cid>`   client `<cid>` -> server: an API call (`rio.runtime.wire`, msgpack; never pickle).
- `reply/<cid>`  server -> client `<cid>`: the reply, matched to its call by call id. An error carries
                 type and message only (`wire.remote_error_payload`); the traceback stays in the node's log.
- `hb`           server -> clients: a heartbeat every 50 ms, from its own thread.
- `hello`        queryable: layout fingerprints and the newest sample (the connect handshake).

Why pub/sub for API calls and requests rather than a queryable: measured here, a `call`/`reply`
publisher pair is ~45 us faster per half round trip than `Querier.get` + `Query.reply` with the same
payload (and ~50 us per request round trip).

Why the client waits for "matching" before relying on a publisher: zenoh silently drops what is put
before the peer's subscription has propagated, so every publisher whose first message matters
(requests, calls, replies) is only used once zenoh reports a matching subscriber. The state stream
may lose its first samples that way, which is why the handshake seeds the client's mirror.

With the station's keys (`keys`, `rio.machine.keys`) every link is mutual TLS (`tls/` endpoints only, the
station's CA on both sides) and zenoh's access control lets through only machines this one trusts
(their certificates' common names, `peers/`), only under `rio/<station>/**`: see `_secure`.

Sessions are heavy (their own links and routing tables), so clients in one process share one
session per set of endpoints (and keys), reference-counted and closed with the last client. The
lowlatency transport is deliberately not enabled: it has no fragmentation and silently drops large frames.
"""

from __future__ import annotations

import json
import logging
import os
import queue
import re
import socket
import struct
import threading
from collections import OrderedDict
from typing import TYPE_CHECKING, Any, Literal

from pydantic import model_validator

from rio import clock
from rio.errors import ConfigError, InvalidRequest, NodeDiedError, NodeError, NodeTimeout, QueueFull
from rio.runtime import wire
from rio.runtime.buffers import RequestQueue, RequestSender, RingBuffer
from rio.runtime.node import Node
from rio.runtime.transport import (
    ClientTransport,
    Middleware,
    NetworkConfig,
    NodeLayouts,
    ProcessWatch,
    ServerTransport,
    is_loopback,
    local_process_watch,
    warn_if_exposed,
)

if TYPE_CHECKING:
    from rio.machine.keys import MachineKeys
    from rio.station.model import MachineSection

log = logging.getLogger("rio.zenoh")

_HEARTBEAT_S = 0.05  # server heartbeat period
_LIVENESS_POLL_S = 0.05  # a waiting call re-checks liveness at least this often
_REPLY_PUBS_MAX = 64  # reply publishers a server keeps declared (one per recent client)
# How long a first reply waits for the client's reply subscription to be known here. The client
# declares it before its handshake, so it is normally known already; a client that has left since
# its call must not stall the API thread for long.
_REPLY_MATCH_WAIT_S = 0.5
_CID = re.compile(r"^[0-9a-f]{1,32}$")
#: Calls waiting for the API thread; beyond this a call is dropped (a flood must not grow the node).
_CALLS_MAX = 256
#: Clients whose reply subscription is not known here yet (their calls wait, the API thread does not),
#: and calls each may have waiting. A flood of calls on made-up client ids fills these and is dropped.
_PARKED_CLIENTS_MAX = 16
_PARKED_CALLS_MAX = 8
#: A request's id, before the record's bytes; its answer on `ack/<cid>` is `[id, status, a, b]`.
_REQ_ID = struct.Struct("<Q")
_ACK_OK, _ACK_FULL, _ACK_INVALID = 0, 1, 2  # b: -; a, b: capacity, seconds; a, b: field, problem
#: How long a request waits for room in a full queue before the client hears QueueFull (what a
#: shared-memory sender waits: `RequestQueue`'s default put timeout).
_REQ_PUT_TIMEOUT_S = 1.0
#: Requests waiting for room in a full queue; beyond this one is answered QueueFull at once.
_FULL_WAITING_MAX = 256


def _zenoh() -> Any:
    """Import zenoh on first use, so `import rio.middleware.zenoh` stays cheap and optional."""
    try:
        import zenoh
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError(
            "the 'zenoh' middleware needs eclipse-zenoh: pip install 'rio-core[zenoh]'"
        ) from e
    return zenoh


def _config(mode: str, listen: list[str], connect: list[str], connect_timeout: float,
            keys: MachineKeys | None = None, station: str = "", max_message: int | None = None) -> Any:
    """A session config with scouting off: RIO always knows whom to connect to, and multicast or
    gossip discovery would reach beyond loopback and across unrelated stations. With `keys`: mutual
    TLS and access control for `station` (`_secure`)."""
    z = _zenoh()
    c = z.Config()
    c.insert_json5("mode", json.dumps(mode))
    c.insert_json5("scouting/multicast/enabled", "false")
    c.insert_json5("scouting/gossip/enabled", "false")
    # Zenoh's shared-memory transport leaves segments in /dev/shm after a SIGKILL (RIO promises to
    # leave nothing behind); loopback TCP is what every measurement here was taken with.
    c.insert_json5("transport/shared_memory/enabled", "false")
    c.insert_json5("listen/endpoints", json.dumps(listen))
    c.insert_json5("connect/endpoints", json.dumps(connect))
    if connect:  # fail at open with a clear error instead of retrying silently in the background
        c.insert_json5("connect/exit_on_failure", "true")
        c.insert_json5("connect/timeout_ms", str(int(connect_timeout * 1000)))
    if max_message is not None:  # a node's session: zenoh refuses a bigger message before reassembling it
        c.insert_json5("transport/link/rx/max_message_size", str(max_message))
    if keys is not None:
        _secure(c, keys, station)
    return c


#: What RIO's traffic is made of, in zenoh's access-control terms (no deletes, no liveliness).
_ACL_MESSAGES = ["put", "declare_subscriber", "query", "declare_queryable", "reply"]


def _secure(c: Any, keys: MachineKeys, station: str) -> None:
    """Mutual TLS on every link, and access control: only machines this one trusts, only RIO's keys
    (`secure_links` for RIO's message kinds under `rio/<station>/**`)."""
    secure_links(c, keys, [f"rio/{station}/**"], _ACL_MESSAGES)


def secure_links(c: Any, keys: MachineKeys, key_exprs: list[str], messages: list[str]) -> None:
    """Make zenoh config `c` authenticate and encrypt every link with `keys`, and let through only
    `messages` under `key_exprs`, to and from machines this one trusts. Also what other zenoh users of a
    station's keys build on (the ROS 2 bridge: its domain's key expressions).

    - `transport/link/protocols = ["tls"]`: no other kind of link is opened or accepted (a `tcp/` peer
      cannot even connect).
    - `transport/link/tls`: the station's CA is the only root (`root_ca_certificate`), this machine's
      certificate and key for both directions (`listen_*`, `connect_*`), `enable_mtls`: each side proves
      itself. `verify_name_on_connect` is off: clients connect to whatever address a node advertises (an
      IP, this machine's host name for a wildcard bind) and a certificate names only the machine, localhost,
      127.0.0.1 and the addresses given to `rio keys generate`, so checking names would refuse working
      stations (measured: connecting by an address not in the certificate fails). What authenticates is
      the private CA plus the common-name access control below, not the address.
    - `access_control`: deny by default; allow, in both directions, `messages` under `key_exprs`, only to
      and from peers whose certificate common name is one of this machine's trusted machines (`peers/`).
      A certificate from the station's CA for a machine since removed from `peers/` connects but sees and
      sends nothing.
    """
    tls = {"root_ca_certificate": str(keys.ca), "enable_mtls": True, "verify_name_on_connect": False,
           "listen_certificate": str(keys.tls_cert), "listen_private_key": str(keys.tls_key),
           "connect_certificate": str(keys.tls_cert), "connect_private_key": str(keys.tls_key)}
    acl = {
        "enabled": True,
        "default_permission": "deny",
        "rules": [{"id": "rio", "permission": "allow", "flows": ["ingress", "egress"], "messages": list(messages),
                   "key_exprs": list(key_exprs)}],
        "subjects": [{"id": "trusted", "cert_common_names": sorted(keys.peers)}],
        "policies": [{"id": "trusted", "rules": ["rio"], "subjects": ["trusted"]}],
    }
    c.insert_json5("transport/link/protocols", json.dumps(["tls"]))
    c.insert_json5("transport/link/tls", json.dumps(tls))
    c.insert_json5("access_control", json.dumps(acl))


def tls_endpoints(endpoints: list[str]) -> list[str]:
    """With keys every link is TLS: `tcp/host:port` is reached (or listened on) as `tls/host:port`."""
    return [f"tls/{e.split('/', 1)[1]}" if _proto(e) == "tcp" else e for e in endpoints]


def _free_port(host: str) -> int:
    """A currently free TCP port (zenoh cannot report the port it picked for `:0`)."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def _endpoint(host: str, port: int, proto: str = "tcp") -> str:
    h = host.strip("[]")
    return f"{proto}/[{h}]:{port}" if ":" in h else f"{proto}/{host}:{port}"


def _proto(endpoint: str) -> str:
    return endpoint.split("/", 1)[0] if "/" in endpoint else ""


_tls = tls_endpoints


# -- shared client sessions --------------------------------------------------------------------------
class _Sessions:
    """One zenoh session per set of endpoints in this process, closed when its last user leaves."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._open: dict[tuple[str, ...], list[Any]] = {}  # endpoints (+ keys) -> [session, refcount]

    def acquire(self, endpoints: list[str], timeout: float, keys: MachineKeys | None = None,
                station: str = "") -> tuple[tuple[str, ...], Any]:
        eps = tuple(sorted(endpoints))
        # a keyed session is also bound to its keys and its station (its access control names both)
        key = eps if keys is None else (*eps, f"keys={keys.dir}", f"station={station}")
        with self._lock:
            entry = self._open.get(key)
            if entry is None or entry[0].is_closed():
                entry = [_zenoh().open(_config("peer", [], list(eps), timeout, keys, station)), 0]
                self._open[key] = entry
            entry[1] += 1
            return key, entry[0]

    def release(self, key: tuple[str, ...]) -> None:
        with self._lock:
            entry = self._open.get(key)
            if entry is None:
                return
            entry[1] -= 1
            if entry[1] <= 0:
                del self._open[key]
                _close(entry[0])


_SESSIONS = _Sessions()


def _error_fields(value: Any) -> tuple[str, str, str]:
    """(type, message, traceback) of an error reply, tolerating a malformed one."""
    if isinstance(value, list) and len(value) == 3:
        return str(value[0]), str(value[1]), str(value[2])
    return "RemoteError", str(value), ""


def _close(session: Any) -> None:
    """Close a session; one whose link is gone (a pulled cable) can only time out: that is no error
    of the caller's (who is usually already reporting the lost node)."""
    try:
        session.close()
    except Exception as e:
        log.debug("zenoh session close: %s", e)


def _undeclare(*entities: Any) -> None:
    for e in entities:
        if e is not None:
            try:
                e.undeclare()
            except Exception:  # already gone with a closed session
                pass


# -- server ------------------------------------------------------------------------------------------
class ZenohServer(ServerTransport):
    """Runs in the node's process: publishes samples, feeds requests to the queue, answers calls."""

    def __init__(self, prefix: str, layouts: NodeLayouts, config: ZenohConfig, station: str = ""):
        z = _zenoh()
        self.prefix, self.layouts, self.config, self.station = prefix, layouts, config, station
        self._keys = config.machine_keys()
        self._max_message = config.message_limit(layouts)
        self._closed = threading.Event()
        self.session, self.endpoints = self._open_session()
        cc, prio = z.CongestionControl, z.Priority
        # State: DROP, so a slow or stuck subscriber never stalls the node loop (newest wins anyway).
        self._state_pub = self.session.declare_publisher(
            f"{prefix}/state", congestion_control=cc.DROP, priority=prio.DATA)
        # Heartbeat: top priority, so it overtakes queued frames and never looks like a dead server.
        self._hb_pub = self.session.declare_publisher(
            f"{prefix}/hb", congestion_control=cc.DROP, priority=prio.REAL_TIME)
        self.ring_buffer = (RingBuffer(layouts.data, layouts.buffer_capacity, on_put=self._send_state)
                            if layouts.data is not None else None)
        # Never waits when full (put_timeout 0): a zenoh callback thread must not stall; a request that
        # finds the queue full waits for room in `_retry_full`'s thread instead.
        self.request_queue = (RequestQueue(layouts.request, layouts.request_capacity, put_timeout=0.0)
                              if layouts.request is not None else None)
        self._full: queue.SimpleQueue[tuple[str, int, bytes, float] | None] = queue.SimpleQueue()
        self.requests_refused = 0
        self._calls: queue.SimpleQueue[tuple[str, bytes, float] | None] = queue.SimpleQueue()
        self._reply_pubs: OrderedDict[str, Any] = OrderedDict()
        #: cid -> (its reply publisher, until when to wait for its subscription, its waiting calls)
        self._parked: dict[str, tuple[Any, float, list[bytes]]] = {}
        self.calls_dropped = 0
        self._listening: set[str] = set()  # clients whose reply subscription was seen (read by _on_call)
        self._subs: list[Any] = []
        self._threads: list[threading.Thread] = []
        self.dispatch: Any = None

    def _open_session(self) -> tuple[Any, list[str]]:
        o, keys = self.config, self._keys
        connect, proto = (list(o.connect), "tcp") if keys is None else (_tls(o.connect), "tls")
        if o.mode == "client":
            if not connect:
                raise ConfigError("zenoh middleware: mode 'client' needs at least one router in 'connect'")
            return _zenoh().open(_config("client", [], connect, o.connect_timeout, keys, self.station,
                                         self._max_message)), connect
        for attempt in range(5):  # a port picked free may be taken before zenoh binds it
            port = o.port if o.port is not None else _free_port(o.host)
            try:
                session = _zenoh().open(_config("peer", [_endpoint(o.host, port, proto)], connect,
                                                o.connect_timeout, keys, self.station, self._max_message))
            except Exception:
                if o.port is not None or attempt == 4:
                    raise
                continue
            return session, [_endpoint(self._advertised_host(), port, proto)]
        raise AssertionError("unreachable")

    def _advertised_host(self) -> str:
        """What clients connect to: the bound host, or this machine's name for a wildcard bind."""
        host = self.config.host
        return socket.getfqdn() if host.strip("[]") in ("0.0.0.0", "::", "") else host

    # -- hot paths (node loop thread / zenoh callback threads) -------------------------------------
    def _send_state(self, rec: Any) -> None:
        try:
            self._state_pub.put(rec.tobytes())
        except Exception:
            if not self._closed.is_set():
                raise

    def _on_request(self, sample: Any) -> None:
        """Queue a request and answer its sender at once (zenoh's callback thread, never the API
        thread): queued, invalid, or, when the queue is full, from `_retry_full` once it has room or
        after `_REQ_PUT_TIMEOUT_S`. Nothing is dropped without its sender hearing of it."""
        cid = str(sample.key_expr).rsplit("/", 1)[-1]
        data = sample.payload.to_bytes()
        if not _CID.match(cid) or len(data) < _REQ_ID.size:
            return  # nobody to answer
        rid = _REQ_ID.unpack_from(data)[0]
        rq = self.request_queue
        if rq is None:
            self._refuse(cid, rid, _ACK_INVALID, None, "the node takes no requests")
            return
        try:
            rq.put_bytes(memoryview(data)[_REQ_ID.size:])
        except InvalidRequest as e:
            self._refuse(cid, rid, _ACK_INVALID, e.field, e.problem)
        except QueueFull:
            if self._full.qsize() >= _FULL_WAITING_MAX:
                self._refuse(cid, rid, _ACK_FULL, rq.capacity, _REQ_PUT_TIMEOUT_S)
            else:
                self._full.put((cid, rid, data, clock.now() + _REQ_PUT_TIMEOUT_S))
        else:
            self._ack(cid, [rid, _ACK_OK])

    def _retry_full(self) -> None:
        """Requests that found the queue full wait here for room, oldest first, each at most
        `_REQ_PUT_TIMEOUT_S` from its arrival; then their senders hear queued or QueueFull."""
        rq = self.request_queue
        while True:
            item = self._full.get()
            if item is None or rq is None:
                return
            cid, rid, data, until = item
            while True:
                try:
                    rq.put_bytes(memoryview(data)[_REQ_ID.size:])
                except QueueFull:
                    if clock.now() > until or self._closed.is_set():
                        self._refuse(cid, rid, _ACK_FULL, rq.capacity, _REQ_PUT_TIMEOUT_S)
                        break
                    self._closed.wait(0.0005)
                except InvalidRequest as e:  # checked on arrival already; kept for safety
                    self._refuse(cid, rid, _ACK_INVALID, e.field, e.problem)
                    break
                else:
                    self._ack(cid, [rid, _ACK_OK])
                    break

    def _refuse(self, cid: str, rid: int, status: int, a: Any, b: Any) -> None:
        self.requests_refused += 1
        if self.requests_refused & (self.requests_refused - 1) == 0:  # 1st, 2nd, 4th...: a flood logs little
            what = "queue full" if status == _ACK_FULL else f"invalid: {a}: {b}"
            log.warning("node '%s': refused a request of client %s (%s; %d refused so far)", self.layouts.name,
                        cid, what, self.requests_refused)
        self._ack(cid, [rid, status, a, b])

    def _ack(self, cid: str, answer: list[Any]) -> None:
        """A request's answer. `session.put` rather than a publisher per client: nothing to keep per
        client (a flood of made-up client ids costs no state) for ~3 us more; it is routed to the
        client's `ack` subscription, which reached here before its request did (same link, in order)."""
        z = _zenoh()
        try:
            self.session.put(f"{self.prefix}/ack/{cid}", wire.pack(answer),
                             congestion_control=z.CongestionControl.BLOCK, priority=z.Priority.INTERACTIVE_HIGH)
        except Exception:
            if not self._closed.is_set():
                log.exception("node '%s': could not answer a request", self.layouts.name)

    def _on_call(self, sample: Any) -> None:
        cid = str(sample.key_expr).rsplit("/", 1)[-1]
        if not _CID.match(cid):
            return
        waiting = self._calls.qsize()  # a client known to listen for replies gets room a flood cannot take
        if waiting >= (4 * _CALLS_MAX if cid in self._listening else _CALLS_MAX):
            self._drop(f"{waiting} calls already wait")
            return
        self._calls.put((cid, sample.payload.to_bytes(), clock.now()))

    def _drop(self, why: str) -> None:
        self.calls_dropped += 1
        if self.calls_dropped & (self.calls_dropped - 1) == 0:  # 1st, 2nd, 4th, 8th...: a flood logs little
            log.warning("node '%s': dropped an API call (%s; %d dropped so far)", self.layouts.name, why,
                        self.calls_dropped)

    def _on_hello(self, query: Any) -> None:
        rb = self.ring_buffer
        newest = rb.get_record().tobytes() if rb is not None and rb.count > 0 else None
        query.reply(f"{self.prefix}/hello", wire.pack([self.layouts.fingerprint(), newest]))

    # -- threads -----------------------------------------------------------------------------------
    def _serve_calls(self) -> None:
        """API calls run here, not in zenoh's callback thread: a slow method must not hold up the
        delivery of requests (measured cost of the hand-off: ~10 us). A call from a client whose reply
        subscription is not known here yet waits aside (`_parked`) while other clients' calls run: a client
        that never listens (gone, or made up by a flood) costs the thread nothing."""
        while True:
            try:
                item = self._calls.get(timeout=0.005 if self._parked else None)
            except queue.Empty:
                item = ("", b"", 0.0)  # only look at the parked clients again
            if item is None:
                return
            cid, data, t_queued = item
            if cid and clock.now() - t_queued > self.config.call_timeout:
                # its caller has given up (NodeTimeout): running it would only delay the calls behind it
                log.debug("node '%s': skipped a call that waited past call_timeout", self.prefix)
            elif cid:
                self._take(cid, data)
            if self._parked:
                self._unpark()

    def _take(self, cid: str, data: bytes) -> None:
        pub = self._reply_pubs.get(cid)
        if pub is not None:
            self._reply_pubs.move_to_end(cid)
            self._run(pub, data)
            return
        parked = self._parked.get(cid)
        if parked is not None:
            if len(parked[2]) >= _PARKED_CALLS_MAX:
                self._drop(f"client {cid} has {_PARKED_CALLS_MAX} calls waiting")
            else:
                parked[2].append(data)
            return
        if len(self._parked) >= _PARKED_CLIENTS_MAX:
            self._drop(f"{_PARKED_CLIENTS_MAX} clients not yet listening for replies")
            return
        z = _zenoh()
        pub = self.session.declare_publisher(
            f"{self.prefix}/reply/{cid}", congestion_control=z.CongestionControl.BLOCK,
            priority=z.Priority.INTERACTIVE_HIGH)
        self._parked[cid] = (pub, clock.now() + _REPLY_MATCH_WAIT_S, [data])
        self._unpark()

    def _unpark(self) -> None:
        """Run the waiting calls of clients now listening for replies; give up on those past their wait."""
        now = clock.now()
        for cid, (pub, until, calls) in list(self._parked.items()):
            if pub.matching_status.matching:
                del self._parked[cid]
                self._reply_pubs[cid] = pub
                self._listening.add(cid)
                if len(self._reply_pubs) > _REPLY_PUBS_MAX:
                    old_cid, old_pub = self._reply_pubs.popitem(last=False)
                    self._listening.discard(old_cid)
                    _undeclare(old_pub)
                for data in calls:
                    self._run(pub, data)
            elif now > until or self._closed.is_set():
                del self._parked[cid]
                _undeclare(pub)
                log.warning("node '%s': client %s does not listen for replies; %d call(s) not run",
                            self.layouts.name, cid, len(calls))

    def _run(self, pub: Any, data: bytes) -> None:
        try:
            call_id, method, args, kwargs = wire.unpack_call(data)
        except Exception as e:
            log.warning("node '%s': dropped a malformed API call: %s", self.layouts.name, e)
            return
        try:
            reply = wire.pack_reply(call_id, True, self.dispatch(method, args, kwargs))
        except Exception as e:  # the client may be another machine: type and message only, no paths
            log.debug("node '%s': API call %s() raised", self.layouts.name, method, exc_info=True)
            reply = wire.pack_reply(call_id, False, wire.remote_error_payload(e))
        try:
            pub.put(reply)
        except Exception:  # keep answering other calls
            if not self._closed.is_set():
                log.exception("node '%s': could not send an API reply", self.layouts.name)

    def _beat(self) -> None:
        while not self._closed.wait(_HEARTBEAT_S):
            try:
                self._hb_pub.put(b"")
            except Exception:
                if not self._closed.is_set():
                    log.exception("node '%s': heartbeat failed", self.layouts.name)

    def start(self, dispatch: Any) -> dict[str, Any]:
        self.dispatch = dispatch
        warn_if_exposed(self.config, self.layouts.name, log)
        s, p = self.session, self.prefix
        self._subs.append(s.declare_subscriber(f"{p}/req/*", self._on_request))  # also to say "no requests"
        self._subs.append(s.declare_subscriber(f"{p}/call/*", self._on_call))
        self._subs.append(s.declare_queryable(f"{p}/hello", self._on_hello))
        threads = [(self._serve_calls, "api"), (self._beat, "heartbeat")]
        if self.request_queue is not None:
            threads.append((self._retry_full, "requests"))
        for target, what in threads:
            t = threading.Thread(target=target, name=f"rio-{self.layouts.name}-zenoh-{what}", daemon=True)
            t.start()
            self._threads.append(t)
        return {"prefix": p, "endpoints": self.endpoints}

    def close(self) -> None:
        if self._closed.is_set():
            return
        self._closed.set()
        self._calls.put(None)
        self._full.put(None)
        for t in self._threads:
            t.join(timeout=2.0)
        _undeclare(*self._subs, *self._reply_pubs.values(), *(p[0] for p in self._parked.values()), self._state_pub,
                   self._hb_pub)
        self._subs.clear()
        self._reply_pubs.clear()
        _close(self.session)


# -- client ------------------------------------------------------------------------------------------
class ZenohClient(ClientTransport):
    """A local mirror of the node's ring buffer, a request sender and remote calls, over zenoh."""

    def __init__(self, node: Node, layouts: NodeLayouts, address: dict[str, Any], config: ZenohConfig,
                 station: str = ""):
        self.name, self.config, self.station = node.name, config, station
        self._closed = False
        self._session_key: tuple[str, ...] | None = None
        self._entities: list[Any] = []
        self._watch: ProcessWatch | None = None
        try:
            self.prefix = str(address["prefix"])
            endpoints = list(address["endpoints"])
        except (KeyError, TypeError) as e:
            raise ConfigError(f"node '{self.name}': zenoh address lacks {e} (got {address!r})") from None
        keys = config.machine_keys()
        self._check_security(endpoints, keys is not None)
        try:
            self._open(layouts, address, endpoints, keys)
        except BaseException:
            self.close()
            raise

    def _check_security(self, endpoints: list[str], keyed: bool) -> None:
        """A keyed node is reached only with keys, and keys are never used on an unauthenticated link:
        a mismatch is a station-file error, said at once (not a connect timeout)."""
        tls = [_proto(e) == "tls" for e in endpoints]
        if not keyed and any(tls):
            raise ConfigError(f"node '{self.name}' serves over mutual TLS ({', '.join(endpoints)}): this client "
                              "needs the station's keys (keys = \"...\" in [middleware], this machine's "
                              "directory made by `rio keys generate`)")
        if keyed and not all(tls):
            raise ConfigError(f"node '{self.name}' serves without authentication ({', '.join(endpoints)}) but "
                              "this client has the station's keys: start the node with the same keys "
                              "(the station file's [middleware] keys)")

    def _open(self, layouts: NodeLayouts, address: dict[str, Any], endpoints: list[str],
              keys: MachineKeys | None) -> None:
        z = _zenoh()
        o, p = self.config, self.prefix
        self._watch = local_process_watch(address, self.name)
        try:
            self._session_key, self.session = _SESSIONS.acquire(endpoints, o.connect_timeout, keys, self.station)
        except Exception as e:
            why = (" (with keys: is this machine's certificate from the node's station CA, and does the node's "
                   "machine trust it?)" if keys is not None else "")
            raise NodeDiedError(self.name, f"cannot reach zenoh endpoints {endpoints}: {e}{why}") from None
        self._last_seen = clock.now()
        self._mirror_lock = threading.Lock()
        self.ring_buffer = RingBuffer(layouts.data, layouts.buffer_capacity) if layouts.data is not None else None
        declare = self._declare
        if self.ring_buffer is not None:
            declare(self.session.declare_subscriber(f"{p}/state", self._on_state))
        if self._watch is None:
            declare(self.session.declare_subscriber(f"{p}/hb", self._on_heartbeat))
        cid = os.urandom(8).hex()
        self._replies: queue.SimpleQueue[bytes] = queue.SimpleQueue()
        self._acks: queue.SimpleQueue[bytes] = queue.SimpleQueue()
        declare(self.session.declare_subscriber(f"{p}/reply/{cid}", self._on_reply))
        cc, prio = z.CongestionControl, z.Priority
        # BLOCK: a request or call is never dropped silently; zenoh keeps one publisher's order.
        self._call_pub = declare(self.session.declare_publisher(
            f"{p}/call/{cid}", congestion_control=cc.BLOCK, priority=prio.INTERACTIVE_HIGH))
        self._req_pub = None
        self.request_queue = None
        if layouts.request is not None:
            declare(self.session.declare_subscriber(f"{p}/ack/{cid}", self._on_ack))
            self._req_pub = declare(self.session.declare_publisher(
                f"{p}/req/{cid}", congestion_control=cc.BLOCK, priority=prio.INTERACTIVE_HIGH))
            self.request_queue = RequestSender(layouts.request, self._send_request)
        self._call_lock = threading.Lock()
        self._call_id = 0
        self._req_lock = threading.Lock()
        self._req_id = 0
        self._handshake(layouts)
        for pub in (self._call_pub, self._req_pub):
            if pub is not None:
                self._wait_matching(pub, str(pub.key_expr))
        self._last_seen = clock.now()

    def _declare(self, entity: Any) -> Any:
        self._entities.append(entity)
        return entity

    def _wait_matching(self, entity: Any, what: str) -> None:
        """Block until the server's side of `entity` is known here (else the first messages vanish)."""
        deadline = clock.now() + self.config.connect_timeout
        while not entity.matching_status.matching:
            if self._watch is not None:
                self._watch.check()
            if clock.now() > deadline:
                raise NodeDiedError(self.name, f"no zenoh server answers on '{what}' "
                                               f"after {self.config.connect_timeout:.3g} s")
            clock.precise_wait(clock.now() + 0.001)

    def _handshake(self, layouts: NodeLayouts) -> None:
        """Check the layouts match the server's and seed the mirror with its newest sample."""
        key = f"{self.prefix}/hello"
        querier = self._declare(self.session.declare_querier(key, timeout=self.config.connect_timeout))
        self._wait_matching(querier, key)
        try:
            reply = querier.get().recv()
            fingerprint, newest = wire.unpack(reply.ok.payload.to_bytes())
        except Exception as e:
            raise NodeDiedError(self.name, f"no handshake reply from the zenoh server: {e}") from None
        _undeclare(querier)
        self._entities.remove(querier)
        if list(fingerprint) != layouts.fingerprint():
            raise ConfigError(
                f"node '{self.name}': the client's data/request layouts do not match the server's "
                f"(fingerprints {layouts.fingerprint()} vs {list(fingerprint)}); build the client with "
                "the same node class and config as the server")
        if newest is not None and self.ring_buffer is not None:
            with self._mirror_lock:
                if self.ring_buffer.count == 0:  # a streamed sample that already arrived is newer
                    self.ring_buffer.put_bytes(newest)

    # -- zenoh callback threads --------------------------------------------------------------------
    def _on_state(self, sample: Any) -> None:
        data = sample.payload.to_bytes()
        with self._mirror_lock:
            self._last_seen = clock.now()
            try:
                self.ring_buffer.put_bytes(data)
            except InvalidRequest as e:
                log.warning("%s", e)

    def _on_heartbeat(self, sample: Any) -> None:
        self._last_seen = clock.now()

    def _on_reply(self, sample: Any) -> None:
        self._replies.put(sample.payload.to_bytes())

    def _on_ack(self, sample: Any) -> None:
        self._acks.put(sample.payload.to_bytes())

    # -- API ---------------------------------------------------------------------------------------
    def check_alive(self) -> None:
        if self._watch is not None:
            self._watch.check()
            return
        silent = clock.now() - self._last_seen
        if silent > self.config.heartbeat_timeout:
            raise NodeDiedError(self.name, f"no heartbeat from its zenoh server for {silent:.2f} s")

    def _send_request(self, record: bytes) -> None:
        """Send one request and wait for the node's answer: queued, or QueueFull / InvalidRequest
        naming the node (as the shared-memory middleware raises them), or NodeTimeout / NodeDiedError.
        Waits as long as an API call may take, and at least twice the node's wait for room in a full queue."""
        timeout = max(self.config.call_timeout, 2 * _REQ_PUT_TIMEOUT_S)
        pub = self._req_pub
        assert pub is not None  # a request sender exists only with it
        with self._req_lock:
            self.check_alive()
            self._req_id += 1
            rid = self._req_id
            pub.put(_REQ_ID.pack(rid) + record)
            deadline = clock.now() + timeout
            while True:
                try:
                    data = self._acks.get(timeout=_LIVENESS_POLL_S)
                except queue.Empty:
                    self.check_alive()
                    if clock.now() > deadline:
                        raise NodeTimeout(self.name, "request (no answer from the node)", timeout) from None
                    continue
                try:
                    answer = wire.unpack(data)
                    if answer[0] != rid:  # the late answer of an earlier request that timed out
                        continue
                    status = answer[1]
                except Exception:
                    log.warning("node '%s': ignored a malformed request answer", self.name)
                    continue
                if status == _ACK_OK:
                    return
                if status == _ACK_FULL:
                    raise QueueFull(self.name, int(answer[2]), float(answer[3]))
                field, problem = (answer[2], answer[3]) if len(answer) == 4 else (None, f"refused ({answer!r})")
                raise InvalidRequest(self.name, None if field is None else str(field), str(problem))

    def call(self, method: str, args: tuple, kwargs: dict) -> Any:
        timeout = self.config.call_timeout
        with self._call_lock:
            self.check_alive()
            self._call_id += 1
            call_id = self._call_id
            self._call_pub.put(wire.pack_call(call_id, method, args, kwargs))
            deadline = clock.now() + timeout
            while True:
                try:
                    data = self._replies.get(timeout=_LIVENESS_POLL_S)
                except queue.Empty:
                    self.check_alive()
                    if clock.now() > deadline:
                        raise NodeTimeout(self.name, f"API call {method}()", timeout) from None
                    continue
                rid, ok, value = wire.unpack_reply(data)
                if rid != call_id:  # the late reply of an earlier call that timed out
                    continue
                if ok:
                    return value
                raise NodeError(self.name, *_error_fields(value))

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        _undeclare(*self._entities)
        self._entities.clear()
        if self._session_key is not None:
            _SESSIONS.release(self._session_key)
            self._session_key = None
        if self._watch is not None:
            self._watch.close()


class ZenohMiddleware(Middleware):
    name = "zenoh"
    class Config(NetworkConfig):
        #: Interface the server listens on (peer mode). "0.0.0.0" for other machines to connect: with `keys`
        #: (mutual TLS and access control), or `insecure = true`; so are routers on other machines in `connect`.
        host: str = "127.0.0.1"
        #: TCP port to listen on; None picks a free one (each node needs its own, so only fix it for
        #: a station that serves a single node with these options).
        port: int | None = None
        #: Extra endpoints the server connects to, e.g. a zenoh router `tcp/10.0.0.2:7447` (with `keys`
        #: reached as `tls/10.0.0.2:7447`: the router needs a certificate from the station's CA whose
        #: machine name this machine trusts, and enforces its own access control for what it forwards).
        connect: list[str] = []
        #: "peer": listen on host:port, clients connect directly. "client": no listening socket; the
        #: server is reached only through the routers in `connect` (clients then connect there too).
        mode: Literal["peer", "client"] = "peer"
        #: Seconds to wait for a link, and for the server's subscriptions to become known, at connect.
        connect_timeout: float = 5.0
        #: A remote server (another machine) is declared dead after this long without a heartbeat.
        heartbeat_timeout: float = 0.5

        def exposed(self) -> list[str]:
            out = [] if self.mode == "client" else super().exposed()  # a client-mode server binds nothing
            return out + [e for e in self.connect if not is_loopback(e)]

        @model_validator(mode="after")
        def _tls_routers(self) -> ZenohMiddleware.Config:
            if self.keys is not None:
                other = [e for e in self.connect if _proto(e) not in ("tcp", "tls")]
                if other:
                    raise ValueError(f"with keys every zenoh link is TLS: connect to routers as tcp/HOST:PORT "
                                     f"or tls/HOST:PORT, not {', '.join(other)}")
            return self

    def _prefix(self, node: Node | str) -> str:
        name = node if isinstance(node, str) else node.name
        for part in (self.station, name):
            if not part or any(ch in part for ch in "/*$?#"):
                raise ConfigError(f"zenoh middleware: '{part}' cannot be part of a key expression "
                                  "(station and node names must not contain / * $ ? #)")
        return f"rio/{self.station}/{name}"

    def placed(self, node: str, index: int, machine: str, section: MachineSection
               ) -> tuple[dict[str, Any], dict[str, Any]]:
        """One fixed port per node from the machine's `port` (peer mode), or the routers in `connect`
        (client mode); `tls/` with keys. The address has no pid: clients there go by heartbeats."""
        prefix = self._prefix(node)
        keyed = self.config.keys is not None
        if self.config.mode == "client":
            routers = _tls(self.config.connect) if keyed else list(self.config.connect)
            return {}, {"prefix": prefix, "endpoints": routers}
        port = section.port + index
        options = {"host": section.bind or section.address, "port": port}
        return options, {"prefix": prefix, "endpoints": [_endpoint(section.address, port, "tls" if keyed else "tcp")]}

    def make_server(self, node: Node, layouts: NodeLayouts, resources: dict[str, Any]) -> ZenohServer:
        return ZenohServer(self._prefix(node), layouts, self.config, self.station)

    def make_client(self, node: Node, layouts: NodeLayouts, address: dict[str, Any]) -> ZenohClient:
        self._prefix(node)  # the station's name is part of the access control's key expression
        return ZenohClient(node, layouts, address, self.config, self.station)


ZenohConfig = ZenohMiddleware.Config
