"""The xArm driver installed without `rio-ufactory[ik]`: the control box does the Cartesian control and reports
the pose, the workspace box is the model table's published reach, and asking for RIO's IK names the extra.

The solver is hidden from the driver only (`mujoco` made unimportable after the emulator built its own), so
the real driver code runs against the real SDK as it does on a machine without MuJoCo. A plain pip install
without MuJoCo is tests/test_light_install.py."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from rio_ufactory.arm.driver import XArm
from rio_ufactory.models import get_arm

from rio import clock
from rio.conformance.driving import Loop
from rio.kinematics.reach import reach_box_from_table
from rio.testing import lifecycle


@pytest.fixture
def no_solver(monkeypatch):
    """`import mujoco` fails from here on, as where rio-core[ik] is not installed."""
    monkeypatch.setitem(sys.modules, "mujoco", None)


def test_native_cartesian_control_runs_without_the_solver_inside_the_published_reach(make_emulator, monkeypatch):
    emu = make_emulator("xarm7")  # built first: its own kinematics stand for the control box's
    assert emu.machine.kin is not None
    monkeypatch.setitem(sys.modules, "mujoco", None)  # then the solver is gone for the driver
    with lifecycle(XArm(ip=emu.host, model="xarm7")) as arm:
        assert arm.kinematics is None
        box = arm.workspace()
        assert box["source"] == "table"
        lower, upper = reach_box_from_table(0.7, 0.267)
        np.testing.assert_allclose(box["lower"], lower)
        np.testing.assert_allclose(box["upper"], upper)
        start = arm.cycle()["eef_pose"]
        assert np.isfinite(start).all()  # measured by the control box, not computed
        goal = start.copy()
        goal[:3] += [0.03, -0.02, -0.04]
        arm.command_eef(goal, clock.now() + 1.0)
        s = Loop(arm).run(until=lambda s: np.linalg.norm(s["eef_pose"][:3] - goal[:3]) < 1e-3, timeout=8.0)
        assert np.linalg.norm(s["eef_pose"][:3] - goal[:3]) < 1e-3
        assert arm.poses is not None and np.allclose(arm.poses.lower, lower) and np.allclose(arm.poses.upper, upper)


def test_rios_ik_without_the_solver_refuses_to_open_naming_the_extra(make_emulator, no_solver):
    emu = make_emulator("xarm7")
    with pytest.raises(ImportError, match=r"node '.*': no IK solver .*pip install 'rio-ufactory\[ik\]'.*"
                                          r"eef_control = \"native\""):
        with lifecycle(XArm(ip=emu.host, model="xarm7", eef_control="ik")):
            pass


def test_the_computed_reach_wins_where_the_solver_is_installed(make_emulator):
    pytest.importorskip("mink")
    emu = make_emulator("lite6", gripper="lite6")
    with lifecycle(XArm(ip=emu.host, model="lite6")) as arm:
        box = arm.workspace()
        assert box["source"] == "model"
        lower, upper = reach_box_from_table(get_arm("lite6").reach, get_arm("lite6").shoulder_height)
        assert (np.asarray(box["lower"]) >= lower).all() and (np.asarray(box["upper"]) <= upper).all(), box


def test_the_emulator_node_of_a_station_names_the_extra_it_needs(no_solver):
    from rio_ufactory.emulator_node import EmulatorNode
    from rio_ufactory.loopback import PORT_502_HINT, can_listen_on_502, free_loopback

    if not can_listen_on_502():
        pytest.skip(PORT_502_HINT)
    with pytest.raises(ImportError, match=r"Cartesian commands and poses need .*pip install 'rio-ufactory\[ik\]'"):
        with lifecycle(EmulatorNode(ip=free_loopback())):
            pass
