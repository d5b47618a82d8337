"""The middleware conformance kit (`rio.conformance.middleware`), run unchanged on every built-in
middleware: the in-tree user of the kit, written exactly as a third-party middleware's test is.

Each case goes through the public API only (serve / connect / ServerManager) with the nodes from
`rio.testing`; a third-party middleware subclasses the same class (or runs `pytest --rio-middleware NAME`).
The flood cases run once more with keys on the middlewares that authenticate (portal has no keys).
"""

from __future__ import annotations

import pytest

from rio.conformance.middleware import FloodConformance, MiddlewareConformance


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



# -- floods by authenticated peers: the flooders hold the station's keys too ---------------------------
def _keys(tmp_path_factory) -> str:
    from rio.machine import keys

    root = tmp_path_factory.mktemp("keys")
    keys.generate(root, ["robot"])
    return str(root / "robot")


class TestZmqTrustedFloods(FloodConformance):
    @pytest.fixture(scope="class")
    @classmethod
    def mw(cls, tmp_path_factory):
        from rio.middleware.zmq import ZmqMiddleware

        return ZmqMiddleware(keys=_keys(tmp_path_factory))


class TestZenohTrustedFloods(FloodConformance):
    @pytest.fixture(scope="class")
    @classmethod
    def mw(cls, tmp_path_factory):
        pytest.importorskip("zenoh")
        from rio.middleware.zenoh import ZenohMiddleware

        return ZenohMiddleware(keys=_keys(tmp_path_factory), station="floods")
