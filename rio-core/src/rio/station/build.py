"""`make_station`: a validated station -> (servers, clients, env), the paper's factory.

This is the only place that imports node classes, the middleware class and the embodiment class, so
a station that does not use a vendor's driver never imports its SDK. Every server and client shares
one middleware instance whose namespace is the station's name.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from pydantic import ValidationError

from rio.config import error_lines
from rio.errors import ConfigError
from rio.plugins import Registry, get_registry
from rio.station import roles as R
from rio.station.load import load_station
from rio.station.model import Station

if TYPE_CHECKING:
    from rio.embodiments.base import Embodiment
    from rio.env import Env
    from rio.runtime.manager import ServedNode
    from rio.runtime.node import Node
    from rio.runtime.transport import Middleware

N = TypeVar("N", bound="Node")


class ClientFactory(Generic[N]):
    """Connects a client for one role: `clients["teleop"]()` returns what `rio.connect` returns, a
    NodeClient proxy (a context manager) typed as the role's node class. `address`: where a node served
    on another machine is reached (None: a node this process serves)."""

    def __init__(self, role: str, cls: type[N], mw: Middleware, config: Any, address: dict[str, Any] | None = None):
        self.role, self.cls, self.mw, self.config, self.address = role, cls, mw, config, address

    def __call__(self) -> N:
        from rio.runtime.manager import connect

        return connect(self.cls, self.mw, name=self.role, address=self.address, config=self.config)

    def __repr__(self) -> str:
        where = f" on {self.address}" if self.address else ""
        return f"<ClientFactory '{self.role}' ({self.cls.__name__} over {self.mw.name}{where})>"


def resolve_middleware(station: Station, name: str | None = None, options: dict[str, Any] | None = None,
                       registry: Registry | None = None) -> Middleware:
    """The station's middleware instance (name/options overridable), options checked by its `Config`."""
    reg = registry or get_registry()
    mw_name = name or station.middleware
    opts = station.middleware_options if options is None else options
    if name is not None and name != station.middleware and options is None:
        opts = {}  # the file's options belong to the file's middleware
    try:
        cls = reg.find("rio_middlewares", mw_name, "middleware").load()
    except ConfigError as e:
        raise ConfigError(f"{station.source}: middleware.name: {e}") from None
    except ImportError as e:
        raise ConfigError(f"{station.source}: middleware '{mw_name}' cannot be imported ({e}); "
                          "run `rio doctor` to see what to install") from None
    try:
        config = cls.Config.model_validate(opts)
    except ValidationError as e:
        raise ConfigError(f"invalid station {station.source}:\n  "
                          + "\n  ".join(error_lines(e, "middleware", cls.Config))) from None
    return cls(config, station=station.name)


def resolve_embodiment(station: Station, registry: Registry | None = None) -> tuple[type[Embodiment] | None, Any]:
    """(Embodiment class, validated options), or (None, None) when the roles make no embodiment."""
    from rio.embodiments.infer import infer_embodiment

    try:
        spec = infer_embodiment(station.roles(), station.embodiment, registry)
    except ConfigError as e:
        raise ConfigError(f"{station.source}: {e}") from None
    if spec is None:
        if station.embodiment_options:
            raise ConfigError(f"{station.source}: [embodiment] options given but no embodiment fits "
                              f"roles {sorted(station.roles())}")
        return None, None
    cls = spec.load()
    try:
        config = cls.Config.model_validate(station.embodiment_options)
    except ValidationError as e:
        raise ConfigError(f"invalid station {station.source}:\n  "
                          + "\n  ".join(error_lines(e, "embodiment", cls.Config))) from None
    return cls, config


def load_node_class(station: Station, role: str) -> type[Node]:
    comp = station.components[role]
    try:
        return comp.node_class()
    except ImportError as e:
        raise ConfigError(f"{station.source}: components.{role}: driver '{comp.driver}' (plugin {comp.spec.plugin}) "
                          f"cannot be imported: {e}. Is its vendor SDK installed? (`rio doctor`)") from None


def make_station(station: str | os.PathLike | Station, *, middleware: str | None = None,
                 middleware_options: dict[str, Any] | None = None, registry: Registry | None = None,
                 machine: str | None = None,
                 ) -> tuple[dict[str, ServedNode], dict[str, ClientFactory[Node]], Env | None]:
    """Build a station (path, registered name or `Station`) into `(servers, clients, env)`.

    - servers: {role: ServedNode}, to pass to `ServerManager(servers)`;
    - clients: {role: ClientFactory}, each call connects a NodeClient (use as a context manager);
    - env: an `Env` over the inferred embodiment and every camera (`with env: ...`), or None when the
      roles make no embodiment (a teleop- or camera-only station).

    A station with `[machines]` is built for one machine: `machine=None` is where the control loop runs
    (it serves the roles placed nowhere and connects to the others at their fixed addresses); a machine's
    name gives only the servers placed there, at those addresses (what `rio serve --machine` runs).

    `middleware=` overrides the file's middleware (its options then default to none).
    """
    from rio.env import Env
    from rio.runtime.manager import serve

    st = load_station(station, registry=registry)
    mw = resolve_middleware(st, middleware, middleware_options, registry)
    if machine is not None and machine not in st.machines:
        raise ConfigError(f"{st.source}: no machine '{machine}' in [machines] "
                          f"(known: {', '.join(sorted(st.machines)) or 'none'})")
    emb_cls, emb_options = resolve_embodiment(st, registry)
    servers: dict[str, ServedNode] = {}
    clients: dict[str, ClientFactory[Node]] = {}
    for role, comp in st.components.items():
        where = st.machine_of(role)
        if where != machine and machine is not None:
            continue  # another machine's node: `rio serve` of this machine has nothing to do with it
        cls = load_node_class(st, role)
        node_mw, address = mw, None
        if where is not None:
            options, address = _placed(st, mw, role, where)
            if where == machine:
                node_mw, address = options, None
                _check_identity(st, node_mw, machine)
        if address is None:
            try:
                servers[role] = serve(cls, node_mw, name=role, config=comp.config)
            except ConfigError as e:  # the node's class refused a validated config
                raise ConfigError(f"{st.source}: components.{role}: driver '{comp.driver}' rejected its config: "
                                  f"{e}") from e
        clients[role] = ClientFactory(role, cls, node_mw, comp.config, address)
    # an arm's wrench source is served before the arm, so it is stopped after it (`ServerManager` stops in
    # reverse): an arm that outlived its source would log the source's end as a fault at every shutdown
    sourced = [s for c in st.components.values() if (s := getattr(c.config, "wrench_source", None)) in servers]
    servers = {**{s: servers[s] for s in sourced}, **servers}
    env = None
    if emb_cls is not None and machine is None:
        robot = {r: clients[r] for r in sorted(emb_cls.roles() & st.roles())}
        cameras = {R.camera_name(r): clients[r] for r in sorted(st.roles()) if R.kind_of(r) == "camera"}
        sensors = {R.sensor_name(r): clients[r] for r in sorted(st.roles()) if R.kind_of(r) == "sensor"}
        sources = {r: R.sensor_name(src) for r, c in st.components.items() if r in robot
                   and (src := getattr(c.config, "wrench_source", None)) is not None}
        env = Env(emb_cls, emb_options, robot, cameras, sensors, rate_hz=st.rate_hz, station=st.name,
                  drivers={r: c.driver for r, c in st.components.items()}, wrench_sources=sources)
    return servers, clients, env


def check_network(st: Station, mw: Middleware) -> None:
    """What a start checks of the station's network, without starting anything (`rio stations check`):
    every node placed on another machine (`[machines]`) is served there with options its middleware accepts,
    so an address beyond loopback without keys (or `insecure = true`) is refused here as at every start.
    The middleware's own options were checked when `mw` was made (`resolve_middleware`)."""
    for machine, sec in st.machines.items():
        for role in sec.nodes:
            _placed(st, mw, role, machine)


def _placed(st: Station, mw: Middleware, role: str, machine: str) -> tuple[Middleware, dict[str, Any]]:
    """(the middleware a placed node is served with on its machine, the address others reach it at)."""
    sec = st.machines[machine]
    try:
        options, address = mw.placed(role, sec.nodes.index(role), machine, sec)
        return mw.with_options(**options), address
    except ValidationError as e:
        raise ConfigError(f"invalid station {st.source}: machines.{machine} (node '{role}'):\n  "
                          + "\n  ".join(error_lines(e, "middleware", type(mw).Config))) from None
    except ConfigError as e:
        raise ConfigError(f"{st.source}: machines.{machine}: {e}") from None


def _check_identity(st: Station, mw: Middleware, machine: str) -> None:
    """The keys this machine serves with must be the ones its station name says: clients expect them."""
    keys = getattr(mw.config, "machine_keys", lambda: None)()
    if keys is not None and keys.identity != machine:
        raise ConfigError(f"{st.source}: serving as machine '{machine}' with the keys of machine '{keys.identity}' "
                          f"({keys.dir}): clients expect '{machine}''s key; copy that machine's keys directory here")
