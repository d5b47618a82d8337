"""The Node: one piece of hardware or one service, written once, runnable over any middleware.

A node author writes only hardware logic:

- `Config`: the node's pydantic config model (see `rio.config`); the node receives it as `self.config`.
- `setup()`: cheap, touches no hardware: read `self.config` and set `example_data` / `example_request`
  (dicts of arrays and scalars that fix the ring-buffer and request-queue slots). Clients build the same
  object to learn the layout and the client-side methods.
- `open()` / `close()`: acquire and release the device (server side only).
- `read_state() -> dict`: one sample, for publishing loops.
- `cycle() -> dict`: what the runtime calls at `rate_hz` in a publishing loop: `read_state()` unless the
  node's kind says otherwise (the commanded kinds read, step their commander and write there).
- `handle_request(req: dict)`: apply one command, for request loops.
- methods marked `@remote` run inside the node when a client calls them (return values and exceptions
  carried back); methods marked `@client_side` run in the client's process against its local ring
  buffer / request queue (never block). The node's API (`__api__`) is exactly the marked methods, so
  a base class's API (an arm's `robot_description`, `home`, ...) is inherited without being listed.

The runtime (`rio.runtime.runner`) owns the loop, its timing, ready/exit events and error reporting; the
standard kinds (`rio.interfaces`) use `opened()` / `closing()` to run their contract (safety, enable)
around the driver's own `open()` / `close()`.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, ClassVar, Literal, TypeVar

from pydantic import Field

from rio.config import Config, validate_config
from rio.runtime.layout import Layout

LoopShape = Literal["pub", "req", "pubreq"]
F = TypeVar("F", bound=Callable[..., Any])
_N = TypeVar("_N", bound="Node")

_MARK = "__rio_api__"


def remote(fn: F) -> F:
    """Mark a method as part of the node's API, run inside the node when a client calls it."""
    setattr(fn, _MARK, "remote")
    return fn


def client_side(fn: F) -> F:
    """Mark a method as part of the node's API, run in the client against its local buffers."""
    setattr(fn, _MARK, "client")
    return fn


def api_kind(cls: type, method: str) -> str | None:
    """'remote', 'client' or None (not part of the API). An override keeps the mark of the method it
    overrides, so a driver implementing its kind's `robot_description()` needs no decorator."""
    for klass in cls.__mro__:
        mark = getattr(klass.__dict__.get(method), _MARK, None)
        if mark is not None:
            return mark
    return None


def is_client_side(cls: type, method: str) -> bool:
    return api_kind(cls, method) == "client"


class Node:
    """Validates its `Config` into `self.config` and calls `setup()`, as `rio.config.Configurable` does for
    other components, without inheriting it: a driver's class chain is its kind's plus its own, nothing more."""

    class Config(Config):
        """Fields every node accepts."""

        rate_hz: float = Field(100.0, gt=0, description="loop rate (Hz): state published / commands applied")
    #: The marked methods, derived for each class (never written by hand).
    __api__: ClassVar[tuple[str, ...]] = ()
    #: Loop shape. None infers it: publishes and accepts requests -> "pubreq"; only one -> that one.
    loop: ClassVar[LoopShape | None] = None
    #: Run the complementary operation ("pub" or "req") in a worker thread instead of the main loop.
    worker: ClassVar[Literal["pub", "req"] | None] = None
    buffer_capacity: ClassVar[int] = 64
    request_capacity: ClassVar[int] = 64
    #: Attributes `setup()` derives that client-side methods read (JSON values: numbers, strings, lists).
    #: The server sends them with its address (`rio.runtime.description`), so a client never runs `setup()`.
    client_state: ClassVar[tuple[str, ...]] = ()

    example_data: Mapping[str, Any] | None = None
    example_request: Mapping[str, Any] | None = None

    # Bound by the runtime (server side) or by the client proxy (client side).
    name: str
    ring_buffer: Any = None
    request_queue: Any = None
    exit_event: threading.Event

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if "__api__" in cls.__dict__:
            raise TypeError(f"{cls.__name__} lists __api__ by hand; mark its methods with @remote or "
                            "@client_side instead (the API is derived from them)")
        cls.__api__ = tuple(sorted(m for m in dir(cls) if api_kind(cls, m) is not None))

    config: Any

    def __init__(self, config: Any = None, /, **fields: Any):
        self.name = type(self).__name__.lower()
        self.exit_event = threading.Event()
        self.config = validate_config(type(self).Config, config, fields)
        self.setup()

    @property
    def rate_hz(self) -> float:
        return float(self.config.rate_hz)

    # -- hardware logic (override) ------------------------------------------------------------------
    def setup(self) -> None:
        """Declare layouts from `self.config`. Runs once, where the node is served (a client gets the layouts
        and `client_state` from the server): no hardware yet, that is `open()`'s."""

    def open(self) -> None:
        """Acquire the device. Runs in the server before the node reports ready."""

    def opened(self) -> None:
        """Runs after `open()`: where a kind's contract starts (the standard kinds use it; drivers don't)."""

    def closing(self) -> None:
        """Runs before `close()`, even after an error: where a kind's contract stops (e.g. disable)."""

    def close(self) -> None:
        """Release the device. Always runs once the loop ends, including after an error."""

    def read_state(self) -> Mapping[str, Any] | None:
        """This cycle's sample, or None to publish nothing this cycle (a camera with no new frame)."""
        raise NotImplementedError(f"{type(self).__name__} publishes but does not define read_state()")

    def cycle(self) -> Mapping[str, Any] | None:
        """One tick of a publishing loop, what the runtime calls at `rate_hz`; returns the sample to publish.
        A node that only reads is its `read_state()`; a commanded kind (`rio.interfaces`) reads the hardware,
        steps its commander and writes the goal here, in that order."""
        return self.read_state()

    def arrival_event(self) -> threading.Event | None:
        """For a node whose samples come from a thread of its own (a camera's grab thread): an Event it sets
        when a new sample is ready, so the runtime publishes it at once instead of at `rate_hz`. None (the
        default): published at `rate_hz`. Asked once, after `open()`."""
        return None

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
        if self.request_queue is None:
            from rio.errors import InvalidRequest

            raise InvalidRequest(self.name, None, f"{type(self).__name__} takes no requests")
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
        return frozenset(m for m in cls.__api__ if api_kind(cls, m) == "remote")

    if TYPE_CHECKING:
        # For type checkers only: `rio.connect(cls, ...)` returns a `NodeClient` proxy typed as `cls`,
        # and these are what the proxy adds to the node's API (a Node itself has none of them).
        def __enter__(self: _N) -> _N: ...
        def __exit__(self, *exc: Any) -> None: ...
        def check_alive(self) -> None: ...


NodeConfig = Node.Config


Node.__api__ = ("get_state", "send_request")
