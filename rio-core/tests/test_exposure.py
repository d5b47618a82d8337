"""Network middlewares serve only this machine unless the station says `insecure = true` (they have no
authentication yet), and then every start says so. The hardening probe found `host = "0.0.0.0"` passing
`rio stations check` without a word."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from rio.errors import ConfigError
from rio.middleware.protocol import is_loopback
from rio.runtime.transport import NodeLayouts
from rio.station import make_station, parse_station
from rio.testing import EchoNode


@pytest.mark.parametrize("addr, loopback", [
    ("127.0.0.1", True), ("127.0.0.2", True), ("localhost", True), ("::1", True), ("tcp/127.0.0.1:7447", True),
    ("tcp/[::1]:7447", True), ("127.0.0.1:5555", True),
    ("0.0.0.0", False), ("::", False), ("*", False), ("10.0.0.2", False), ("tcp/10.0.0.2:7447", False),
    ("robot.lab", False), ("", False),
])
def test_what_counts_as_this_machine(addr, loopback):
    assert is_loopback(addr) is loopback


def _station(middleware: dict) -> dict:
    return {"name": "exposed", "middleware": middleware, "components": {"arm": {"driver": "rio.fake_arm"}}}


@pytest.mark.parametrize("middleware", [
    {"name": "zmq", "host": "0.0.0.0"},
    {"name": "zenoh", "host": "0.0.0.0"},
    {"name": "zenoh", "connect": ["tcp/10.0.0.2:7447"], "mode": "client"},
    {"name": "portal", "host": "192.168.1.20"},
])
def test_a_node_reachable_from_other_machines_needs_insecure_true(middleware):
    pytest.importorskip({"zmq": "zmq", "zenoh": "zenoh", "portal": "portal"}[middleware["name"]])
    with pytest.raises(ConfigError, match=r"middleware: .*without authentication.*insecure = true"):
        make_station(parse_station(_station(middleware)))
    servers, _clients, _env = make_station(parse_station(_station({**middleware, "insecure": True})))
    assert set(servers) == {"arm"}


def test_loopback_stations_need_nothing():
    for mw in ({"name": "zmq"}, {"name": "zenoh", "connect": ["tcp/127.0.0.1:7447"]}, {"name": "portal"}):
        servers, _clients, _env = make_station(parse_station(_station(mw)))
        assert set(servers) == {"arm"}


def test_every_start_of_an_exposed_node_says_so(caplog):
    from rio.middleware.zmq import ZmqMiddleware, ZmqServer

    node = EchoNode()
    server = ZmqServer(node, NodeLayouts.of(node), ZmqMiddleware.Config(host="0.0.0.0", insecure=True))
    try:
        with caplog.at_level(logging.WARNING):
            address = server.start(lambda *a: None)
        assert address["host"] == "127.0.0.1" and np.isfinite(address["rpc_port"])
        assert "WITHOUT authentication (insecure = true)" in caplog.text and "0.0.0.0" in caplog.text
    finally:
        server.close()
