"""The arm driver on the fake franky backend (franky's own motion objects and exceptions, a modelled
control box: libfranka's 1 kHz UDP link is not emulated, see rio_franka.fake): joint and Cartesian
goals handed to franky as asynchronous motions, reflexes held as named faults and recovered, a
dropped link reconnected, and the set-up errors (versions, FCI) saying what to do."""

from __future__ import annotations

import numpy as np
import pytest
from rio_franka import fake
from rio_franka.arm.driver import FrankaArm
from rio_franka.faults import FrankaSetupError, fault_of_message
from rio_franka.models import HAND_TCP

from rio import clock
from rio.conformance.driving import Loop
from rio.errors import InvalidRequest
from rio.testing import lifecycle


def arm_on(ip, **fields):
    return FrankaArm(ip=ip, backend="fake", relative_dynamics_factor=1.0, **fields)


def run_until(arm, pred, timeout: float = 8.0) -> dict:
    return Loop(arm).run(until=pred, timeout=timeout)


def request(arm, q) -> None:
    arm.handle_request({"mode": 0, "joint_pos": np.asarray(q), "eef_pose": np.zeros(7), "t_cmd_target": clock.now()})


def test_joint_goals_become_asynchronous_motions_the_robot_follows(fake_ip):
    with lifecycle(arm_on(fake_ip)) as arm:
        ctl = fake.controller(fake_ip)
        s = arm.cycle()
        assert s["enabled"] and s["connected"] and s["fault_code"] == 0
        goal = s["joint_pos"] + np.array([0.3, -0.2, 0.2, 0.2, 0.1, -0.1, 0.25])
        n0 = ctl.motions
        arm.command_joints(goal, clock.now() + 0.6)
        s = run_until(arm, lambda s: np.abs(s["joint_pos"] - goal).max() < 2e-3)
        np.testing.assert_allclose(s["joint_pos"], goal, atol=2e-3)
        assert ctl.motions - n0 > 5  # a new motion per changed goal, each replacing the last


def test_eef_goals_become_cartesian_motions_in_the_tool_frame(fake_ip):
    with lifecycle(arm_on(fake_ip, tcp_offset=HAND_TCP)) as arm:
        start = arm.cycle()["eef_pose"]
        assert abs(start[2] - (0.5903 - 0.1034)) < 1e-3  # the hand's TCP below the flange at the ready pose
        goal = start.copy()
        goal[:3] += [0.05, -0.04, -0.06]
        arm.command_eef(goal, clock.now() + 1.0)
        s = run_until(arm, lambda s: np.linalg.norm(s["eef_pose"][:3] - goal[:3]) < 1.5e-3)
        assert np.linalg.norm(s["eef_pose"][:3] - goal[:3]) < 1.5e-3
        assert abs(abs(float(np.dot(s["eef_pose"][3:], goal[3:]))) - 1.0) < 1e-4


@pytest.mark.parametrize("what,name", [("joint_reflex", "joint_reflex"), ("cartesian_reflex", "cartesian_reflex"),
                                       ("collision", "collision"), ("communication", "communication"),
                                       ("power", "power")])
def test_a_reflex_is_held_as_a_named_fault_until_recovered(fake_ip, what, name):
    with lifecycle(arm_on(fake_ip)) as arm:
        q0 = arm.cycle()["joint_pos"]
        goal = q0 + 0.4
        arm.command_joints(goal, clock.now() + 1.0)
        Loop(arm).run(seconds=0.1)
        fake.controller(fake_ip).inject(what)
        s = run_until(arm, lambda s: s["fault_code"] != 0, timeout=3)
        assert arm.faults.fault is not None and arm.faults.fault.name == name
        assert not s["enabled"] and s["connected"]  # node alive, arm held
        held = s["joint_pos"].copy()
        s = Loop(arm).run(seconds=0.3)
        np.testing.assert_allclose(s["joint_pos"], held, atol=1e-6)
        with pytest.raises(InvalidRequest, match=name):
            request(arm, goal)
        assert arm.clear_faults() == "cleared"
        s = Loop(arm).run(seconds=0.1)
        assert s["enabled"] and s["fault_code"] == 0
        request(arm, held + 0.05)
        s = run_until(arm, lambda s: np.abs(s["joint_pos"] - (held + 0.05)).max() < 2e-3)
        assert np.abs(s["joint_pos"] - (held + 0.05)).max() < 2e-3


def test_auto_recover_clears_a_reflex_by_itself(fake_ip):
    with lifecycle(arm_on(fake_ip, auto_recover=True, auto_recover_delay_s=0.2)) as arm:
        arm.cycle()
        fake.controller(fake_ip).inject("joint_reflex")
        run_until(arm, lambda s: s["fault_code"] == 1, timeout=3)
        s = run_until(arm, lambda s: s["fault_code"] == 0 and s["enabled"], timeout=5)
        assert s["enabled"] and arm.faults.fault is None


def test_user_stop_is_a_named_fault(fake_ip):
    with lifecycle(arm_on(fake_ip)) as arm:
        arm.cycle()
        fake.controller(fake_ip).inject("user_stopped")
        run_until(arm, lambda s: s["fault_code"] != 0, timeout=3)
        assert arm.faults.fault.name == "user_stopped"


def test_a_dropped_link_holds_then_reconnects_holding_where_the_arm_is(fake_ip):
    with lifecycle(arm_on(fake_ip)) as arm:
        q0 = arm.cycle()["joint_pos"]
        ctl = fake.controller(fake_ip)
        ctl.inject("link_lost")
        s = run_until(arm, lambda s: not s["connected"], timeout=3)
        assert not s["enabled"]
        with pytest.raises(InvalidRequest, match="Franka at .* is down"):
            request(arm, q0 + 0.1)
        ctl.restore_link()
        s = run_until(arm, lambda s: s["connected"] and s["enabled"], timeout=5)
        np.testing.assert_allclose(s["joint_pos"], q0, atol=1e-3)
        request(arm, q0 + 0.1)
        s = run_until(arm, lambda s: np.abs(s["joint_pos"] - (q0 + 0.1)).max() < 2e-3)
        assert np.abs(s["joint_pos"] - (q0 + 0.1)).max() < 2e-3


def test_version_mismatch_names_both_versions_and_what_to_install(fake_ip):
    fake.controller(fake_ip).server_version = 5
    with pytest.raises(FrankaSetupError) as err:
        with lifecycle(arm_on(fake_ip)):
            pass
    text = str(err.value)
    assert "server version 5" in text and "speaks 9" in text
    assert "by-robot-server-version/5/" in text and "franky-control" in text


def test_fci_not_active_says_to_activate_it_in_desk(fake_ip):
    fake.controller(fake_ip).fci_active = False
    with pytest.raises(FrankaSetupError, match="activate FCI"):
        with lifecycle(arm_on(fake_ip)):
            pass


def test_libfranka_messages_map_to_named_faults():
    assert fault_of_message('libfranka: Move command aborted: motion aborted by reflex! ["cartesian_reflex"]').name \
        == "cartesian_reflex"
    assert fault_of_message('libfranka: Move command rejected: command not possible in the current mode '
                            '("User stopped")!').name == "user_stopped"
    assert fault_of_message('libfranka: Move command rejected: command not possible in the current mode '
                            '("Other")!').name == "locked"
