"""`make_station`: a validated station -> (servers, clients, env), the paper's factory.

This is the only place that imports node classes, the middleware class and the embodiment class, so
a station that does not use a vendor's driver never imports its SDK. Every server and client shares
one middleware instance whose namespace is the station's name.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from pydantic import ValidationError

from ..config import error_lines
from ..errors import ConfigError
from ..plugins import Registry, get_registry
from . import roles as R
from .load import load_station
from .model import Station

if TYPE_CHECKING:
    from ..embodiments.base import Embodiment
    from ..env import Env
    from ..manager import ServedNode
    from ..middleware.base import Middleware
    from ..node import Node

N = TypeVar("N", bound="Node")


class ClientFactory(Generic[N]):
    """Connects a client for one role: `clients["teleop"]()` returns what `rio.connect` returns, a
    NodeClient proxy (a context manager) typed as the role's node class."""

    def __init__(self, role: str, cls: type[N], mw: Middleware, kwargs: dict[str, Any]):
        self.role, self.cls, self.mw, self.kwargs = role, cls, mw, kwargs

    def __call__(self) -> N:
        from ..manager import connect

        return connect(self.cls, self.mw, name=self.role, **self.kwargs)

    def __repr__(self) -> str:
        return f"<ClientFactory '{self.role}' ({self.cls.__name__} over {self.mw.name})>"


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
    from ..embodiments.infer import infer_embodiment

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
                 ) -> tuple[dict[str, ServedNode], dict[str, ClientFactory[Node]], Env | None]:
    """Build a station (path, registered name or `Station`) into `(servers, clients, env)`.

    - servers: {role: ServedNode}, to pass to `ServerManager(servers)`;
    - clients: {role: ClientFactory}, each call connects a NodeClient (use as a context manager);
    - env: an `Env` over the inferred embodiment and every camera (`with env: ...`), or None when the
      roles make no embodiment (a teleop- or camera-only station).

    `middleware=` overrides the file's middleware (its options then default to none).
    """
    from ..env import Env
    from ..manager import serve

    st = load_station(station, registry=registry)
    mw = resolve_middleware(st, middleware, middleware_options, registry)
    emb_cls, emb_options = resolve_embodiment(st, registry)
    servers: dict[str, ServedNode] = {}
    clients: dict[str, ClientFactory[Node]] = {}
    for role, comp in st.components.items():
        cls, kwargs = load_node_class(st, role), comp.kwargs()
        try:
            servers[role] = serve(cls, mw, name=role, **kwargs)
        except ConfigError as e:  # the node's setup() refused a validated config
            raise ConfigError(f"{st.source}: components.{role}: driver '{comp.driver}' rejected its config: {e}") from e
        clients[role] = ClientFactory(role, cls, mw, kwargs)
    env = None
    if emb_cls is not None:
        robot = {r: clients[r] for r in sorted(emb_cls.roles() & st.roles())}
        cameras = {R.camera_name(r): clients[r] for r in sorted(st.roles()) if R.kind_of(r) == "camera"}
        sensors = {R.sensor_name(r): clients[r] for r in sorted(st.roles()) if R.kind_of(r) == "sensor"}
        env = Env(emb_cls, emb_options, robot, cameras, sensors, rate_hz=st.rate_hz, station=st.name)
    return servers, clients, env
