"""What a station file contains, validated: the file's top-level schema (pydantic) and the
resolved `Station` (each component bound to its registered spec and validated config)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel, ConfigDict, Field

from rio.clock import RATE_RANGE_HZ
from rio.plugins.specs import Spec

if TYPE_CHECKING:
    from rio.runtime.node import Node


class MiddlewareSection(BaseModel):
    """`[middleware]`: `name` plus that middleware's own options (checked by its `Config` model)."""

    model_config = ConfigDict(extra="allow", allow_inf_nan=False)
    name: str = "shm"


class EmbodimentSection(BaseModel):
    """`[embodiment]` (optional): `name` overrides inference; other keys go to its `Config` model."""

    model_config = ConfigDict(extra="allow", allow_inf_nan=False)
    name: str | None = None


class MachineSection(BaseModel):
    """`[machines.<name>]`: nodes served on another machine (`rio serve STATION --machine <name>` there).

    The name is also the machine's name in the station's keys (`rio keys generate --name <name>`), so
    a client on another machine knows whose key to expect. Each node placed here gets fixed ports from
    `port` on (in `nodes` order; zmq takes two per node), so the other machines can reach it without a
    directory service."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    #: Host name or IP address at which the other machines reach this one.
    address: str = Field(min_length=1, max_length=253)
    #: Roles served there (the rest run where the control loop runs).
    nodes: list[str] = Field(min_length=1)
    #: First port of the nodes served there.
    port: int = Field(7600, ge=1024, le=65000)
    #: Interface the servers bind there: `address` by default ("0.0.0.0": every interface).
    bind: str | None = None


class StationFile(BaseModel):
    #: Every number finite (`rate_hz = inf` passed `gt=0` and made a loop that never sleeps), as in
    #: components' configs (`rio.config.Config`).
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    #: Also the middleware namespace (zenoh key expressions, shm segment names): keep it short.
    name: str = Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_\-]*$", max_length=64)
    description: str = ""
    #: Rate of the control loop (Hz), within `rio.clock.RATE_RANGE_HZ`; `Env.step` targets commands one
    #: period ahead by default.
    rate_hz: float = Field(30.0, ge=RATE_RANGE_HZ[0], le=RATE_RANGE_HZ[1])
    #: How long its nodes may take to be ready before the start is given up (a node that says how long it
    #: waits for its device, `connect_timeout_s`, gets that plus 15 s where longer). `--ready-timeout` overrides.
    ready_timeout_s: float = Field(60.0, gt=0, le=3600)
    middleware: MiddlewareSection = Field(default_factory=MiddlewareSection)
    embodiment: EmbodimentSection = Field(default_factory=EmbodimentSection)
    components: dict[str, dict[str, Any]] = Field(min_length=1)
    machines: dict[str, MachineSection] = Field(default_factory=dict)


@dataclass
class Component:
    role: str
    driver: str
    kind: str
    spec: Spec
    #: Validated driver config (an instance of the spec's config model).
    config: BaseModel

    def node_class(self) -> type[Node]:
        """The driver's (or policy's) Node class, imported from its plugin."""
        return self.spec.load()

    def kwargs(self) -> dict[str, Any]:
        """The node's constructor keyword arguments."""
        return self.config.model_dump()


@dataclass
class Station:
    name: str
    components: dict[str, Component]
    description: str = ""
    rate_hz: float = 30.0
    ready_timeout_s: float = 60.0
    middleware: str = "shm"
    middleware_options: dict[str, Any] = field(default_factory=dict)
    embodiment: str | None = None
    embodiment_options: dict[str, Any] = field(default_factory=dict)
    #: Where it was read from (file path, package resource, or "<dict>").
    source: str = "<dict>"
    #: Other machines and the roles they serve (`[machines]`); roles not placed run with the loop.
    machines: dict[str, MachineSection] = field(default_factory=dict)

    def machine_of(self, role: str) -> str | None:
        """The machine `role` is served on, or None: where the control loop runs."""
        return next((m for m, sec in self.machines.items() if role in sec.nodes), None)

    def roles(self) -> set[str]:
        return set(self.components)

    @property
    def has_cameras(self) -> bool:
        from rio.station.roles import kind_of

        return any(kind_of(r) == "camera" for r in self.components)
