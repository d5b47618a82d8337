"""A station behind the bridge: `open_bridge(station)` starts it and connects the bridge to it.

The bridge runs a station the way every workflow command does (`make_station`): this process serves
the station's nodes that no `[machines]` section places elsewhere, and connects to those placed on
other machines at their fixed addresses (where `rio serve STATION --machine NAME` runs them). Teleop
devices and policies are not started (ROS is the one commanding); grippers and sensors are, though not
bridged (a simulated world is a sensor its arms and cameras need). The ROS side is a node
`rio_<station>` on a zenoh session of its own (`rmw.RosNode`), on loopback unless keys are given or the
risk is accepted (`security`), checked before the station starts.
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from rio.station import roles as R

from . import security
from .bridge import Bridge, BridgeOptions, bridged_roles
from .messages import message_types
from .rmw import DEFAULT_CONNECT, DEFAULT_LISTEN, RosNode

#: Kinds of component the bridge does not start: what would command the robot besides ROS.
NOT_STARTED = ("teleop", "policy")


@dataclass(frozen=True)
class RosOptions:
    domain: int = 0
    distro: str = "jazzy"
    connect: Sequence[str] = DEFAULT_CONNECT
    listen: Sequence[str] = DEFAULT_LISTEN
    #: this machine's keys directory (`rio keys generate`): every link mutual TLS (`security`)
    keys: str | None = None
    #: allow endpoints beyond loopback without keys (every start says so)
    insecure: bool = False
    #: whether the bridge takes commands (for the warning's wording only: `BridgeOptions.commands` decides)
    commands: bool = True


@dataclass
class RunningBridge:
    bridge: Bridge
    manager: Any        # rio.runtime.manager.ServerManager of the nodes served here
    factories: dict     # {role: ClientFactory}: another client of a bridged node (`factories["arm"]()`)
    node_name: str

    def run(self, stop: Any) -> None:
        """Tick until `stop()`; a node of the station that stops ends the bridge with its name."""
        from rio.errors import RioError

        def done() -> bool:
            ended = self.manager.ended()
            if ended:
                raise RioError(f"node {', '.join(ended)} stopped; stopping the bridge")
            return bool(stop())

        self.bridge.run(done)


def node_name(station: str) -> str:
    """A valid ROS node name for the station ('so100-emulator' -> 'rio_so100_emulator')."""
    return "rio_" + re.sub(r"[^A-Za-z0-9_]", "_", station)


@contextlib.contextmanager
def open_bridge(station: Any, *, middleware: str | None = None, ros: RosOptions | None = None,
                options: BridgeOptions | None = None) -> Iterator[RunningBridge]:
    """Start `station` (name, path or `Station`), connect its joint devices and cameras, open the ROS node;
    yield a `RunningBridge`. Everything stops on exit."""
    from rio.errors import ConfigError
    from rio.runtime.manager import ServerManager
    from rio.station.build import make_station
    from rio.station.load import load_station

    ros = ros or RosOptions()
    keys = security.check(ros)  # endpoints beyond loopback without keys: refused before anything starts
    security.warn_if_exposed(ros)
    types = message_types(ros.distro)  # an unknown distribution fails before anything starts
    st = load_station(station)
    roles = bridged_roles(st.components)
    if not roles:
        raise ConfigError(f"station '{st.name}' has no arm, hand, humanoid or camera to bridge")
    servers, factories, _env = make_station(st, middleware=middleware)
    served = {r: s for r, s in servers.items() if R.kind_of(r) not in NOT_STARTED}
    with ServerManager(served, station=st.name) as manager, contextlib.ExitStack() as stack:
        clients = {r: stack.enter_context(factories[r]()) for r in roles}
        name = node_name(st.name)
        node = stack.enter_context(RosNode(name, namespace="/", domain=ros.domain, types=types,
                                           connect=ros.connect, listen=ros.listen, keys=keys))
        yield RunningBridge(Bridge(clients, node, options), manager, {r: factories[r] for r in roles}, name)
