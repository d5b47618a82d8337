"""Zenoh middleware: eclipse-zenoh 1.x carrying RIO's network protocol (`rio.middleware.protocol`), on one
machine or across many (through routers). Keys under `rio/<station>/<node>`, `<cid>` a client's random id:
`state` (STATE: the record, its stream header as attachment) and `hb` (BEAT, BYE: top priority, they
overtake queued frames); `req/<cid>` and `call/<cid>` from a client, `ack/<cid>` and `reply/<cid>` back;
`hello`, a queryable (the query carries the client's id).

Pub/sub rather than queries for calls: measured, ~45 us less per half round trip. Zenoh drops what is put
before the peer's subscription has propagated, so a client declares its answer subscriptions before its
handshake and uses its publishers only once zenoh reports them matched. A node answers a client it knows
through a publisher of its own (~4.5 us less than `session.put`), anyone else by `session.put` (a made-up
client id costs no state). A message over the node's limit is dropped by zenoh before reassembly
(`transport/link/rx/max_message_size`). With `keys` every link is mutual TLS and zenoh's access control
admits only trusted machines (`secure_links`). Clients in one process share one session per set of endpoints
(and keys). The lowlatency transport stays off: it has no fragmentation and silently drops large frames.
"""

from __future__ import annotations

import json
import logging
import os
import re
import socket
import threading
from collections import OrderedDict
from typing import TYPE_CHECKING, Any, Literal

from pydantic import model_validator

from rio import clock
from rio.errors import ConfigError, NodeDiedError
from rio.middleware.protocol import NetworkClient, NetworkConfig, NetworkServer, is_loopback
from rio.middleware.protocol.messages import ACK, CALL, REPLY, REQUEST
from rio.runtime.node import Node
from rio.runtime.transport import Middleware, NodeLayouts

if TYPE_CHECKING:
    from rio.machine.keys import MachineKeys
    from rio.station.model import MachineSection

log = logging.getLogger("rio.zenoh")

_CID = re.compile(r"^[0-9a-f]{1,32}$")
_KEYS = {REQUEST: "req", CALL: "call", ACK: "ack", REPLY: "reply"}  # a message's kind -> its key
_PUBS_MAX = 128  # answer publishers a node keeps declared (for the clients it knows, the newest)
#: What RIO's traffic is made of, in zenoh's access-control terms (no deletes, no liveliness).
_ACL_MESSAGES = ["put", "declare_subscriber", "query", "declare_queryable", "reply"]


def _zenoh() -> Any:
    """Import zenoh on first use, so `import rio.middleware.zenoh` stays cheap and optional."""
    try:
        import zenoh
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("the 'zenoh' middleware needs eclipse-zenoh: pip install 'rio-core[zenoh]'") from e
    return zenoh


def _config(mode: str, listen: list[str], connect: list[str], connect_timeout: float,
            keys: MachineKeys | None = None, station: str = "", max_message: int | None = None) -> Any:
    """A session config. Scouting off: RIO knows whom to connect to, and discovery would reach beyond
    loopback and across stations. Zenoh's shared memory off: it leaves segments in /dev/shm after a SIGKILL."""
    c = _zenoh().Config()
    options: dict[str, Any] = {"mode": mode, "scouting/multicast/enabled": False, "scouting/gossip/enabled": False,
                               "transport/shared_memory/enabled": False, "listen/endpoints": listen,
                               "connect/endpoints": connect}
    if connect:  # fail at open with a clear error instead of retrying silently in the background
        options.update({"connect/exit_on_failure": True, "connect/timeout_ms": int(connect_timeout * 1000)})
    if max_message is not None:  # a node's session: zenoh refuses a bigger message before reassembling it
        options["transport/link/rx/max_message_size"] = max_message
    if keys is not None:
        options.update(secure_links(keys, [f"rio/{station}/**"], _ACL_MESSAGES))  # RIO's kinds only
    for key, value in options.items():
        c.insert_json5(key, json.dumps(value))
    return c


def secure_links(keys: MachineKeys, key_exprs: list[str], messages: list[str]) -> dict[str, Any]:
    """The zenoh settings (config path -> value) that authenticate and encrypt every link with `keys` and let
    through only `messages` under `key_exprs`, to and from machines this one trusts. Also what other zenoh
    users of a station's keys build on (the ROS 2 bridge: its domain's key expressions).

    Only `tls` links are opened or accepted (a `tcp/` peer cannot even connect). The station's CA is the only
    root, this machine's certificate serves both directions and each side proves itself (`enable_mtls`).
    Names are not verified: clients connect to whatever address a node advertises, and a certificate names
    only the machine and the addresses given to `rio keys generate` (measured: another address fails); what
    authenticates is the private CA plus the access control: deny by default, allow `messages` under
    `key_exprs` only to and from certificates whose common name is a machine in `peers/` (one removed from
    `peers/` connects but sees and sends nothing)."""
    tls = {"root_ca_certificate": str(keys.ca), "enable_mtls": True, "verify_name_on_connect": False,
           "listen_certificate": str(keys.tls_cert), "listen_private_key": str(keys.tls_key),
           "connect_certificate": str(keys.tls_cert), "connect_private_key": str(keys.tls_key)}
    acl = {"enabled": True, "default_permission": "deny",
           "rules": [{"id": "rio", "permission": "allow", "flows": ["ingress", "egress"], "messages": list(messages),
                      "key_exprs": list(key_exprs)}],
           "subjects": [{"id": "trusted", "cert_common_names": sorted(keys.peers)}],
           "policies": [{"id": "trusted", "rules": ["rio"], "subjects": ["trusted"]}]}
    return {"transport/link/protocols": ["tls"], "transport/link/tls": tls, "access_control": acl}


def tls_endpoints(endpoints: list[str]) -> list[str]:
    """With keys every link is TLS: `tcp/host:port` is reached (or listened on) as `tls/host:port`."""
    return [f"tls/{e.split('/', 1)[1]}" if _proto(e) == "tcp" else e for e in endpoints]


def _free_port(host: str) -> int:
    """A currently free TCP port (zenoh cannot report the port it picked for `:0`)."""
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def _endpoint(host: str, port: int, proto: str = "tcp") -> str:
    h = host.strip("[]")
    return f"{proto}/[{h}]:{port}" if ":" in h else f"{proto}/{host}:{port}"


def _proto(endpoint: str) -> str:
    return endpoint.split("/", 1)[0] if "/" in endpoint else ""


def _prefix(station: str, node: str) -> str:
    for part in (station, node):
        if not part or any(ch in part for ch in "/*$?#"):
            raise ConfigError(f"zenoh middleware: '{part}' cannot be part of a key expression "
                              "(station and node names must not contain / * $ ? #)")
    return f"rio/{station}/{node}"


class _Sessions:
    """One zenoh session per set of endpoints (and keys, and station) in this process, reference-counted."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._open: dict[tuple[str, ...], list[Any]] = {}  # key -> [session, users]

    def acquire(self, endpoints: list[str], timeout: float, keys: MachineKeys | None = None,
                station: str = "") -> tuple[tuple[str, ...], Any]:
        eps = tuple(sorted(endpoints))
        key = eps if keys is None else (*eps, f"keys={keys.dir}", f"station={station}")  # (both in its ACL)
        with self._lock:
            entry = self._open.get(key)
            if entry is None or entry[0].is_closed():
                entry = self._open[key] = [_zenoh().open(_config("peer", [], list(eps), timeout, keys, station)), 0]
            entry[1] += 1
            return key, entry[0]

    def release(self, key: tuple[str, ...]) -> None:
        with self._lock:
            entry = self._open.get(key)
            if entry is not None:
                entry[1] -= 1
                if entry[1] <= 0:
                    del self._open[key]
                    _close(entry[0])


_SESSIONS = _Sessions()


def _close(session: Any) -> None:
    """A session whose link is gone (a pulled cable) can only time out closing: no error of the caller's."""
    try:
        session.close()
    except Exception as e:
        log.debug("zenoh session close: %s", e)


def _undeclare(*entities: Any) -> None:
    for e in entities:
        try:
            e.undeclare()
        except Exception:  # already gone with a closed session
            pass


class ZenohServer(NetworkServer):
    mw = "zenoh"
    config: ZenohConfig

    def __init__(self, node: Node, layouts: NodeLayouts, config: ZenohConfig, station: str = "rio"):
        super().__init__(node, layouts, config)
        z = _zenoh()
        self.prefix, self.station = _prefix(station, node.name), station
        self._keys = config.machine_keys()
        self.session, self.endpoints = self._open_session()
        cc, prio = z.CongestionControl, z.Priority
        # State: DROP, so a slow or stuck subscriber never stalls the node loop (newest wins anyway).
        self._state_pub = self.session.declare_publisher(f"{self.prefix}/state", congestion_control=cc.DROP,
                                                         priority=prio.DATA)
        self._hb_pub = self.session.declare_publisher(f"{self.prefix}/hb", congestion_control=cc.DROP,
                                                      priority=prio.REAL_TIME)
        self._answer = {"congestion_control": cc.BLOCK, "priority": prio.INTERACTIVE_HIGH}
        self._pubs: OrderedDict[tuple[bytes, str], Any] = OrderedDict()  # (kind, client id) -> its publisher
        self._pubs_lock = threading.Lock()
        self._subs: list[Any] = []

    def _open_session(self) -> tuple[Any, list[str]]:
        o, keys = self.config, self._keys
        connect, proto = (list(o.connect), "tcp") if keys is None else (tls_endpoints(o.connect), "tls")
        if o.mode == "client":
            if not connect:
                raise ConfigError("zenoh middleware: mode 'client' needs at least one router in 'connect'")
            return _zenoh().open(_config("client", [], connect, o.connect_timeout, keys, self.station,
                                         self.max_message_bytes)), connect
        for attempt in range(5):  # a port picked free may be taken before zenoh binds it
            port = o.port if o.port is not None else _free_port(o.host)
            try:
                session = _zenoh().open(_config("peer", [_endpoint(o.host, port, proto)], connect,
                                                o.connect_timeout, keys, self.station, self.max_message_bytes))
            except Exception:
                if o.port is not None or attempt == 4:
                    raise
                continue
            wildcard = o.host.strip("[]") in ("0.0.0.0", "::", "")  # clients then reach this machine's name
            return session, [_endpoint(socket.getfqdn() if wildcard else o.host, port, proto)]
        raise AssertionError("unreachable")

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
        if _CID.match(cid):  # its calls outrank strangers' (`FairQueue`)
            self.vouch(cid)
        query.reply(f"{self.prefix}/hello", self.hello())

    def _send(self, peer: Any, kind: bytes, body: bytes, tag: Any = None) -> None:
        try:
            pub = self._pubs.get((kind, peer))
            if pub is None and self._knows(peer):
                with self._pubs_lock:
                    pub = self._pubs[kind, peer] = self.session.declare_publisher(
                        f"{self.prefix}/{_KEYS[kind]}/{peer}", **self._answer)
                    if len(self._pubs) > _PUBS_MAX:
                        _undeclare(self._pubs.popitem(last=False)[1])
            if pub is not None:
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
        _close(self.session)


class ZenohClient(NetworkClient):
    mw = "zenoh"
    config: ZenohConfig

    def __init__(self, node: Node, layouts: NodeLayouts, address: dict[str, Any], config: ZenohConfig,
                 station: str = "rio"):
        try:
            self.prefix, endpoints = str(address["prefix"]), list(address["endpoints"])
        except (KeyError, TypeError) as e:
            raise ConfigError(f"node '{node.name}': zenoh address lacks {e} (got {address!r})") from None
        keys = config.machine_keys()
        tls = [_proto(e) == "tls" for e in endpoints]
        if keys is None and any(tls):  # a mismatch is said at once, not as a connect timeout
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
        try:
            self._connect(endpoints, keys)
        except BaseException:
            self.close()
            raise

    def _connect(self, endpoints: list[str], keys: MachineKeys | None) -> None:
        z, p, timeout = _zenoh(), self.prefix, self.config.connect_timeout
        try:
            self._session_key, self.session = _SESSIONS.acquire(endpoints, timeout, keys, self.station)
        except Exception as e:
            why = (" (with keys: is this machine's certificate from the node's station CA, and does the node's "
                   "machine trust it?)" if keys is not None else "")
            raise NodeDiedError(self.name, f"cannot reach zenoh endpoints {endpoints}: {e}{why}") from None
        s, cid = self.session, os.urandom(8).hex()
        if self.ring_buffer is not None:
            self._declare(s.declare_subscriber(f"{p}/state", self._on_state))
        self._declare(s.declare_subscriber(f"{p}/hb", lambda smp: self._on_stream(smp.payload.to_bytes(), None)))
        for kind in (ACK, REPLY):
            self._declare(s.declare_subscriber(f"{p}/{_KEYS[kind]}/{cid}",
                                               lambda smp, k=kind: self._answered(k, smp.payload.to_bytes())))
        # BLOCK: a request or call is never dropped silently; zenoh keeps one publisher's order.
        options = {"congestion_control": z.CongestionControl.BLOCK, "priority": z.Priority.INTERACTIVE_HIGH}
        self._call_pub = self._declare(s.declare_publisher(f"{p}/call/{cid}", **options))
        self._req_pub = self._declare(s.declare_publisher(f"{p}/req/{cid}", **options))
        querier = s.declare_querier(f"{p}/hello", timeout=timeout)
        try:
            self._wait_matching(querier, f"{p}/hello")
            body = querier.get(payload=cid).recv().ok.payload.to_bytes()
        except NodeDiedError:
            raise
        except Exception as e:
            raise NodeDiedError(self.name, f"no handshake reply from the zenoh server: {e}") from None
        finally:
            _undeclare(querier)
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
        if sample.attachment is not None:
            self._on_stream(sample.attachment.to_bytes(), sample.payload.to_bytes())

    def _send(self, kind: bytes, body: bytes) -> None:
        (self._req_pub if kind == REQUEST else self._call_pub).put(body)

    def close(self) -> None:
        _undeclare(*self._entities)
        self._entities.clear()
        if self._session_key is not None:
            _SESSIONS.release(self._session_key)
            self._session_key = None
        super().close()


class ZenohMiddleware(Middleware):
    name = "zenoh"

    class Config(NetworkConfig):
        #: TCP port to listen on; None picks a free one (each node needs its own, so only fix it for a
        #: station that serves a single node with these options).
        port: int | None = None
        #: Extra endpoints the server connects to, e.g. a zenoh router `tcp/10.0.0.2:7447` (with `keys`
        #: reached as `tls/...`: the router needs a certificate from the station's CA whose machine name this
        #: machine trusts, and enforces its own access control for what it forwards).
        connect: list[str] = []
        #: "peer": listen on host:port, clients connect directly. "client": no listening socket; the
        #: server is reached only through the routers in `connect` (clients then connect there too).
        mode: Literal["peer", "client"] = "peer"

        def exposed(self) -> list[str]:
            out = [] if self.mode == "client" else super().exposed()  # a client-mode server binds nothing
            return out + [e for e in self.connect if not is_loopback(e)]

        @model_validator(mode="after")
        def _tls_routers(self) -> ZenohMiddleware.Config:
            other = [e for e in self.connect if _proto(e) not in ("tcp", "tls")] if self.keys is not None else []
            if other:
                raise ValueError(f"with keys every zenoh link is TLS: connect to routers as tcp/HOST:PORT "
                                 f"or tls/HOST:PORT, not {', '.join(other)}")
            return self

    def placed(self, node: str, index: int, machine: str, section: MachineSection
               ) -> tuple[dict[str, Any], dict[str, Any]]:
        """One fixed port per node from the machine's `port` (peer mode), or the routers in `connect`
        (client mode); `tls/` with keys. The address has no pid: clients there go by heartbeats."""
        prefix, keyed = _prefix(self.station, node), self.config.keys is not None
        if self.config.mode == "client":
            routers = tls_endpoints(self.config.connect) if keyed else list(self.config.connect)
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
