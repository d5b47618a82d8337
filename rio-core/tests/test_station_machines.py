"""`[machines]` in station files: where each role runs, checked when the file is read, and what each
machine builds from it (`make_station(machine=...)`), without starting anything."""

from __future__ import annotations

import pytest

from rio.errors import ConfigError
from rio.station.build import make_station
from rio.station.load import parse_station


def _station(mw: dict, machines: dict) -> dict:
    return {"name": "two", "middleware": mw, "machines": machines,
            "components": {"arm": {"driver": "rio.fake_arm"}, "gripper": {"driver": "rio.fake_gripper"},
                           "teleop": {"driver": "teleop.scripted"}}}


ROBOT = {"robot": {"address": "10.0.0.2", "nodes": ["arm", "gripper"], "port": 7600}}


@pytest.mark.parametrize("machines, words", [
    ({"robot": {"address": "10.0.0.2", "nodes": ["wrist_camera"]}}, "not a component"),
    ({"a": {"address": "10.0.0.2", "nodes": ["arm"]}, "b": {"address": "10.0.0.3", "nodes": ["arm"]}},
     "already placed on machine 'a'"),
    ({"../x": {"address": "10.0.0.2", "nodes": ["arm"]}}, "machine name"),
    ({"robot": {"address": "10.0.0.2", "nodes": []}}, "machines.robot.nodes"),
    ({"robot": {"address": "10.0.0.2", "nodes": ["arm"], "port": 80}}, "machines.robot.port"),
])
def test_a_bad_placement_is_named_in_the_file(machines, words):
    with pytest.raises(ConfigError, match=words):
        parse_station(_station({"name": "zmq", "insecure": True}, machines))


def test_each_machine_builds_its_share_at_fixed_addresses():
    st = parse_station(_station({"name": "zmq", "insecure": True}, ROBOT))
    servers, clients, env = make_station(st, machine="robot")
    assert set(servers) == {"arm", "gripper"} and env is None  # the robot side serves, runs no loop
    assert servers["arm"].mw.config.host == "10.0.0.2"
    ports = {(s.mw.config.state_port, s.mw.config.rpc_port) for s in servers.values()}
    assert ports == {(7600, 7601), (7602, 7603)}  # two fixed ports per zmq node, in `nodes` order
    servers, clients, env = make_station(st)  # the loop's machine
    assert set(servers) == {"teleop"} and env is not None
    assert clients["arm"].address == {"host": "10.0.0.2", "state_port": 7600, "rpc_port": 7601, "heartbeat_s": 0.05}
    assert clients["teleop"].address is None


def test_a_placed_node_beyond_loopback_needs_keys_or_insecure():
    st = parse_station(_station({"name": "zmq"}, ROBOT))
    with pytest.raises(ConfigError, match="(?s)machines.robot.*without authentication"):
        make_station(st, machine="robot")


@pytest.mark.parametrize("mw", ["shm", "thread"])
def test_middlewares_of_one_machine_refuse_placement(mw):
    with pytest.raises(ConfigError, match="keeps every node on one machine"):
        make_station(parse_station(_station({"name": mw}, ROBOT)))


def test_an_unknown_machine_is_named():
    with pytest.raises(ConfigError, match="no machine 'lab' in \\[machines\\].*known: robot"):
        make_station(parse_station(_station({"name": "zmq", "insecure": True}, ROBOT)), machine="lab")
