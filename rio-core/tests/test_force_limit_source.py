"""A separate wrench node as an arm's force-limit source (`wrench_source`): the station checks the name, the
arm's own process reads the sensor node through a client it connects from a reference (`rio.runtime.peer`),
a load over the limit holds it, and so does a source that is not connected, goes silent or dies, each
counted in `force_holds` (and `source_holds`). The reading and the dead source run on every middleware (the
arm's own client: in its thread, its process's shared memory, a network client); the rest on thread and shm."""

from __future__ import annotations

import importlib.util
import logging
import os
import signal
import time

import numpy as np
import pytest

from rio import clock
from rio.errors import ConfigError, NodeError
from rio.fakes.arms import FakeArm
from rio.fakes.sensors import FakeSensor, FakeWrench
from rio.runtime.manager import ServerManager, connect, serve
from rio.station.load import parse_station

LIMIT = {"force_n": 20.0, "source_timeout_s": 0.3}


def _needs(module: str) -> pytest.MarkDecorator:
    return pytest.mark.skipif(importlib.util.find_spec(module) is None, reason=f"{module} is not installed")


#: the arm reads the sensor node from its own thread or process on each: shared memory, network clients
EVERY_MIDDLEWARE = ["thread", "shm", "zmq", pytest.param("zenoh", marks=_needs("zenoh")),
                    pytest.param("portal", marks=_needs("portal"))]


def station(arm: dict, **more: dict) -> dict:
    comps = {"arm": {"driver": "rio.fake_arm", **arm}, **more}
    return {"name": "ftsrc", "middleware": {"name": "thread"}, "components": comps}


def test_the_station_checks_that_the_source_is_a_wrench_node():
    ok = parse_station(station({"force_limit": LIMIT, "wrench_source": "ft_sensor"},
                               ft_sensor={"driver": "rio.fake_wrench"}))
    assert ok.components["arm"].config.wrench_source == "ft_sensor"
    with pytest.raises(ConfigError, match=r"components\.arm\.wrench_source: 'wrist_ft_sensor' is not a component "
                                          r"of this station \(wrench sensors here: ft_sensor\)"):
        parse_station(station({"force_limit": LIMIT, "wrench_source": "wrist_ft_sensor"},
                              ft_sensor={"driver": "rio.fake_wrench"}))
    with pytest.raises(ConfigError, match=r"components\.arm\.wrench_source: 'world_sensor' is a 'rio.fake_sensor' "
                                          r"sensor, not a wrench sensor \(this station has no wrench sensor\)"):
        parse_station(station({"force_limit": LIMIT, "wrench_source": "world_sensor"},
                              world_sensor={"driver": "rio.fake_sensor"}))
    with pytest.raises(ConfigError, match=r"components\.arm.*wrench_source = 'ft_sensor' is set but force_limit "
                                          r"is not"):
        parse_station(station({"wrench_source": "ft_sensor"}, ft_sensor={"driver": "rio.fake_wrench"}))


def run_arm(arm, seconds: float) -> dict:
    """Wait `seconds` (the arm's own loop runs) and return its newest sample."""
    time.sleep(seconds)
    return arm.get_state()


def served(mw: str, load: list[float]):
    return ServerManager(mw, [
        serve(FakeArm, name="arm", dof=3, max_step_rad=0.05, force_limit={**LIMIT, "tare_on_enable": False},
              wrench_source="ft_sensor"),
        serve(FakeWrench, name="ft_sensor", load=load, noise=0.0, rate_hz=200.0),
    ], station=f"ftsrc-{mw}-{os.getpid()}")


@pytest.mark.parametrize("mw", ["thread", "shm"])
def test_a_load_over_the_limit_on_the_sensor_node_holds_the_arm(mw, caplog):
    with caplog.at_level(logging.INFO, logger="rio.control"), served(mw, [0.0, 0.0, -30.0, 0.0, 0.0, 0.0]) as mgr:
        with connect(FakeArm, mw, name="arm", station=mgr.station) as arm, \
                connect(FakeWrench, mw, name="ft_sensor", station=mgr.station) as ft:
            s = run_arm(arm, 0.1)  # no source handed over yet: held, counted
            assert s["force_holds"] == 1 and np.isnan(s["ext_wrench"]).all()
            arm.use_wrench_source(ft.reference)
            arm.move_joints([1.0, 0.0, 0.0], clock.now() + 0.5)
            s = run_arm(arm, 1.0)
    # the sensor's 30 N is over the 20 N limit from the first cycle it was read: the arm never left where it was,
    # and the hold that began while it had no source went on (one hold: never back under the limit meanwhile)
    assert s["ext_wrench"][2] == pytest.approx(-30.0)
    assert s["force_holds"] == 1 and s["holding"] and abs(s["joint_pos"][0]) < 1e-9
    assert s["source_holds"] == 1  # the one it began with: no source yet
    if mw == "thread":  # (the shm arm logs in its own process) starting up is no alarm
        start = [r for r in caplog.records if "its wrench source 'ft_sensor' is not connected" in r.getMessage()]
        assert [r.levelno for r in start] == [logging.INFO]


def test_a_reference_to_another_node_or_kind_is_refused():
    with ServerManager("thread", [
        serve(FakeArm, name="arm", dof=3, force_limit=LIMIT, wrench_source="ft_sensor"),
        serve(FakeWrench, name="ft_sensor"), serve(FakeSensor, name="other_sensor"),
    ], station=f"ftsrc-refs-{os.getpid()}") as mgr:
        with connect(FakeArm, "thread", name="arm", station=mgr.station) as arm, \
                connect(FakeSensor, "thread", name="other_sensor", station=mgr.station) as other:
            with pytest.raises(NodeError, match=r"handed a reference to node 'other_sensor', but the station "
                                                     r"names 'ft_sensor'"):
                arm.use_wrench_source(other.reference)
            ref = {**other.reference, "node": "ft_sensor"}  # the right name, the wrong kind
            with pytest.raises(NodeError, match="node 'ft_sensor' is a FakeSensor, not a wrench sensor"):
                arm.use_wrench_source(ref)
            assert arm.get_state()["holding"]  # still without a source: held


@pytest.mark.parametrize("mw", EVERY_MIDDLEWARE)
def test_a_dead_sensor_node_holds_the_arm(mw, caplog):
    with served(mw, [0.0, 0.0, -5.0, 0.0, 0.0, 0.0]) as mgr:
        with connect(FakeArm, mw, name="arm", station=mgr.station) as arm, \
                connect(FakeWrench, mw, name="ft_sensor", station=mgr.station) as ft:
            arm.use_wrench_source(ft.reference)
            s = run_arm(arm, 0.1)
            assert s["ext_wrench"][2] == pytest.approx(-5.0)  # within the limit: followed
            holds, silent = int(s["force_holds"]), int(s["source_holds"])
            arm.move_joints([3.0, 0.0, 0.0], clock.now() + 3.0)  # 1 rad/s
            s = run_arm(arm, 0.5)
            assert not s["holding"] and s["joint_pos"][0] > 0.1
            with caplog.at_level(logging.WARNING, logger="rio.control"):
                if mw == "shm":  # killed
                    os.kill(mgr.pids()["ft_sensor"], signal.SIGKILL)
                else:  # stopped (its thread or process ends)
                    next(h for h in mgr.handles if h.name == "ft_sensor").stop(2.0)
                q_dead = s["joint_pos"][0]
                s = run_arm(arm, 1.2)  # source_timeout_s (0.3 s) at most, then held
                later = run_arm(arm, 0.5)
    assert s["force_holds"] == holds + 1 and s["source_holds"] == silent + 1 and s["holding"], s
    # held within the timeout: at 1 rad/s it went on for 0.3 s at most (plus a loaded machine's late cycles)
    assert s["joint_pos"][0] - q_dead < 0.6 and later["joint_pos"][0] == pytest.approx(s["joint_pos"][0])
    assert later["joint_pos"][0] < 2.0
    if mw == "thread":  # the shm arm logs in its own process
        assert "node 'arm': its wrench source 'ft_sensor' " in caplog.text


def test_the_summary_counts_the_holds_of_a_silent_source_apart():
    from rio.loop.summary import ArmTracking, _arm_line

    pose = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    line = _arm_line(ArmTracking("arm", "eef_pose", pose, pose, force_holds=5, source_holds=1))
    assert "force limit held it 5 times (1 with its wrench source silent or gone)" in line
    assert "silent" not in _arm_line(ArmTracking("arm", "eef_pose", pose, pose, force_holds=2, source_holds=0))
