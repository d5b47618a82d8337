"""The one interface every middleware implements (built-in or third-party).

A middleware answers four questions, nothing else:
- `prepare` / `release` (in the process that runs `ServerManager`): create and destroy what must
  outlive a crashed server (shared-memory segments, a run directory).
- `make_server` (where the node runs): the ring buffer the node writes, the request queue it reads,
  and `start(dispatch)` to begin answering API calls; returns an address (plain JSON-able dict).
- `make_client` (anywhere): a local ring buffer mirror that reads never block on, a request sender,
  `call()` for remote API methods, and `check_alive()` that turns a dead server into NodeDiedError.
"""

from __future__ import annotations

import os
import select
import socket
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from pydantic import Field, model_validator

from rio import clock
from rio.config import Config, Configurable
from rio.errors import NodeDiedError
from rio.machine import host
from rio.runtime.layout import Layout
from rio.runtime.node import Node

if TYPE_CHECKING:
    from rio.machine.keys import MachineKeys
    from rio.station.model import MachineSection


@dataclass
class NodeLayouts:
    name: str
    data: Layout | None
    request: Layout | None
    buffer_capacity: int
    request_capacity: int

    @classmethod
    def of(cls, node: Node) -> NodeLayouts:
        data, req = node.layouts()
        return cls(node.name, data, req, node.buffer_capacity, node.request_capacity)

    def fingerprint(self) -> list[int]:
        return [self.data.fingerprint if self.data else 0, self.request.fingerprint if self.request else 0]


class ServerTransport(ABC):
    ring_buffer: Any = None
    request_queue: Any = None
    #: For a node run as a thread of the manager's process (`process_per_node` False): set by the
    #: manager when that thread has ended (with the error, if any).
    ended: str | None = None

    @abstractmethod
    def start(self, dispatch: Any) -> dict[str, Any]:
        """Begin serving requests and API calls; return the address clients connect to."""

    def close(self) -> None:  # noqa: B027 - optional hook, nothing to release by default
        """Stop serving and release sockets; the default has nothing to release."""


class ClientTransport(ABC):
    ring_buffer: Any = None
    request_queue: Any = None

    @abstractmethod
    def call(self, method: str, args: tuple, kwargs: dict) -> Any:
        """Run a remote API method; raise NodeError / NodeDiedError / NodeTimeout."""

    @abstractmethod
    def check_alive(self) -> None:
        """Raise NodeDiedError if the server is known to be gone. Must be cheap (called on reads)."""

    def close(self) -> None:  # noqa: B027 - optional hook, nothing to release by default
        """Stop threads and release sockets; the default has nothing to release."""


class Middleware(Configurable, ABC):
    name: ClassVar[str]
    #: False: nodes run as threads of the calling process (the thread middleware).
    process_per_node: ClassVar[bool] = True
    class Config(Config):
        """Fields every middleware accepts (the station file's `[middleware]` table); subclasses add their own."""

        call_timeout: float = Field(10.0, gt=0, description="seconds a remote API call may take before NodeTimeout")

    def __init__(self, config: Any = None, /, *, station: str = "rio", **fields: Any):
        super().__init__(config, **fields)
        self.station = station

    def prepare(self, layouts: NodeLayouts, run_dir: str) -> dict[str, Any]:
        """Create resources that must survive the server (parent side). Default: none."""
        return {}

    def release(self, resources: dict[str, Any]) -> None:  # noqa: B027 - default: nothing to destroy
        """Destroy what `prepare` created, even if the server was SIGKILLed."""

    def ring_address(self, address: dict[str, Any]) -> dict[str, Any] | None:
        """The part of a node's `address` through which another consumer reads the node's ring buffer
        *in place* (`rio.runtime.ring_ref`: how a policy node takes camera frames by reference), or None where
        clients read local mirrors of it (network middlewares, the default): there the data must travel."""
        return None

    def placed(self, node: str, index: int, machine: str, section: MachineSection
               ) -> tuple[dict[str, Any], dict[str, Any]]:
        """A node served on another machine of the station (`[machines.<machine>]`, the `index`-th of its
        nodes) at fixed ports: (the config options its server runs with there, the address a client on
        any other machine connects to). Only middlewares that reach other machines place nodes."""
        from rio.errors import ConfigError

        raise ConfigError(f"middleware '{self.name}' keeps every node on one machine: a station with "
                          "[machines] needs zmq or zenoh")

    def with_options(self, **options: Any) -> Middleware:
        """This middleware with some options changed, checked again (a placed node's fixed ports)."""
        return type(self)(type(self).Config.model_validate({**self.config.model_dump(), **options}),
                          station=self.station)

    @abstractmethod
    def make_server(self, node: Node, layouts: NodeLayouts, resources: dict[str, Any]) -> ServerTransport: ...

    @abstractmethod
    def make_client(self, node: Node, layouts: NodeLayouts, address: dict[str, Any]) -> ClientTransport: ...


MiddlewareConfig = Middleware.Config


#: Added to a request record's size for a node's message limit (a message's kind and ids, room to spare).
_MESSAGE_HEADROOM = 4096


class NetworkConfig(MiddlewareConfig):
    """Fields of the middlewares that reach other machines (zmq, zenoh, portal).

    Whoever reaches an unauthenticated node's port can read its state, send it commands and call its
    API. So a node serves only this machine (loopback) unless the station names this machine's keys
    (`keys`, made by `rio keys generate`: zmq CURVE, zenoh mutual TLS and access control; a middleware
    without authentication refuses them) or says `insecure = true`, and then every start says so
    (`warn_if_exposed`). Without keys, reach other machines through a tunnel (ssh -L, WireGuard) that
    keeps the node on loopback, or a network you trust."""

    #: False for a middleware that has no authentication (portal): it refuses `keys`.
    authenticates: ClassVar[bool] = True
    insecure: bool = Field(False, description="allow serving or connecting beyond this machine without "
                                              "authentication (anyone who reaches the port controls the node)")
    keys: str | None = Field(None, description="this machine's keys directory, made by `rio keys generate` "
                                               "(the same path on every machine, each holding its own keys): "
                                               "authenticates and encrypts every link")
    #: Interface a node's server binds (each middleware says more on its own `host`).
    host: str = "127.0.0.1"
    max_message_bytes: int = Field(4 << 20, ge=1024, description="largest message (API call or request) a node "
                                   "accepts; a peer sending more is refused before anything is allocated for it "
                                   "(raised to fit the node's request record where that is larger)")

    def message_limit(self, layouts: NodeLayouts) -> int:
        """`max_message_bytes`, raised to fit one request record and a call's envelope."""
        record = layouts.request.itemsize if layouts.request is not None else 0
        return max(self.max_message_bytes, record + _MESSAGE_HEADROOM)

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
    import ipaddress

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


def machine_id() -> str:
    """This kernel *and* PID namespace: a pid in an address is meaningful only to a client with the
    same id (same machine, not another container). Falls back to the host name."""
    try:
        with open("/proc/sys/kernel/random/boot_id") as f:
            boot = f.read().strip()
        return f"{boot}/{os.stat('/proc/self/ns/pid').st_ino}"
    except OSError:
        return socket.gethostname()


def local_process_watch(address: dict[str, Any], node: str) -> ProcessWatch | None:
    """A watch on the server process when the address says it runs where this client can see its
    pid (ServerManager stamps "pid" and "machine"); None means liveness must come from heartbeats."""
    if "pid" in address and address.get("machine") == machine_id():
        return ProcessWatch(int(address["pid"]), node)
    return None


class ProcessWatch:
    """Knows, cheaply and exactly, whether a local process has exited (`rio.machine.host.process_exit_watch`:
    pidfd or kqueue; polled fallback)."""

    def __init__(self, pid: int, node: str, check_every_s: float = 0.02):
        self.pid, self.node, self.check_every_s = pid, node, check_every_s
        self._t_next = 0.0
        self._dead = False
        self._exit = host.process_exit_watch(pid)

    def dead(self) -> bool:
        if self._dead:
            return True
        if self._exit is not None:
            r, _, _ = select.select([self._exit], [], [], 0)
            self._dead = bool(r)
        else:
            self._dead = not host.pid_alive(self.pid)
        return self._dead

    def check(self) -> None:
        """Throttled: at most one syscall per `check_every_s` on the hot read path."""
        t = clock.now()
        if self._dead or t >= self._t_next:
            self._t_next = t + self.check_every_s
            if self.dead():
                raise NodeDiedError(self.node, f"server process {self.pid} exited")

    def close(self) -> None:
        if self._exit is not None:
            self._exit.close()
            self._exit = None
