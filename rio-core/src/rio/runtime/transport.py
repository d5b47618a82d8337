"""The one interface every middleware implements (built-in or third-party).

A middleware answers four questions, nothing else:
- `prepare` / `release` (in the process that runs `ServerManager`): create and destroy what must
  outlive a crashed server (shared-memory segments, a run directory).
- `make_server` (where the node runs): the ring buffer the node writes, the request queue it reads,
  and `start(dispatch)` to begin answering API calls; returns an address (plain JSON-able dict).
- `make_client` (anywhere): a local ring buffer mirror that reads never block on, a request sender,
  `call()` for remote API methods, and `check_alive()` that turns a dead server into NodeDiedError.

The network middlewares share one protocol and its settings (`rio.middleware.protocol`); what is here is
what every middleware needs, including the ones that never leave the machine.
"""

from __future__ import annotations

import os
import select
import socket
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from pydantic import Field

from rio import clock
from rio.config import Config, Configurable
from rio.errors import NodeDiedError
from rio.machine import host
from rio.runtime.layout import Layout
from rio.runtime.node import Node

if TYPE_CHECKING:
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


def machine_id() -> str:
    """This kernel *and* PID namespace: a pid in an address is meaningful only to a client with the
    same id (same machine, not another container). Falls back to the host name."""
    try:
        with open("/proc/sys/kernel/random/boot_id") as f:
            boot = f.read().strip()
        return f"{boot}/{os.stat('/proc/self/ns/pid').st_ino}"
    except OSError:
        return socket.gethostname()


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
