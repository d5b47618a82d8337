"""The settings every network middleware shares (zmq, zenoh, portal), and who may reach a node.

Whoever reaches an unauthenticated node's port can read its state, send it commands and call its API.
So a node serves only this machine (loopback) unless the station names this machine's keys (`keys`, made
by `rio keys generate`: zmq CURVE, zenoh mutual TLS and access control; a middleware without
authentication refuses them) or says `insecure = true`, and then every start says so (`warn_if_exposed`).
"""

from __future__ import annotations

import ipaddress
import warnings
from typing import TYPE_CHECKING, Any, ClassVar

from pydantic import Field, model_validator

from rio.runtime.transport import MiddlewareConfig, NodeLayouts

if TYPE_CHECKING:
    from rio.machine.keys import MachineKeys

#: Added to a request record's size for a node's message limit (a message's kind and ids, room to spare).
_MESSAGE_HEADROOM = 4096
#: Old field name -> new one; the old name still works for one release, with a deprecation message.
RENAMED = {"max_pending_per_connection": "max_pending_per_peer"}


class NetworkConfig(MiddlewareConfig):
    """Fields of the middlewares that reach other machines: authentication, liveness, limits and quotas."""

    #: False for a middleware that has no authentication (portal): it refuses `keys`.
    authenticates: ClassVar[bool] = True
    insecure: bool = Field(False, description="allow serving or connecting beyond this machine without "
                                              "authentication (anyone who reaches the port controls the node)")
    keys: str | None = Field(None, description="this machine's keys directory, made by `rio keys generate` "
                                               "(the same path on every machine, each holding its own keys): "
                                               "authenticates and encrypts every link")
    #: Interface a node's server binds; "0.0.0.0" serves other machines (with `keys`, or `insecure = true`).
    host: str = "127.0.0.1"
    connect_timeout: float = Field(5.0, gt=0, description="seconds a client waits to reach its server and "
                                                          "finish the handshake")
    heartbeat_s: float = Field(0.05, gt=0, le=1.0, description="a server says it is alive this often, "
                                                              "whether or not it publishes")
    heartbeat_timeout: float = Field(0.5, gt=0, description="a client whose server's process it cannot watch "
                                     "(another machine) reports the node dead after this long without a word "
                                     "from it (at least 5 heartbeats)")
    max_message_bytes: int = Field(4 << 20, ge=1024, description="largest message (API call or request) a node "
                                   "accepts; a peer sending more is refused before anything is allocated for it "
                                   "(raised to fit the node's request record where that is larger)")
    max_pending_per_peer: int = Field(8, ge=1, description="API calls, and requests waiting for room in a full "
                                      "queue, one peer may have waiting on a node; more are refused at once")
    max_pending: int = Field(64, ge=1, description="the same from all peers together; when it is reached, the "
                             "peer holding the most gives way to one holding fewer")
    max_pending_bytes: int = Field(64 << 20, ge=1 << 20, description="bytes those calls and requests hold, from "
                                   "all peers together (raised to one message where that is larger): what a node "
                                   "keeps for its peers is bounded whatever their number; past it, the peer holding "
                                   "the most gives way, as past max_pending")
    max_connections: int = Field(128, ge=1, description="connections a node serves at once, where the transport has "
                                 "connections (zmq, portal; a zmq client has two); a newcomer takes the slot of the "
                                 "oldest that has not finished its handshake, else is refused with 'too many "
                                 "connections'")
    max_connections_per_address: int = Field(64, ge=1, description="the same from one address")
    handshake_timeout_s: float = Field(5.0, gt=0, description="a connection that has not finished the handshake "
                                       "after this long is dropped (zmq, portal)")
    idle_timeout_s: float = Field(30.0, gt=0, description="a connection that has sent nothing for this long is "
                                  "dropped (portal; a client's long poll goes out every heartbeat)")

    @model_validator(mode="before")
    @classmethod
    def _renamed_fields(cls, data: Any) -> Any:
        if isinstance(data, dict) and any(old in data for old in RENAMED):
            data = dict(data)
            for old, new in RENAMED.items():
                if old in data:
                    warnings.warn(f"[middleware] {old} is deprecated: it is now {new} (the same for every "
                                  "network middleware); the old name goes in the next release", FutureWarning,
                                  stacklevel=2)
                    data.setdefault(new, data.pop(old))
        return data

    def message_limit(self, layouts: NodeLayouts) -> int:
        """`max_message_bytes`, raised to fit one request record and a call's envelope."""
        record = layouts.request.itemsize if layouts.request is not None else 0
        return max(self.max_message_bytes, record + _MESSAGE_HEADROOM)

    def pending_bytes(self, layouts: NodeLayouts) -> int:
        """What the waiting calls may hold, and what the waiting requests may: half of `max_pending_bytes` each,
        raised to hold one message (`message_limit`)."""
        return max(self.max_pending_bytes // 2, self.message_limit(layouts))

    def exposed(self) -> list[str]:
        """The non-loopback addresses this config binds or connects to: its `host` (a middleware that
        also connects out, like zenoh to its routers, adds those)."""
        return [] if is_loopback(self.host) else [self.host]

    def machine_keys(self) -> MachineKeys | None:
        """This machine's keys (checked), or None when the station names none."""
        from rio.machine.keys import load

        return load(self.keys) if self.keys else None

    @model_validator(mode="after")
    def _authenticated_unless_insecure(self) -> NetworkConfig:
        if self.keys is not None:
            if not self.authenticates:
                raise ValueError("this middleware has no authentication: remove keys, keep its nodes on "
                                 "127.0.0.1 and reach them through an ssh tunnel or a VPN (or use zmq or zenoh)")
            self.machine_keys()  # a missing or unreadable directory is an error in the station file
            return self
        exposed = self.exposed()
        if exposed and not self.insecure:
            advice = ("name this machine's keys (keys = \"~/.config/rio/keys/<station>\", made by `rio keys "
                      "generate`), keep" if self.authenticates else "keep")
            raise ValueError(f"{', '.join(exposed)} is reachable from other machines without authentication: "
                             f"{advice} nodes on 127.0.0.1 (reach them through an ssh tunnel or a VPN), or set "
                             "insecure = true in [middleware] to accept that anyone who can reach the port can "
                             "command the robot")
        return self


def is_loopback(host_or_endpoint: str) -> bool:
    """Whether an address ("127.0.0.1", "localhost", "::1", "tcp/127.0.0.1:7447") stays on this machine;
    a wildcard ("0.0.0.0", "*", "::") or another machine's address does not."""
    h = host_or_endpoint.split("/", 1)[1] if "/" in host_or_endpoint else host_or_endpoint
    if h.startswith("["):  # [::1]:port
        h = h[1:h.index("]")]
    elif h.count(":") == 1:  # host:port
        h = h.rsplit(":", 1)[0]
    if h == "localhost":
        return True
    try:
        return ipaddress.ip_address(h).is_loopback
    except ValueError:
        return False  # a name, a wildcard: assume it is reachable from elsewhere


def warn_if_exposed(config: NetworkConfig, node: str, log: Any) -> None:
    """Every start of a node that `insecure = true` lets serve or connect beyond loopback says so."""
    exposed = config.exposed()
    if exposed and config.keys is None:
        log.warning("node '%s': on %s WITHOUT authentication (insecure = true): anyone who can reach it can "
                    "read its state, command it and call its API", node, ", ".join(exposed))
