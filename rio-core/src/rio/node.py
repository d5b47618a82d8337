"""The Node: one piece of hardware or one service, written once, runnable over any middleware.

A node author writes only hardware logic:

- `example_data` / `example_request` (set in `__init__`): dicts of arrays and scalars that fix the
  ring-buffer and request-queue slots. `__init__` must be cheap and touch no hardware: clients build
  the same object to learn the layout and the client-side methods.
- `open()` / `close()`: acquire and release the device (server side only).
- `read_state() -> dict`: one sample, for publishing loops.
- `handle_request(req: dict)`: apply one command, for request loops.
- `__api__`: the method names a client may call. Methods marked `@client_side` run in the client's
  process against its local ring buffer / request queue (never block); the rest run inside the node
  (a remote call, return values and exceptions carried back).

The runtime (`rio.runtime`) owns the loop, its timing, ready/exit events and error reporting.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping
from typing import Any, ClassVar, Literal

from .layout import Layout

LoopShape = Literal["pub", "req", "pubreq"]

_CLIENT_SIDE = "__rio_client_side__"


def client_side(fn: Callable) -> Callable:
    """Mark an `__api__` method to run in the client against its local buffers (no remote call)."""
    setattr(fn, _CLIENT_SIDE, True)
    return fn


def is_client_side(cls: type, method: str) -> bool:
    return bool(getattr(getattr(cls, method, None), _CLIENT_SIDE, False))


class Node:
    __api__: ClassVar[tuple[str, ...]] = ("get_state",)
    #: Loop shape. None infers it: publishes and accepts requests -> "pubreq"; only one -> that one.
    loop: ClassVar[LoopShape | None] = None
    #: Run the complementary operation ("pub" or "req") in a worker thread instead of the main loop.
    worker: ClassVar[Literal["pub", "req"] | None] = None
    rate_hz: float = 100.0
    buffer_capacity: ClassVar[int] = 64
    request_capacity: ClassVar[int] = 64

    example_data: Mapping[str, Any] | None = None
    example_request: Mapping[str, Any] | None = None

    # Bound by the runtime (server side) or by the client proxy (client side).
    name: str
    ring_buffer: Any = None
    request_queue: Any = None
    exit_event: threading.Event

    def __init__(self, *, rate_hz: float | None = None):
        if rate_hz is not None:
            self.rate_hz = float(rate_hz)
        self.name = type(self).__name__.lower()
        self.exit_event = threading.Event()

    # -- hardware logic (override) ------------------------------------------------------------------
    def open(self) -> None:
        """Acquire the device. Runs in the server before the node reports ready."""

    def close(self) -> None:
        """Release the device. Always runs once the loop ends, including after an error."""

    def read_state(self) -> Mapping[str, Any]:
        raise NotImplementedError(f"{type(self).__name__} publishes but does not define read_state()")

    def handle_request(self, request: dict[str, Any]) -> None:
        raise NotImplementedError(f"{type(self).__name__} takes requests but does not define handle_request()")

    # -- helpers usable by node code ----------------------------------------------------------------
    def publish(self, values: Mapping[str, Any]) -> None:
        """Publish a sample from anywhere in the node (e.g. an SDK callback thread)."""
        self.ring_buffer.put(values)

    # -- default client-side API --------------------------------------------------------------------
    @client_side
    def get_state(self, k: int | None = None, out: dict | None = None) -> dict[str, Any]:
        """Newest sample (or the k newest, oldest first) from the local ring buffer."""
        return self.ring_buffer.get(out=out) if k is None else self.ring_buffer.get_last_k(k, out=out)

    @client_side
    def send_request(self, request: Mapping[str, Any] | None = None, **fields: Any) -> None:
        """Validate and enqueue a request; raises InvalidRequest naming the field on bad input."""
        self.request_queue.put({**(request or {}), **fields})

    # -- introspection used by the runtime ----------------------------------------------------------
    def layouts(self) -> tuple[Layout | None, Layout | None]:
        data = Layout(self.example_data, owner=self.name, what="sample") if self.example_data else None
        req = Layout(self.example_request, owner=self.name, what="request") if self.example_request else None
        return data, req

    def loop_shape(self) -> LoopShape:
        if self.loop is not None:
            return self.loop
        pub, req = bool(self.example_data), bool(self.example_request)
        if pub and req:
            return "pubreq"
        if req:
            return "req"
        return "pub"

    @classmethod
    def remote_methods(cls) -> frozenset[str]:
        return frozenset(m for m in cls.__api__ if not is_client_side(cls, m))
