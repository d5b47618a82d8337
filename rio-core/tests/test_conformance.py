"""The middleware conformance kit (`rio.conformance.middleware`), run unchanged on every built-in
middleware: the in-tree user of the kit, written exactly as a third-party middleware's test is.

Each case goes through the public API only (serve / connect / ServerManager) with the nodes from
`rio.testing`; a third-party middleware subclasses the same class (or runs `pytest --rio-middleware NAME`).
"""

from __future__ import annotations

from rio.conformance.middleware import MiddlewareConformance


class TestThread(MiddlewareConformance):
    middleware = "thread"


class TestShm(MiddlewareConformance):
    middleware = "shm"


class TestZmq(MiddlewareConformance):
    middleware = "zmq"


class TestZenoh(MiddlewareConformance):
    middleware = "zenoh"


class TestPortal(MiddlewareConformance):
    middleware = "portal"

