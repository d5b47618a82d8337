"""Client references: how a node (or any process) that was handed one connects its own client of another node.

A node runs where its server put it (a thread, its own process, another machine) and is started without
knowing its peers' addresses: they exist only once every node is ready. Where one node must read another
(an arm's force limit fed by a separate force/torque sensor node), whoever holds clients of both, once the
station is up, hands the reader a *reference* to the other: `client.reference` (plain JSON: what
`connect` needs, and nothing it would have to import from the station) sent through a remote call. The
reader connects with `connect_reference(ref)`, which is `rio.connect` itself, so the client it gets is
checked like every other: the layout fingerprint, liveness (a dead server is an error naming it), and on
network middlewares the handshake and the keys of the machine it runs on.

Unlike a ring reference (`rio.runtime.ring_ref`, same machine only, in place), this works on every
middleware: shared memory from another process, a network address from another machine (the address the
station gave the node it placed there, which every machine of the station reaches).
"""

from __future__ import annotations

from typing import Any

from rio.errors import ConfigError
from rio.plugins.specs import import_path
from rio.runtime.node import Node
from rio.runtime.transport import Middleware


def client_reference(cls: type[Node], mw: Middleware, name: str, address: dict[str, Any]) -> dict[str, Any]:
    """What `connect_reference` needs to connect another client of node `name` (JSON values only)."""
    mw_cls = type(mw)
    return {"node": name, "class": f"{cls.__module__}:{cls.__qualname__}",
            "middleware": f"{mw_cls.__module__}:{mw_cls.__qualname__}",
            "options": mw.config.model_dump(mode="json"), "station": mw.station, "address": address}


def connect_reference(ref: dict[str, Any]) -> Any:
    """A client (`rio.connect`'s `NodeClient`) of the node `ref` names, connected from this process."""
    from rio.runtime.manager import connect

    try:
        cls = import_path(ref["class"])
        mw = import_path(ref["middleware"])(station=ref["station"], **ref.get("options", {}))
    except (KeyError, ImportError, AttributeError, TypeError) as e:
        raise ConfigError(f"a client reference to node '{ref.get('node', '?')}' cannot be used here: "
                          f"{type(e).__name__}: {e}") from e
    return connect(cls, mw, name=ref["node"], address=ref["address"])


__all__ = ["client_reference", "connect_reference"]
