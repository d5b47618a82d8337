"""Faults on the FAKE kortex backend (stand-ins for kortex's clients, which cannot run here: see
`rio_kinova.fake`): the base's arm-state and action-abort notifications become named faults, the node
stays alive holding and refuses commands naming the fault, and clear_faults() (Base.ClearFaults)
brings it back holding where the arm is. Also: continuous joints unwrap across 360 degrees."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rio_kinova import session
from rio_kinova.arm.driver import KinovaArm
from rio_kinova.faults import KinovaError
from rio_kinova.gripper.robotiq import KinovaRobotiq

from rio import clock
from rio.conformance.driving import Loop
from rio.errors import InvalidRequest
from rio.testing import lifecycle

IP = "127.0.0.3"


def arm_node(**fields) -> KinovaArm:
    return KinovaArm(backend="fake", model="gen3", ip=IP, **fields)


def test_a_joint_fault_is_named_held_and_cleared():
    with lifecycle(arm_node()) as arm:
        q0 = Loop(arm).run(cycles=3)["joint_pos"]
        arm.command_joints(q0 + 0.5, clock.now() + 1.0)
        Loop(arm).run(seconds=0.2)
        session.fake_robot(IP, "gen3").inject_fault("joint_fault")
        s = Loop(arm).run(cycles=3)
        assert s["fault_code"] == 3 and not s["enabled"] and s["holding"]
        assert arm.faults.fault is not None and arm.faults.fault.name == "action_aborted"
        held = s["joint_pos"].copy()
        with pytest.raises(InvalidRequest, match="stopped by a fault: action_aborted"):
            arm.handle_request({**arm.example_request, "joint_pos": q0, "t_cmd_target": clock.now()})
        s = Loop(arm).run(seconds=0.3)
        np.testing.assert_allclose(s["joint_pos"], held, atol=1e-6)  # stopped, nothing replayed
        assert arm.clear_faults() == "cleared"
        s = Loop(arm).run(seconds=0.3)
        assert s["fault_code"] == 0 and s["enabled"]
        np.testing.assert_allclose(s["joint_pos"], held, atol=2e-3)  # holds where it stopped


def test_an_emergency_stop_is_named_and_clears_only_once_released():
    with lifecycle(arm_node()) as arm, lifecycle(KinovaRobotiq(backend="fake", ip=IP)) as grip:
        robot = session.fake_robot(IP, "gen3")
        robot.inject_fault("emergency_stop")
        s = Loop(arm).run(cycles=2)
        assert s["fault_code"] == 2 and arm.faults.fault.name == "emergency_stop" and "release the emergency stop" in \
            str(arm.faults.fault)
        assert Loop(grip).run(cycles=2)["fault_code"] == 2  # the gripper's node holds too (one base)
        with pytest.raises(KinovaError, match="emergency stop"):
            arm.clear_faults()
        robot.release_estop()
        assert arm.clear_faults() == "cleared" and grip.clear_faults() == "cleared"
        assert Loop(arm).run(cycles=2)["fault_code"] == 0


def test_enable_refuses_while_the_base_is_in_fault():
    with lifecycle(arm_node(enable_on_open=False)) as arm:
        session.fake_robot(IP, "gen3").inject_fault("joint_fault")
        with pytest.raises(InvalidRequest, match="stopped by a fault: action_aborted"):
            arm.enable()


def test_continuous_joints_unwrap_across_a_full_turn():
    with lifecycle(arm_node()) as arm:
        robot = session.fake_robot(IP, "gen3")
        q0 = Loop(arm).run(cycles=3)["joint_pos"]
        assert abs(q0[2] - math.pi) < 1e-6  # Home has joint 3 at 180 degrees
        goal = q0.copy()
        goal[2] += 1.0  # through 180/-180 degrees: reported wrapped, read continuous
        arm.command_joints(goal, clock.now() + 1.0)
        # settled there (a reading taken while the joint still passes through the goal races the base, which
        # the next call advances)
        s = Loop(arm).run(until=lambda s: abs(s["joint_pos"][2] - goal[2]) < 2e-3 and abs(s["joint_vel"][2]) < 0.01,
                          timeout=6)
        assert abs(s["joint_pos"][2] - goal[2]) < 2e-3 and abs(robot.q[2] - goal[2]) < 5e-3


def test_eef_targets_through_the_bases_twist_control():
    with lifecycle(arm_node(eef_control="controller", max_step_m=0.002)) as arm:
        start = Loop(arm).run(cycles=3)["eef_pose"]
        goal = start.copy()
        goal[:3] += [0.03, -0.02, 0.04]
        arm.command_eef(goal, clock.now() + 1.0)
        s = Loop(arm).run(until=lambda s: np.linalg.norm(s["eef_pose"][:3] - goal[:3]) < 2e-3, timeout=6)
        assert np.linalg.norm(s["eef_pose"][:3] - goal[:3]) < 2e-3
        assert session.fake_robot(IP, "gen3").calls.get("SendTwistCommand", 0) > 20


def test_a_lost_session_holds_refuses_and_reconnects_holding_where_the_arm_is():
    """The fake base's link is dropped (every call fails in transport, as kortex's KClientException) and
    restored: the node stays alive, says `connected = False`, refuses commands, and after the session is
    reopened it is enabled again holding where the arm stopped; the gripper shares the reopened session."""
    with lifecycle(arm_node()) as arm, lifecycle(KinovaRobotiq(backend="fake", ip=IP)) as grip:
        robot = session.fake_robot(IP, "gen3")
        q0 = Loop(arm).run(cycles=3)["joint_pos"]
        arm.command_joints(q0 + 0.3, clock.now() + 1.0)
        Loop(arm).run(seconds=0.2)
        robot.drop_link()
        s = Loop(arm).run(until=lambda s: not s["connected"], timeout=3)
        assert not s["connected"] and not s["enabled"] and s["fault_code"] == 0
        assert not Loop(grip).run(cycles=2)["connected"]
        with pytest.raises(InvalidRequest, match="Kinova base at 127.0.0.3 is down"):
            arm.handle_request({**arm.example_request, "joint_pos": q0, "t_cmd_target": clock.now()})
        with pytest.raises(InvalidRequest, match="is down"):
            arm.clear_faults()
        robot.restore_link()
        s = Loop(arm).run(until=lambda s: s["connected"] and s["enabled"], timeout=5)
        assert s["connected"] and s["enabled"] and s["fault_code"] == 0
        held = Loop(arm).run(seconds=0.3)["joint_pos"]  # the base stopped the arm when the link went quiet
        s = Loop(arm).run(seconds=0.4)
        np.testing.assert_allclose(s["joint_pos"], held, atol=2e-3)  # it holds there: the old goal is not replayed
        assert np.all(np.abs(s["joint_pos"] - (q0 + 0.3)) > 0.1)
        g = Loop(grip).run(until=lambda s: s["connected"] and s["enabled"], timeout=5)
        assert g["connected"] and g["enabled"]
        grip.command("width", [0.02], clock.now() + 0.5)
        g = Loop(grip).run(until=lambda s: abs(s["width"] - 0.02) < 2e-3, timeout=5)
        assert abs(g["width"] - 0.02) < 2e-3
