"""What a client needs to know of a node, sent by the node's server with its address.

A node is built once, where it runs: its server constructs it from the validated config and runs `setup()`,
which derives its sample and request layouts (and whatever else it needs) from the config. A client needs
only the layouts and the few values its client-side methods read (`Node.client_state`: an arm's joint names,
a gripper's full opening), so the server puts them in its address as plain JSON and `connect` makes the
client's node from them without constructing it or running `setup()` again — a client of a simulated world
does not compile its scene, a client of a policy node does not build the policy.

A node reached at an address that carries no description (one placed on another machine, whose address a
station computes without asking it) is still built on the client, as before; the handshake of the network
middlewares then checks that both sides agree on the layouts.
"""

from __future__ import annotations

import threading
from typing import Any, TypeVar

import numpy as np

from rio.runtime.layout import Layout
from rio.runtime.node import Node
from rio.runtime.transport import NodeLayouts

N = TypeVar("N", bound=Node)

#: The key of a node's address under which its server describes it.
KEY = "description"


def _layout(layout: Layout | None) -> list[list[Any]] | None:
    """A layout's fields, in order, as JSON: [[name, dtype, shape], ...]."""
    if layout is None:
        return None
    return [[name, dtype, list(shape)] for name, (dtype, shape) in layout.describe().items()]


def describe(node: Node, layouts: NodeLayouts) -> dict[str, Any]:
    """The description a server sends of its (set-up) node."""
    state = {}
    for attr in type(node).client_state:
        value = getattr(node, attr)
        state[attr] = value.tolist() if isinstance(value, np.ndarray) else value
    return {"data": _layout(layouts.data), "request": _layout(layouts.request),
            "buffer_capacity": layouts.buffer_capacity, "request_capacity": layouts.request_capacity,
            "state": state, "config": node.config.model_dump(mode="json")}


def client_config(cls: type[Node], name: str, config: Any, fields: dict[str, Any], description: dict[str, Any]) -> Any:
    """The config a client's node gets: the server's own when the caller gives none; else the caller's, which
    must agree with the server's on every field the caller sets (a client asking for another node than the
    one running is an error naming the fields, not a silently different node)."""
    from rio.config import validate_config
    from rio.errors import ConfigError

    served = description.get("config", {})
    if config is None and not fields:
        return cls.Config.model_validate(served)
    cfg = validate_config(cls.Config, config, fields)
    given = set(fields) | (set(config.model_fields_set) if hasattr(config, "model_fields_set") else set(config or {}))
    mine = cfg.model_dump(mode="json")
    differ = sorted(k for k in given if k in served and mine.get(k) != served[k])
    if differ:
        said = ", ".join(f"{k}={mine[k]!r} (it runs with {served[k]!r})" for k in differ)
        raise ConfigError(f"node '{name}': this client asks for {said}; connect with the server's config, or none")
    return cfg


def _rebuilt(fields: list[list[Any]] | None, owner: str, what: str) -> Layout | None:
    if fields is None:
        return None
    example = {name: np.zeros(tuple(shape), dtype=np.dtype(dtype)) for name, dtype, shape in fields}
    return Layout(example, owner=owner, what=what, add_timestamp=False)  # the timestamp is one of the fields


def layouts_of(description: dict[str, Any], name: str) -> NodeLayouts:
    """The node's layouts, rebuilt from its description (the same fields in the same order: the same
    fingerprint as the server's)."""
    return NodeLayouts(name, _rebuilt(description["data"], name, "sample"),
                       _rebuilt(description["request"], name, "request"),
                       int(description["buffer_capacity"]), int(description["request_capacity"]))


def client_node(cls: type[N], name: str, config: Any, description: dict[str, Any]) -> N:
    """The client side's instance of `cls`: its validated config, name and described state, no `setup()`.
    Its client-side methods run on it; its buffers are bound by the client proxy."""
    node = cls.__new__(cls)
    node.name, node.config, node.exit_event = name, config, threading.Event()
    for attr, value in description.get("state", {}).items():
        setattr(node, attr, value)
    return node
