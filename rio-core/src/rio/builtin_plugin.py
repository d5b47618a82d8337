"""The core's own plugin: the built-in middlewares, registered through the same hook a
third-party middleware uses."""

from __future__ import annotations

from .hookspecs import hookimpl
from .specs import Spec


@hookimpl
def rio_middlewares() -> list[Spec]:
    return [
        Spec("thread", "middleware", "rio.middleware.thread:ThreadMiddleware",
             "nodes as threads of one process; one stack trace, best for debugging"),
        Spec("shm", "middleware", "rio.middleware.shm:ShmMiddleware",
             "a process per node; state and requests in shared memory, zero-copy reads"),
        Spec("zmq", "middleware", "rio.middleware.zmq:ZmqMiddleware",
             "pyzmq over TCP; multi-machine; state mirrored into a local ring buffer"),
        Spec("zenoh", "middleware", "rio.middleware.zenoh:ZenohMiddleware",
             "eclipse-zenoh 1.x; multi-machine through routers; key expressions rio/<station>/<node>/*"),
        Spec("portal", "middleware", "rio.middleware.portal:PortalMiddleware",
             "danijar's portal RPC, as in the RIO paper"),
    ]
