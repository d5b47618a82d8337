"""Ring references: naming a node's ring buffer so that another consumer on the same machine reads it in
place instead of receiving copies of its samples.

`connect` gives every client a `ring_ref` (plain JSON) when its middleware shares rings (`shm`: a
shared-memory segment any local process maps; `thread`: one object in this process) and None on
network middlewares, whose clients read mirrors. The policy node uses it to take camera frames straight
from the camera nodes' rings (`rio.policy.frames`), so a request carries a frame's timestamp, not its
pixels.

A reference holds what opening the ring needs without importing the node's driver: the middleware
(import path and options), the station, the node's name, the ring's part of its address, the sample's
fields (name -> dtype, shape) and the ring's capacity. The ring is opened through the middleware's own
`make_client`, so the layout fingerprint check and the slot checks (`rio.runtime.slot_check`) apply as to any client.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rio.errors import ConfigError
from rio.plugins.specs import import_path
from rio.runtime.layout import Layout
from rio.runtime.node import Node
from rio.runtime.transport import ClientTransport, Middleware, NodeLayouts, machine_id


def ring_reference(mw: Middleware, layouts: NodeLayouts, address: dict[str, Any]) -> dict[str, Any] | None:
    """How another consumer on this machine reads this node's ring buffer in place, or None."""
    if layouts.data is None:
        return None
    ring = mw.ring_address(address)
    if ring is None:
        return None
    cls = type(mw)
    return {"middleware": f"{cls.__module__}:{cls.__qualname__}", "options": mw.config.model_dump(mode="json"),
            "station": mw.station, "node": layouts.name, "address": ring, "capacity": layouts.buffer_capacity,
            "sample": {n: [dt, list(shape)] for n, (dt, shape) in layouts.data.describe().items()}}


class SharedRing:
    """A node's ring buffer opened from its reference (`ring_buffer`: a `rio.runtime.buffers.RingBuffer`);
    `close()` it."""

    def __init__(self, ref: dict[str, Any]):
        name = ref["node"]
        machine = ref["address"].get("machine")
        if machine is not None and machine != machine_id():
            raise ConfigError(f"node '{name}': its ring buffer is in another machine's memory; it cannot be read "
                              "in place from here")
        example = {n: np.zeros(tuple(shape), np.dtype(dt)) for n, (dt, shape) in ref["sample"].items()}
        layouts = NodeLayouts(name, Layout(example, owner=name), None, int(ref["capacity"]), 1)
        mw_cls: type[Middleware] = import_path(ref["middleware"])
        mw = mw_cls(station=ref["station"], **ref.get("options", {}))
        reader = Node()
        reader.name = name
        try:
            self.transport: ClientTransport = mw.make_client(reader, layouts, ref["address"])
        except Exception as e:  # a thread middleware's ring asked for from another process, say
            raise ConfigError(f"node '{name}': its ring buffer cannot be read in place from here "
                              f"({type(e).__name__}: {e})") from e
        self.name = name
        self.ring_buffer = self.transport.ring_buffer

    def close(self) -> None:
        self.transport.close()


__all__ = ["ring_reference", "SharedRing"]
