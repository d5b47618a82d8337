"""The plugin as a user meets it: registered drivers, stations and requirements; the packaged stations
validate without importing the SDK, cyclonedds or MuJoCo; and the `g1-sim` station runs: the bridge
and the driver as station components, a move of the left elbow seen in the bridge's ground truth."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from rio.plugins import Registry
from rio.station.load import load_station
from rio.testing import wait_until


def test_drivers_stations_and_requirements_are_registered():
    reg = Registry()
    assert not [p for p in reg.problems if "unitree" in p.plugin], reg.problems
    drivers = {s.name: s for s in reg.specs("rio_drivers") if s.plugin == "rio-unitree"}
    assert drivers["unitree.g1"].kind == "humanoid" and drivers["unitree.g1_23dof"].preset == {"dof": 23}
    assert drivers["unitree.bridge"].kind == "sensor" and drivers["unitree.dex3"].kind == "hand"
    stations = sorted(s.name for s in reg.specs("rio_stations") if s.plugin == "rio-unitree")
    assert {"g1", "g1-sim", "g1-sim-hands", "g1-sim-inspire"} <= set(stations) <= {
        "g1", "g1-sim", "g1-sim-hands", "g1-sim-floating", "g1-sim-inspire"}
    assert drivers["unitree.inspire"].kind == "hand"
    from rio_unitree.plugin import rio_requirements

    assert {r.module for r in rio_requirements()} == {"unitree_sdk2py", "cyclonedds", "mujoco"}


def test_stations_validate_without_importing_the_sdk():
    code = ("import sys; from rio.station.load import load_station\n"
            "for name in ('g1', 'g1-sim', 'g1-sim-hands', 'g1-sim-inspire'):\n"
            "    st = load_station(name); assert st.components['humanoid'].driver == 'unitree.g1'\n"
            "assert load_station('g1-sim-hands').components['hand2'].config.side == 'right'\n"
            "assert load_station('g1-sim-inspire').components['bridge_sensor'].config.hands == 'inspire'\n"
            "heavy = [m for m in ('cyclonedds', 'unitree_sdk2py', 'mujoco') if m in sys.modules]\n"
            "assert not heavy, heavy\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    real = load_station("g1").components["humanoid"].config
    assert (real.control, real.interface, real.domain_id) == ("arm_sdk", "eth0", 0)


def test_the_bridge_station_moves_the_simulated_robot(tmp_path, domain_id):
    pytest.importorskip("mujoco")
    from rio import ServerManager
    from rio.station import make_station
    from rio.station.load import read_station_text

    text, _ = read_station_text("g1-sim")
    text = text.replace("domain_id = 1", f"domain_id = {domain_id}").replace(
        'interface = "lo"\ndomain_id', 'interface = "lo"\nmodel = "fallback"\ndomain_id', 1)
    path = tmp_path / "g1-sim.toml"
    path.write_text(text)
    assert load_station(path).components["bridge_sensor"].config.model == "fallback"
    servers, clients, env = make_station(path, middleware="thread")
    with ServerManager(servers), clients["humanoid"]() as g1, clients["bridge_sensor"]() as bridge:
        q0 = np.asarray(g1.get_state()["joint_pos"])
        elbow = g1.joint_names().index("left_elbow_joint")
        target = q0.copy()
        target[elbow] -= 0.5
        g1.move_joints(target)  # now: as fast as max_step allows
        assert wait_until(lambda: abs(bridge.get_state()["joint_pos"][18] - target[elbow]) < 0.05, timeout=10.0)
        assert bridge.get_state()["bad_crc"] == 0 and g1.get_state()["fault_code"] == 0
