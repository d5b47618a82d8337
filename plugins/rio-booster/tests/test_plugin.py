"""The plugin as a user meets it: the registered driver, stations and requirement; the packaged stations
validate without importing the SDK; the `t1-fake` station runs (driver and emulated T1 in one
process) and a move of the left elbow reaches the emulated joints."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from rio.plugins import Registry
from rio.station.load import load_station
from rio.testing import wait_until


def test_driver_stations_and_requirements_are_registered():
    reg = Registry()
    assert not [p for p in reg.problems if "booster" in p.plugin], reg.problems
    drivers = {s.name: s for s in reg.specs("rio_drivers") if s.plugin == "rio-booster"}
    assert drivers["booster.t1"].kind == "humanoid"
    stations = sorted(s.name for s in reg.specs("rio_stations") if s.plugin == "rio-booster")
    assert stations == ["t1", "t1-fake", "t1-sim"]
    from rio_booster.plugin import rio_requirements

    assert {r.module for r in rio_requirements()} == {"booster_robotics_sdk_python"}


def test_stations_validate_without_importing_the_sdk():
    code = ("import sys; from rio.station.load import load_station\n"
            "for name in ('t1', 't1-fake', 't1-sim'):\n"
            "    st = load_station(name); assert st.components['humanoid'].driver == 'booster.t1'\n"
            "assert 'booster_robotics_sdk_python' not in sys.modules\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    real = load_station("t1").components["humanoid"].config
    assert real.sdk == "booster_robotics_sdk_python" and real.domain_id == 0 and real.on_stale == "damp"


def test_the_emulator_station_moves_the_emulated_robot():
    from rio_booster import emulator

    from rio import ServerManager
    from rio.station import make_station

    servers, clients, _ = make_station("t1-fake", middleware="thread")
    with ServerManager(servers), clients["humanoid"]() as t1:
        q0 = np.asarray(t1.get_state()["joint_pos"])
        elbow = t1.joint_names().index("Left_Elbow_Pitch")
        target = q0.copy()
        target[elbow] += 0.5
        t1.move_joints(target)
        robot = emulator.robot(0)
        assert robot is not None
        assert wait_until(lambda: abs(robot.joint_pos()[elbow] - target[elbow]) < 0.03, timeout=10.0)
        assert t1.get_state()["fault_code"] == 0
    assert emulator.robot(0) is None  # the channels that started it stopped it
