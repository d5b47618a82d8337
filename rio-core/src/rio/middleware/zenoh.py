"""Zenoh middleware: a node reachable through eclipse-zenoh 1.x, on one machine or across many. It carries
RIO's network protocol (`rio.middleware.protocol`) and authenticates; the protocol does the rest.

Key expressions, under `rio/<station>/<node>`; a client picks a random id `<cid>` (the protocol's peer):

- `state`, `hb`    the state stream: STATE (the record as payload, the stream header as attachment) on
                   `state`; BEAT and BYE on `hb`, at top priority so they overtake queued frames.
- `req/<cid>`, `call/<cid>`    a client's requests and API calls (message bodies; the key is the kind).
- `ack/<cid>`, `reply/<cid>`   their answers, to that client only.
- `hello`          a queryable: the handshake.

Why pub/sub for calls and requests rather than a queryable: measured here, a publisher pair is ~45 us
faster per half round trip than `Querier.get` + `Query.reply`. Zenoh drops what is put before the peer's
subscription has propagated, so a client uses its publishers only once zenoh reports a matching subscriber,
and declares its `ack` and `reply` subscriptions before its handshake (they reach the node first: same
link, in order). Answers are `session.put`s: nothing is kept per client, so made-up client ids cost no state.

With the station's keys (`keys`, `rio.machine.keys`) every link is mutual TLS (`tls/` endpoints only, the
station's CA on both sides) and zenoh's access control lets through only machines this one trusts
(their certificates' common names, `peers/`), only under `rio/<station>/**`: see `_secure`. A message over
the node's limit is refused by zenoh itself (`transport/link/rx/max_message_size`) before it is reassembled.

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
import threading
from collections import OrderedDict
from typing import TYPE_CHECKING, Any, Literal

from pydantic import model_validator

from rio import clock
from rio.errors import ConfigError, NodeDiedError
from rio.middleware.protocol import NetworkClient, NetworkConfig, NetworkServer, is_loopback
from rio.middleware.protocol.client import POLL_S
from rio.middleware.protocol.messages import ACK, CALL, REPLY, REQUEST
from rio.runtime.node import Node
from rio.runtime.transport import Middleware, NodeLayouts

if TYPE_CHECKING:
    from rio.machine.keys import MachineKeys
    from rio.station.model import MachineSection

log = logging.getLogger("rio.zenoh")

_CID = re.compile(r"^[0-9a-f]{1,32}$")
_KEYS = {REQUEST: "req", CALL: "call", ACK: "ack", REPLY: "reply"}  # a message's kind -> its key
_PUBS_MAX = 128  # answer publishers a server keeps declared (for the clients it knows, the newest)


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
    """Mutual TLS on every link, and access control: only machines this one trusts, only RIO's keys.

    - `transport/link/protocols = ["tls"]`: no other kind of link is opened or accepted (a `tcp/` peer
      cannot even connect).
    - `transport/link/tls`: the station's CA is the only root (`root_ca_certificate`), this machine's
      certificate and key for both directions (`listen_*`, `connect_*`), `enable_mtls`: each side proves
      itself. `verify_name_on_connect` is off: clients connect to whatever address a node advertises (an
      IP, this machine's host name for a wildcard bind) and a certificate names only the machine, localhost,
      127.0.0.1 and the addresses given to `rio keys generate`, so checking names would refuse working
      stations (measured: connecting by an address not in the certificate fails). What authenticates is
      the private CA plus the common-name access control below, not the address.
    - `access_control`: deny by default; allow, in both directions, RIO's message kinds under
      `rio/<station>/**`, only to and from peers whose certificate common name is one of this machine's
      trusted machines (`peers/`). A certificate from the station's CA for a machine since removed from
      `peers/` connects but sees and sends nothing.
    """
    tls = {"root_ca_certificate": str(keys.ca), "enable_mtls": True, "verify_name_on_connect": False,
           "listen_certificate": str(keys.tls_cert), "listen_private_key": str(keys.tls_key),
           "connect_certificate": str(keys.tls_cert), "connect_private_key": str(keys.tls_key)}
    acl = {
        "enabled": True,
        "default_permission": "deny",
        "rules": [{"id": "rio", "permission": "allow", "flows": ["ingress", "egress"], "messages": _ACL_MESSAGES,
                   "key_exprs": [f"rio/{station}/**"]}],
        "subjects": [{"id": "trusted", "cert_common_names": sorted(keys.peers)}],
        "policies": [{"id": "trusted", "rules": ["rio"], "subjects": ["trusted"]}],
    }
    c.insert_json5("transport/link/protocols", json.dumps(["tls"]))
    c.insert_json5("transport/link/tls", json.dumps(tls))
    c.insert_json5("access_control", json.dumps(acl))


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


def _tls(endpoints: list[str]) -> list[str]:
    """With keys every link is TLS: a router given as `tcp/host:port` is reached as `tls/host:port`."""
    return [f"tls/{e.split('/', 1)[1]}" if _proto(e) == "tcp" else e for e in endpoints]


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
class ZenohServer(NetworkServer):
    mw = "zenoh"

    def __init__(self, node: Node, layouts: NodeLayouts, config: ZenohConfig, station: str = "rio"):
        super().__init__(node, layouts, config)
        z = _zenoh()
        self.prefix, self.station = _prefix(station, node.name), station
        self._keys = config.machine_keys()
        self.session, self.endpoints = self._open_session()
        cc, prio = z.CongestionControl, z.Priority
        # State: DROP, so a slow or stuck subscriber never stalls the node loop (newest wins anyway).
        self._state_pub = self.session.declare_publisher(
            f"{self.prefix}/state", congestion_control=cc.DROP, priority=prio.DATA)
        self._hb_pub = self.session.declare_publisher(
            f"{self.prefix}/hb", congestion_control=cc.DROP, priority=prio.REAL_TIME)
        self._answer = {"congestion_control": cc.BLOCK, "priority": prio.INTERACTIVE_HIGH}
        self._pubs: OrderedDict[tuple[bytes, str], Any] = OrderedDict()  # (kind, client id) -> its publisher
        self._pubs_lock = threading.Lock()
        self._subs: list[Any] = []

    def _open_session(self) -> tuple[Any, list[str]]:
        o, keys = self.config, self._keys
        connect, proto = (list(o.connect), "tcp") if keys is None else (_tls(o.connect), "tls")
        limit = self.max_message_bytes
        if o.mode == "client":
            if not connect:
                raise ConfigError("zenoh middleware: mode 'client' needs at least one router in 'connect'")
            return _zenoh().open(_config("client", [], connect, o.connect_timeout, keys, self.station, limit)), connect
        for attempt in range(5):  # a port picked free may be taken before zenoh binds it
            port = o.port if o.port is not None else _free_port(o.host)
            try:
                session = _zenoh().open(_config("peer", [_endpoint(o.host, port, proto)], connect,
                                                o.connect_timeout, keys, self.station, limit))
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

    def _open(self) -> dict[str, Any]:
        s, p = self.session, self.prefix
        for kind in (REQUEST, CALL):  # requests too where the node takes none: the protocol says so
            self._subs.append(s.declare_subscriber(f"{p}/{_KEYS[kind]}/*", self._receiver(kind)))
        self._subs.append(s.declare_queryable(f"{p}/hello", self._on_hello))
        return {"prefix": p, "endpoints": self.endpoints}

    def _receiver(self, kind: bytes) -> Any:
        def receive(sample: Any) -> None:  # zenoh's callback thread
            cid = str(sample.key_expr).rsplit("/", 1)[-1]
            if _CID.match(cid):  # else nobody to answer
                self.on_message(cid, kind, sample.payload.to_bytes())
        return receive

    def _on_hello(self, query: Any) -> None:
        cid = query.payload.to_bytes().decode("ascii", "replace") if query.payload is not None else ""
        if _CID.match(cid):  # the client's id, so that its calls outrank strangers' (`FairQueue`)
            self.vouch(cid)
        query.reply(f"{self.prefix}/hello", self.hello())

    def _send(self, peer: Any, kind: bytes, body: bytes, tag: Any = None) -> None:
        try:
            pub = self._pubs.get((kind, peer))
            if pub is not None:  # a known client's: routed once, ~10 us less per answer than session.put
                pub.put(body)
            elif self._knows(peer):
                with self._pubs_lock:
                    self._pubs[kind, peer] = pub = self.session.declare_publisher(
                        f"{self.prefix}/{_KEYS[kind]}/{peer}", **self._answer)
                    if len(self._pubs) > _PUBS_MAX:
                        _undeclare(self._pubs.popitem(last=False)[1])
                pub.put(body)
            else:
                self.session.put(f"{self.prefix}/{_KEYS[kind]}/{peer}", body, **self._answer)
        except Exception:
            if not self.closed:
                log.exception("node '%s': could not answer client %s", self.name, peer)

    def _broadcast(self, head: bytes, record: bytes | None) -> None:
        try:
            if record is None:
                self._hb_pub.put(head)
            else:
                self._state_pub.put(record, attachment=head)
        except Exception:
            if not self.closed:
                raise

    def _shut(self, busy: bool) -> None:
        _undeclare(*self._subs, *self._pubs.values(), self._state_pub, self._hb_pub)
        self._subs.clear()
        _close(self.session)


# -- client ------------------------------------------------------------------------------------------
class ZenohClient(NetworkClient):
    mw = "zenoh"

    def __init__(self, node: Node, layouts: NodeLayouts, address: dict[str, Any], config: ZenohConfig,
                 station: str = "rio"):
        try:
            self.prefix = str(address["prefix"])
            endpoints = list(address["endpoints"])
        except (KeyError, TypeError) as e:
            raise ConfigError(f"node '{node.name}': zenoh address lacks {e} (got {address!r})") from None
        keys = config.machine_keys()
        tls = [_proto(e) == "tls" for e in endpoints]
        if keys is None and any(tls):  # said at once, not a connect timeout
            raise ConfigError(f"node '{node.name}' serves over mutual TLS ({', '.join(endpoints)}): this client "
                              "needs the station's keys (keys = \"...\" in [middleware], this machine's "
                              "directory made by `rio keys generate`)")
        if keys is not None and not all(tls):
            raise ConfigError(f"node '{node.name}' serves without authentication ({', '.join(endpoints)}) but "
                              "this client has the station's keys: start the node with the same keys "
                              "(the station file's [middleware] keys)")
        super().__init__(node, layouts, address, config)
        self.station = station
        self._session_key: tuple[str, ...] | None = None
        self._entities: list[Any] = []
        self._answers: dict[bytes, queue.SimpleQueue[bytes]] = {ACK: queue.SimpleQueue(), REPLY: queue.SimpleQueue()}
        try:
            self._connect(endpoints, keys)
        except BaseException:
            self.close()
            raise

    def _connect(self, endpoints: list[str], keys: MachineKeys | None) -> None:
        z = _zenoh()
        p = self.prefix
        try:
            self._session_key, self.session = _SESSIONS.acquire(endpoints, self.config.connect_timeout, keys,
                                                                self.station)
        except Exception as e:
            why = (" (with keys: is this machine's certificate from the node's station CA, and does the node's "
                   "machine trust it?)" if keys is not None else "")
            raise NodeDiedError(self.name, f"cannot reach zenoh endpoints {endpoints}: {e}{why}") from None
        declare = self._declare
        if self.ring_buffer is not None:
            declare(self.session.declare_subscriber(f"{p}/state", self._on_state))
        declare(self.session.declare_subscriber(f"{p}/hb", lambda s: self._on_stream(s.payload.to_bytes(), None)))
        cid = os.urandom(8).hex()
        for kind in (ACK, REPLY):
            declare(self.session.declare_subscriber(f"{p}/{_KEYS[kind]}/{cid}", self._answers[kind].put))
        # BLOCK: a request or call is never dropped silently; zenoh keeps one publisher's order.
        options = {"congestion_control": z.CongestionControl.BLOCK, "priority": z.Priority.INTERACTIVE_HIGH}
        self._call_pub = declare(self.session.declare_publisher(f"{p}/call/{cid}", **options))
        self._req_pub = declare(self.session.declare_publisher(f"{p}/req/{cid}", **options))
        querier = declare(self.session.declare_querier(f"{p}/hello", timeout=self.config.connect_timeout))
        self._wait_matching(querier, f"{p}/hello")
        try:
            body = querier.get(payload=cid).recv().ok.payload.to_bytes()
        except Exception as e:
            raise NodeDiedError(self.name, f"no handshake reply from the zenoh server: {e}") from None
        _undeclare(querier)
        self._entities.remove(querier)
        self._handshake(body, ", ".join(endpoints))
        for pub in (self._call_pub, self._req_pub):
            self._wait_matching(pub, str(pub.key_expr))
        self._heard()

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

    def _on_state(self, sample: Any) -> None:
        head = sample.attachment
        if head is not None:
            self._on_stream(head.to_bytes(), sample.payload.to_bytes())

    def _send(self, kind: bytes, body: bytes) -> None:
        (self._req_pub if kind == REQUEST else self._call_pub).put(body)

    def _recv(self, kind: bytes) -> bytes | None:
        try:
            return self._answers[kind].get(timeout=POLL_S).payload.to_bytes()
        except queue.Empty:
            return None

    def close(self) -> None:
        _undeclare(*self._entities)
        self._entities.clear()
        if self._session_key is not None:
            _SESSIONS.release(self._session_key)
            self._session_key = None
        super().close()


def _prefix(station: str, node: str) -> str:
    for part in (station, node):
        if not part or any(ch in part for ch in "/*$?#"):
            raise ConfigError(f"zenoh middleware: '{part}' cannot be part of a key expression "
                              "(station and node names must not contain / * $ ? #)")
    return f"rio/{station}/{node}"


class ZenohMiddleware(Middleware):
    name = "zenoh"
    class Config(NetworkConfig):
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

    def placed(self, node: str, index: int, machine: str, section: MachineSection
               ) -> tuple[dict[str, Any], dict[str, Any]]:
        """One fixed port per node from the machine's `port` (peer mode), or the routers in `connect`
        (client mode); `tls/` with keys. The address has no pid: clients there go by heartbeats."""
        prefix = _prefix(self.station, node)
        keyed = self.config.keys is not None
        if self.config.mode == "client":
            routers = _tls(self.config.connect) if keyed else list(self.config.connect)
            return {}, {"prefix": prefix, "endpoints": routers}
        port = section.port + index
        options = {"host": section.bind or section.address, "port": port}
        return options, {"prefix": prefix, "endpoints": [_endpoint(section.address, port, "tls" if keyed else "tcp")]}

    def make_server(self, node: Node, layouts: NodeLayouts, resources: dict[str, Any]) -> ZenohServer:
        return ZenohServer(node, layouts, self.config, self.station)

    def make_client(self, node: Node, layouts: NodeLayouts, address: dict[str, Any]) -> ZenohClient:
        _prefix(self.station, node.name)  # the station's name is part of the access control's key expression
        return ZenohClient(node, layouts, address, self.config, self.station)


ZenohConfig = ZenohMiddleware.Config
