"""The zenoh middleware with a station's keys: mutual TLS on every link, access control by machine name.

Keys as `rio keys generate` makes them: a station CA, a directory per machine ("robot" serves, "laptop"
is the trusted client). Attackers: a client without keys, a plain `tcp/` peer, a machine with keys from
another CA (that still trusts the robot's certificate), and a machine whose certificate is from the
station's own CA but whom the robot no longer trusts (its `peers/` entry removed)."""

from __future__ import annotations

import shutil
import time

import numpy as np
import pytest

zenoh = pytest.importorskip("zenoh")

import rio  # noqa: E402
from rio import ServerManager, connect, serve  # noqa: E402
from rio.conformance.middleware import send_in_turn  # noqa: E402
from rio.errors import ConfigError  # noqa: E402
from rio.machine import keys  # noqa: E402
from rio.middleware.protocol.messages import REQUEST_ID as _REQ_ID  # noqa: E402
from rio.middleware.zenoh import _SESSIONS, ZenohMiddleware, _config, _free_port  # noqa: E402
from rio.runtime import wire  # noqa: E402
from rio.testing import EchoNode, wait_until  # noqa: E402

STATION = "sec"


@pytest.fixture(scope="module")
def station_keys(tmp_path_factory):
    root = tmp_path_factory.mktemp("keys")
    keys.generate(root, ["robot", "laptop"])
    # a machine signed by the station's CA that the robot does not trust (removed from its peers/)
    keys.add(root, ["stranger"])
    (root / "robot" / "peers" / "stranger.key").unlink()
    # a machine of another station: its own CA signed its certificate; it holds the robot's CA (public,
    # in every machine's directory) so that only the robot's demand for a client certificate stops it
    other = tmp_path_factory.mktemp("other")
    keys.generate(other, ["laptop"])
    shutil.copyfile(root / "robot" / "ca.pem", other / "laptop" / "ca.pem")
    return {"robot": root / "robot", "laptop": root / "laptop", "stranger": root / "stranger",
            "other_ca": other / "laptop"}


@pytest.fixture(scope="module")
def robot(station_keys):
    opts = {"keys": str(station_keys["robot"])}
    with ServerManager("zenoh", [serve(EchoNode, name="echo")], station=STATION, mw_options=opts) as mgr:
        yield mgr


def _mw(key_dir=None, **options) -> ZenohMiddleware:
    return ZenohMiddleware(station=STATION, keys=None if key_dir is None else str(key_dir), **options)


def test_keyed_node_and_client_end_to_end_over_tls(robot, station_keys):
    """The trusted machine gets state, its requests are applied and answered, its calls return; every
    link of both sides is `tls/`."""
    addr = robot.address("echo")
    assert addr["endpoints"] and all(e.startswith("tls/127.0.0.1:") for e in addr["endpoints"]), addr
    with connect(EchoNode, _mw(station_keys["laptop"]), name="echo") as c:
        assert all(k.startswith("tls/") for k in c._transport._session_key[:1]), c._transport._session_key
        s1 = c.get_state()
        assert wait_until(lambda: c.get_state()["tick"] > s1["tick"] + 5), "no state over TLS"
        for i in range(20):  # back to back: a sender within its credits, waiting for one when it has none
            send_in_turn(c, 5.0, q=np.full(6, float(i)), client=1, seq=i)
        assert wait_until(lambda: np.allclose(c.get_state()["last"], 19.0)), "requests not applied"
        assert [tuple(x) for x in c.handled()][-20:] == [(1, i) for i in range(20)]
        payload = np.arange(256.0)
        np.testing.assert_array_equal(c.echo(payload), payload)
        with pytest.raises(rio.InvalidRequest, match="NaN"):
            c.send_request(q=np.array([0, np.nan, 0, 0, 0, 0.0]), client=1, seq=99)


def test_unkeyed_client_is_told_the_node_needs_keys(robot, station_keys):
    """A client without keys facing a keyed node gets a ConfigError naming the node at once (not a hang
    or a timeout), and a plain `tcp/` zenoh peer cannot connect to the node's port at all; a keyed
    client never talks to an unauthenticated (`tcp/`) node either."""
    addr = robot.address("echo")
    t0 = time.monotonic()
    with pytest.raises(ConfigError, match="'echo'.*keys"):
        connect(EchoNode, _mw(connect_timeout=3.0), name="echo")
    assert time.monotonic() - t0 < 3.0 + 30, "a refused client must not hang"
    tcp = [e.replace("tls/", "tcp/", 1) for e in addr["endpoints"]]
    with pytest.raises(Exception):  # noqa: B017 - zenoh raises its own ZError
        zenoh.open(_config("peer", [], tcp, 2.0)).close()
    with pytest.raises(ConfigError, match="'echo'.*without authentication"):
        connect(EchoNode, _mw(station_keys["laptop"]), name="echo",
                address={"prefix": f"rio/{STATION}/echo", "endpoints": tcp})


def test_certificate_from_another_ca_is_refused(robot, station_keys):
    """A machine whose certificate another CA signed cannot open a link to the node (mutual TLS: the
    node demands a client certificate from its own CA), even though it trusts the node's certificate."""
    addr = robot.address("echo")
    other = keys.load(station_keys["other_ca"])
    with pytest.raises(Exception):  # noqa: B017 - zenoh raises its own ZError
        zenoh.open(_config("peer", [], addr["endpoints"], 2.0, other, STATION)).close()
    t0 = time.monotonic()
    with pytest.raises(rio.NodeDiedError, match="'echo'.*cannot reach"):
        connect(EchoNode, _mw(station_keys["other_ca"], connect_timeout=2.0), name="echo")
    assert time.monotonic() - t0 < 2.0 + 30, "a refused client must not hang"


def test_same_ca_certificate_not_trusted_is_refused_by_access_control(robot, station_keys):
    """A certificate from the station's own CA for a machine the robot does not trust (not in its
    `peers/`) opens a link, but zenoh's access control lets nothing through: no state, no handshake,
    its requests are neither applied nor answered, its calls neither run nor return."""
    addr = robot.address("echo")
    prefix = addr["prefix"]
    with pytest.raises(rio.NodeDiedError, match="'echo'"):
        connect(EchoNode, _mw(station_keys["stranger"], connect_timeout=2.0), name="echo")
    s = zenoh.open(_config("peer", [], addr["endpoints"], 5.0, keys.load(station_keys["stranger"]), STATION))
    try:
        seen: list[str] = []
        for key in ("state", "hb", "ack/cafe", "reply/cafe"):
            s.declare_subscriber(f"{prefix}/{key}", lambda smp: seen.append(str(smp.key_expr)))
        layout = EchoNode().layouts()[1]
        rec = layout.encode({"q": np.full(6, 666.0), "client": 66, "seq": 0}, fill_timestamp=0.0).tobytes()
        for _ in range(5):
            s.put(f"{prefix}/req/cafe", _REQ_ID.pack(1) + rec)
            s.put(f"{prefix}/call/cafe", wire.pack_call(1, "echo", (5,), {}))
            time.sleep(0.2)
        assert list(s.get(f"{prefix}/hello", timeout=1.0)) == []
        time.sleep(1.0)  # the node publishes at 200 Hz and beats at 20 Hz meanwhile
        assert seen == [], seen[:5]
    finally:
        s.close()
    with connect(EchoNode, _mw(station_keys["laptop"]), name="echo") as c:
        assert all(client != 66 for client, _ in c.handled())
        assert not np.any(c.get_state(k=20)["last"] == 666.0)


def test_keyed_server_reaches_clients_through_a_keyed_router(tmp_path):
    """A client-mode server behind a router: its `connect = ["tcp/..."]` is reached as `tls/...` (the
    router here only speaks TLS, with its own certificate from the station's CA)."""
    keys.generate(tmp_path, ["robot", "laptop", "router"])
    port = _free_port("127.0.0.1")
    router = zenoh.open(_config("router", [f"tls/127.0.0.1:{port}"], [], 5.0, keys.load(tmp_path / "router"),
                                STATION))
    try:
        opts = {"mode": "client", "connect": [f"tcp/127.0.0.1:{port}"], "keys": str(tmp_path / "robot")}
        with ServerManager("zenoh", [serve(EchoNode, name="routed")], station=STATION, mw_options=opts) as mgr:
            assert mgr.address("routed")["endpoints"] == [f"tls/127.0.0.1:{port}"]
            with connect(EchoNode, _mw(tmp_path / "laptop"), name="routed") as c:
                assert c.echo(9) == 9
                c.send_request(q=np.full(6, 2.0), client=0, seq=0)
                assert wait_until(lambda: np.allclose(c.get_state()["last"], 2.0)), "request via router"
    finally:
        router.close()


def test_keys_with_a_non_tls_router_is_a_config_error(station_keys):
    with pytest.raises((ConfigError, ValueError), match="TLS"):
        ZenohMiddleware(keys=str(station_keys["laptop"]), connect=["udp/10.0.0.2:7447"])


def test_keyed_sessions_are_not_shared_with_unkeyed_ones(robot, station_keys):
    """A keyed client's session is keyed by its keys and station as well as its endpoints."""
    with connect(EchoNode, _mw(station_keys["laptop"]), name="echo") as c:
        key = c._transport._session_key
        assert any(str(k).startswith("keys=") for k in key) and f"station={STATION}" in key
        assert key in _SESSIONS._open


def test_a_node_placed_on_another_machine_is_reached_over_tls(station_keys):
    """`[machines]` placement: one fixed port per node from the machine's `port`, bound on its address,
    and with keys the address other machines connect to is `tls/` (a `tcp/` one would be refused)."""
    from rio.station.model import MachineSection

    sec = MachineSection(address="10.0.0.2", nodes=["wrist_camera", "arm"], port=7600)
    options, address = _mw(station_keys["laptop"]).placed("arm", 1, "robot", sec)
    assert options == {"host": "10.0.0.2", "port": 7601}
    assert address == {"prefix": f"rio/{STATION}/arm", "endpoints": ["tls/10.0.0.2:7601"]}
    _, plain = ZenohMiddleware(station=STATION, insecure=True).placed("arm", 1, "robot", sec)
    assert plain["endpoints"] == ["tcp/10.0.0.2:7601"]
