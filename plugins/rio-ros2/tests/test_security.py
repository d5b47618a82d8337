"""The bridge's open door, closed like a station's (`rio_ros2.security`): an endpoint beyond loopback is
refused without keys, before the station starts; `--insecure` lets it through and every start says so;
with a machine's keys every link is mutual TLS with the station's CA and only machines those keys trust
see the domain's traffic (a plain tcp peer, or a certificate from another CA, cannot connect)."""

from __future__ import annotations

import json
import logging
import socket
import time

import pytest

from rio.cli import main as rio_main
from rio.errors import ConfigError
from rio.machine import keys as K


class _Started(BaseException):  # noqa: N818 - the marker that the station would have started
    pass


@pytest.fixture
def nothing_starts(monkeypatch):
    from rio.runtime.manager import ServerManager

    def started(*_a, **_k):
        raise _Started

    monkeypatch.setattr(ServerManager, "__enter__", started)


@pytest.mark.parametrize(("args", "named"), [
    (["--listen", "tcp/0.0.0.0:7447"], "--listen tcp/0.0.0.0:7447"),
    (["--listen", "tcp/[::]:7447"], "--listen tcp/[::]:7447"),
    (["--connect", "tcp/192.0.2.1:7447"], "--connect tcp/192.0.2.1:7447"),
    (["--connect", "tcp/ros-machine.lan:7447", "--read-only"], "--connect tcp/ros-machine.lan:7447"),
    (["--listen", "tcp/127.0.0.1:0", "--connect", "tcp/10.0.0.2:7447"], "--connect tcp/10.0.0.2:7447"),
])
def test_endpoints_beyond_loopback_without_keys_are_refused_before_the_station_starts(
        station_file, capsys, nothing_starts, args, named):
    assert rio_main(["ros2", "bridge", str(station_file), *args]) == 1
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err, err
    text = " ".join(lines[0].split())
    assert named in text and "without authentication" in text and "--insecure" in text and "--keys" in text


def test_loopback_needs_no_keys_and_says_nothing(station_file, caplog, nothing_starts):
    with caplog.at_level(logging.WARNING, "rio.ros2"), pytest.raises(_Started):
        rio_main(["ros2", "bridge", str(station_file), "--listen", "tcp/127.0.0.1:0", "--connect",
                  "tcp/[::1]:7447", "--connect", "tcp/localhost:7447"])
    assert "WITHOUT authentication" not in caplog.text


def test_insecure_is_let_through_and_every_start_says_so(station_file, caplog, nothing_starts):
    for _ in range(2):
        with caplog.at_level(logging.WARNING, "rio.ros2"), pytest.raises(_Started):
            rio_main(["ros2", "bridge", str(station_file), "--listen", "tcp/0.0.0.0:0", "--insecure"])
    said = [r.getMessage() for r in caplog.records if "WITHOUT authentication (--insecure)" in r.getMessage()]
    assert len(said) == 2 and "tcp/0.0.0.0:0" in said[0] and "command its arms" in said[0]


def test_open_bridge_itself_refuses_without_keys(station_file, nothing_starts):
    """The library call, not only the command line: a script gets the same refusal."""
    from rio_ros2.station import RosOptions, open_bridge

    with pytest.raises(ConfigError, match=r"--listen tcp/0\.0\.0\.0:0"), \
            open_bridge(station_file, ros=RosOptions(listen=("tcp/0.0.0.0:0",))):
        pass


# -- with keys: mutual TLS --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def station_keys(tmp_path_factory):
    root = tmp_path_factory.mktemp("keys")
    K.generate(root, ["robot", "ros"])
    other = tmp_path_factory.mktemp("other-ca")
    K.generate(other, ["ros"])
    return {"robot": root / "robot", "ros": root / "ros", "other_ca": other / "ros"}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _peer(key_dir, endpoint: str, domain: int):
    """A zenoh session of the 'ROS machine', connecting to `endpoint` with `key_dir`'s keys (None: plain)."""
    import zenoh
    from rio_ros2.security import ROS_MESSAGES, key_exprs

    from rio.middleware.zenoh import secure_links

    c = zenoh.Config()
    c.insert_json5("mode", '"peer"')
    c.insert_json5("scouting/multicast/enabled", "false")
    c.insert_json5("listen/endpoints", "[]")
    c.insert_json5("connect/endpoints", json.dumps([endpoint]))
    c.insert_json5("connect/exit_on_failure", "true")
    c.insert_json5("connect/timeout_ms", "3000")
    if key_dir is not None:
        for path, value in secure_links(K.load(key_dir), key_exprs(domain), ROS_MESSAGES).items():
            c.insert_json5(path, json.dumps(value))
    return zenoh.open(c)


def test_with_keys_every_link_is_mutual_tls_and_only_trusted_machines_connect(station_keys):
    import numpy as np
    import zenoh
    from rio_ros2.messages import message_types
    from rio_ros2.rmw import RosNode
    from rio_ros2.to_ros import joint_state

    port, domain = _free_port(), 21
    types = message_types("jazzy")
    with RosNode("rio_secure", domain=domain, types=types, connect=(), listen=(f"tcp/127.0.0.1:{port}",),
                 keys=K.load(station_keys["robot"])) as node:
        pub = node.publisher("/arm/joint_states", "sensor_msgs/msg/JointState")
        got = []
        peer = _peer(station_keys["ros"], f"tls/127.0.0.1:{port}", domain)  # the trusted ROS machine
        try:
            peer.declare_subscriber(f"{domain}/arm/joint_states/**", lambda s: got.append(s))
            msg = joint_state(types, ["j1"], {"joint_pos": np.zeros(1)}, 0.0)
            t_end = time.monotonic() + 20
            while not got and time.monotonic() < t_end:
                pub.publish(msg)
                time.sleep(0.05)
            assert got, "the trusted machine received nothing over TLS"
        finally:
            peer.close()
        with pytest.raises(zenoh.ZError):  # a plain tcp peer cannot even connect to a tls-only session
            _peer(None, f"tcp/127.0.0.1:{port}", domain)
        with pytest.raises(zenoh.ZError):  # nor can a machine whose certificate another CA signed
            _peer(station_keys["other_ca"], f"tls/127.0.0.1:{port}", domain)
