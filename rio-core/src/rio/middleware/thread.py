"""Thread middleware: every node is a thread of the calling process.

Best for debugging: one process, one stack trace, breakpoints work, and remote API methods run
directly in the caller's thread (under the node's lock), so an exception shows both sides.
"""

from __future__ import annotations

import threading
from typing import Any

from rio.errors import NodeDiedError, NodeError
from rio.runtime.buffers import RequestQueue, RingBuffer
from rio.runtime.node import Node
from rio.runtime.transport import ClientTransport, Middleware, NodeLayouts, ServerTransport
from rio.runtime.wire import error_payload

# Servers of this process by (station, node name): the thread middleware's "address space".
_SERVERS: dict[tuple[str, str], ThreadServer] = {}
_LOCK = threading.Lock()


class ThreadServer(ServerTransport):
    def __init__(self, key: tuple[str, str], layouts: NodeLayouts):
        self.key = key
        self.ring_buffer = RingBuffer(layouts.data, layouts.buffer_capacity) if layouts.data else None
        self.request_queue = RequestQueue(layouts.request, layouts.request_capacity) if layouts.request else None
        self.dispatch: Any = None
        #: Set by the manager when the node's thread has ended (with the error, if any).
        self.ended: str | None = None

    def start(self, dispatch: Any) -> dict[str, Any]:
        self.dispatch = dispatch
        with _LOCK:
            _SERVERS[self.key] = self
        return {"station": self.key[0], "node": self.key[1]}

    def close(self) -> None:
        self.ended = self.ended or "stopped"
        with _LOCK:
            if _SERVERS.get(self.key) is self:
                del _SERVERS[self.key]


class ThreadClient(ClientTransport):
    def __init__(self, server: ThreadServer, name: str):
        self.server, self.name = server, name
        self.ring_buffer = server.ring_buffer
        self.request_queue = server.request_queue

    def check_alive(self) -> None:
        if self.server.ended is not None:
            raise NodeDiedError(self.name, f"node thread ended ({self.server.ended})")

    def call(self, method: str, args: tuple, kwargs: dict) -> Any:
        self.check_alive()
        try:
            return self.server.dispatch(method, args, kwargs)
        except Exception as e:
            raise NodeError(self.name, *error_payload(e)) from e


class ThreadMiddleware(Middleware):
    name = "thread"
    process_per_node = False

    def ring_address(self, address: dict[str, Any]) -> dict[str, Any] | None:
        """Every node of this process shares its ring buffer object: a client of the same process reads it in place."""
        return dict(address)

    def make_server(self, node: Node, layouts: NodeLayouts, resources: dict[str, Any]) -> ThreadServer:
        return ThreadServer((self.station, node.name), layouts)

    def make_client(self, node: Node, layouts: NodeLayouts, address: dict[str, Any]) -> ThreadClient:
        key = (address.get("station", self.station), address.get("node", node.name))
        with _LOCK:
            server = _SERVERS.get(key)
        if server is None:
            raise NodeDiedError(node.name, f"no thread server '{key[1]}' in station '{key[0]}' in this process")
        return ThreadClient(server, node.name)
