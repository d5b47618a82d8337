"""Client proxy: what user code holds for a node (`arm.get_state()`, `arm.send_request(...)`).

It holds the client side's instance of the node class (made from the server's description of the node,
`rio.runtime.description`: its config, layouts and `client_state`, without `setup()`), whose client-side
methods run here on the middleware's client-side buffers. Only `__api__` names are exposed;
client-side ones run here, the others become remote calls. Every access first checks that the
server is alive, so a dead node is an error, never a silently stale value.
"""

from __future__ import annotations

from typing import Any

from rio.runtime.node import Node, is_client_side
from rio.runtime.transport import ClientTransport


class _Checked:
    """Forwards buffer methods to the transport's object after a (throttled) liveness check. The
    wrapped methods are built once per name: this sits on every client read at the control rate."""

    __slots__ = ("_obj", "_check", "_wrapped")

    def __init__(self, obj: Any, check: Any):
        self._obj, self._check = obj, check
        self._wrapped: dict[str, Any] = {}

    def __getattr__(self, attr: str) -> Any:
        fn = self._wrapped.get(attr)
        if fn is not None:
            return fn
        target = getattr(self._obj, attr)
        if not callable(target):
            return target
        check = self._check

        def checked(*args: Any, **kwargs: Any) -> Any:
            check()
            return target(*args, **kwargs)

        self._wrapped[attr] = checked
        return checked


class NodeClient:
    """Proxy for a running node. Use as a context manager, or call `close()`."""

    def __init__(self, node: Node, transport: ClientTransport, ring_ref: dict[str, Any] | None = None,
                 reference: dict[str, Any] | None = None):
        self._node, self._transport = node, transport
        self.name = node.name
        #: How another process connects a client of this node (`rio.runtime.peer`: JSON, for a remote call).
        self.reference = reference
        #: How another consumer on this machine reads this node's ring buffer in place (`rio.runtime.ring_ref`),
        #: or None (network middlewares, nodes that publish nothing).
        self.ring_ref = ring_ref
        check = transport.check_alive
        node.ring_buffer = None if transport.ring_buffer is None else _Checked(transport.ring_buffer, check)
        node.request_queue = None if transport.request_queue is None else _Checked(transport.request_queue, check)
        cls = type(node)
        self._api: dict[str, Any] = {}
        for m in cls.__api__:
            if is_client_side(cls, m):
                self._api[m] = getattr(node, m)
            else:
                self._api[m] = self._remote(m)

    def _remote(self, method: str) -> Any:
        call = self._transport.call

        def remote(*args: Any, **kwargs: Any) -> Any:
            return call(method, args, kwargs)

        remote.__name__ = method
        remote.__doc__ = getattr(type(self._node), method).__doc__
        return remote

    def __getattr__(self, attr: str) -> Any:
        api = self.__dict__.get("_api", {})
        if attr in api:
            return api[attr]
        raise AttributeError(
            f"node '{self.__dict__.get('name', '?')}' has no API method '{attr}'; its __api__ is {sorted(api)}"
        )

    def __dir__(self) -> list[str]:
        return sorted(set(super().__dir__()) | set(self._api))

    def check_alive(self) -> None:
        self._transport.check_alive()

    def published(self) -> int | None:
        """Samples the node has published so far (its ring buffer's counter; None for a node without
        state): what the control loop's summary turns into per-node rates."""
        rb = self._node.ring_buffer
        return None if rb is None else int(rb.count)

    def close(self) -> None:
        self._transport.close()

    def __enter__(self) -> NodeClient:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"<NodeClient '{self.name}' ({type(self._node).__name__}) api={sorted(self._api)}>"
