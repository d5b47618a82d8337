"""The arm driver through the unmodified xArm SDK against the controller emulator: servo streaming in
joint and Cartesian space, the model check, faults held and recovered, a dropped socket reconnected."""

from __future__ import annotations

import numpy as np
import pytest
from rio_ufactory.arm.driver import XArm
from rio_ufactory.connection import XArmConnection
from rio_ufactory.faults import XArmError, XArmFault
from rio_ufactory.loopback import free_loopback

from rio import clock
from rio.conformance.driving import Loop
from rio.errors import InvalidRequest
from rio.testing import lifecycle, wait_until


def spin(arm, seconds: float) -> dict:
    """Run the node's cycle for `seconds` (as its loop would) and return the last sample."""
    return Loop(arm).run(seconds=seconds)


def run_until(arm, pred, timeout: float = 8.0) -> dict:
    return Loop(arm).run(until=pred, timeout=timeout)


def test_joint_targets_stream_as_servo_commands_and_the_report_follows(make_emulator):
    emu = make_emulator("xarm7")
    with lifecycle(XArm(ip=emu.host, model="xarm7")) as arm:
        s = arm.cycle()
        assert s["enabled"] and s["connected"] and s["fault_code"] == 0
        assert emu.mode == 1  # servo mode
        np.testing.assert_allclose(s["joint_pos"], emu.joint_pos, atol=1e-4)
        goal = s["joint_pos"] + np.array([0.3, -0.1, 0.2, 0.1, 0.0, -0.1, 0.25])
        n0 = emu.servo_commands
        arm.command_joints(goal, clock.now() + 0.8)
        s = run_until(arm, lambda s: np.abs(s["joint_pos"] - goal).max() < 2e-3)
        np.testing.assert_allclose(s["joint_pos"], goal, atol=2e-3)
        np.testing.assert_allclose(emu.joint_pos, goal, atol=2e-3)
        assert emu.servo_commands - n0 > 50  # streamed, one target per cycle
        assert s["report_age"] < 0.5


def test_joint_targets_are_clipped_to_the_models_limits(make_emulator):
    emu = make_emulator("lite6", gripper="lite6")
    with lifecycle(XArm(ip=emu.host, model="lite6", max_step_rad=0.05)) as arm:
        q = arm.cycle()["joint_pos"]
        goal = q.copy()
        goal[2] = 7.0  # joint 3 of a Lite 6 stops at 5.236 rad
        arm.command_joints(goal, clock.now() + 0.5)
        s = run_until(arm, lambda s: abs(s["joint_pos"][2] - 5.2359) < 2e-3, timeout=10)
        assert abs(s["joint_pos"][2] - 5.2359) < 2e-3
        assert emu.error_code == 0  # never sent past the limit


def test_eef_targets_go_through_the_controllers_cartesian_servo(make_emulator):
    emu = make_emulator("xarm6")
    with lifecycle(XArm(ip=emu.host, model="xarm6")) as arm:
        start = arm.cycle()["eef_pose"]
        goal = start.copy()
        goal[:3] += [0.04, -0.03, -0.05]
        arm.command_eef(goal, clock.now() + 1.0)
        s = run_until(arm, lambda s: np.linalg.norm(s["eef_pose"][:3] - goal[:3]) < 1e-3)
        assert np.linalg.norm(s["eef_pose"][:3] - goal[:3]) < 1e-3
        assert abs(abs(float(np.dot(s["eef_pose"][3:], goal[3:]))) - 1.0) < 1e-4


def test_eef_targets_by_rios_ik_with_a_tool_offset_agree_with_the_controller(make_emulator):
    emu = make_emulator("xarm7")
    offset = [0.0, 0.0, 0.16, 0.0, 0.0, 0.0]
    with lifecycle(XArm(ip=emu.host, model="xarm7", eef_control="ik", tcp_offset=offset)) as arm:
        assert arm.robot_description()["frame"] == "tool"
        s = arm.cycle()
        reported = emu.tcp_pose()  # the controller's TCP: mm, rad, offset included
        np.testing.assert_allclose(s["eef_pose"][:3] * 1000.0, reported[:3], atol=0.5)
        goal = s["eef_pose"].copy()
        goal[:3] += [0.0, 0.05, 0.03]
        arm.command_eef(goal, clock.now() + 1.0)
        s = run_until(arm, lambda s: np.linalg.norm(s["eef_pose"][:3] - goal[:3]) < 2e-3)
        assert np.linalg.norm(s["eef_pose"][:3] - goal[:3]) < 2e-3
        np.testing.assert_allclose(np.asarray(emu.tcp_pose()[:3]) / 1000.0, s["eef_pose"][:3], atol=2e-3)


def test_a_station_naming_the_wrong_model_is_refused(make_emulator):
    emu = make_emulator("xarm7")
    arm = XArm(ip=emu.host, model="xarm6")
    with pytest.raises(XArmError, match=r"station says xArm 6, the controller reports xArm 7"):
        arm.open()
    assert emu.host not in XArmConnection._shared  # nothing left open


def test_no_controller_is_a_clear_error_naming_the_address():
    arm = XArm(ip=free_loopback(), model="xarm7", connect_timeout_s=0.3)
    with pytest.raises(XArmError, match=r"no xArm controller answers on TCP 502"):
        arm.open()


@pytest.mark.parametrize("kind, code, name", [("collision", 31, "collision"), ("joint_limit", 23, "joint_limit"),
                                              ("servo", 13, "servo_error")])
def test_a_fault_holds_the_arm_names_itself_and_clears(make_emulator, kind, code, name):
    emu = make_emulator("xarm7")
    with lifecycle(XArm(ip=emu.host, model="xarm7")) as arm:
        q0 = arm.cycle()["joint_pos"]
        goal = q0 + 0.4
        arm.command_joints(goal, clock.now() + 1.5)
        spin(arm, 0.3)
        emu.inject_fault(kind, joint=3)
        s = run_until(arm, lambda s: s["fault_code"] != 0, timeout=3)
        assert s["fault_code"] == code and not s["enabled"]
        assert arm.faults.fault is not None and arm.faults.fault.name == name
        stopped = emu.joint_pos.copy()
        spin(arm, 0.3)
        np.testing.assert_allclose(emu.joint_pos, stopped, atol=1e-3)  # held where it stopped
        with pytest.raises(InvalidRequest, match=f"C{code} {name}"):
            arm.handle_request({"mode": 0, "joint_pos": goal, "eef_pose": np.zeros(7), "t_cmd_target": clock.now()})
        assert arm.fault_info()["code"] == code
        assert arm.clear_faults() == "cleared"
        s = spin(arm, 0.1)
        assert s["enabled"] and s["fault_code"] == 0 and emu.error_code == 0
        np.testing.assert_allclose(s["joint_pos"], stopped, atol=2e-3)  # no jump toward the old goal
        arm.command_joints(q0, clock.now() + 1.0)
        s = run_until(arm, lambda s: np.abs(s["joint_pos"] - q0).max() < 2e-3)
        np.testing.assert_allclose(s["joint_pos"], q0, atol=2e-3)


def test_emergency_stop_cannot_be_cleared_until_released(make_emulator):
    emu = make_emulator("xarm7")
    with lifecycle(XArm(ip=emu.host, model="xarm7")) as arm:
        emu.inject_fault("estop")
        s = run_until(arm, lambda s: s["fault_code"] != 0, timeout=3)
        assert s["fault_code"] == 1 and arm.faults.fault.name == "emergency_stop"
        assert "release the emergency stop" in str(arm.faults.fault)
        with pytest.raises(XArmFault, match="emergency_stop"):
            arm.clear_faults()
        emu.release_estop()
        arm.clear_faults()
        assert spin(arm, 0.1)["enabled"]


def test_a_dropped_connection_is_reconnected_and_the_arm_holds(make_emulator):
    emu = make_emulator("xarm7")
    with lifecycle(XArm(ip=emu.host, model="xarm7")) as arm:
        q0 = spin(arm, 0.1)["joint_pos"]
        assert emu.drop_connections() >= 2  # command and report sockets
        s = run_until(arm, lambda s: not s["connected"] or not s["enabled"], timeout=5)
        with pytest.raises(InvalidRequest):
            if not s["connected"]:
                arm.handle_request({"mode": 0, "joint_pos": q0, "eef_pose": np.zeros(7), "t_cmd_target": 0.0})
            else:
                raise InvalidRequest(arm.name, None, "already back")
        s = run_until(arm, lambda s: s["connected"] and s["enabled"], timeout=15)
        assert s["connected"] and s["enabled"]
        np.testing.assert_allclose(s["joint_pos"], q0, atol=2e-3)
        goal = q0.copy()
        goal[0] += 0.2
        arm.command_joints(goal, clock.now() + 0.5)
        s = run_until(arm, lambda s: abs(s["joint_pos"][0] - goal[0]) < 2e-3)
        assert abs(s["joint_pos"][0] - goal[0]) < 2e-3


def test_arm_and_gripper_in_one_process_share_one_connection(make_emulator):
    from rio_ufactory.gripper.xarm_gripper import XArmGripper

    emu = make_emulator("xarm7")
    with lifecycle(XArm(ip=emu.host, model="xarm7")) as arm, lifecycle(XArmGripper(ip=emu.host)) as grip:
        assert arm.conn is grip.conn and arm.conn.users == 2
        assert wait_until(lambda: emu.clients == 2)  # one command socket + one report socket
    assert emu.host not in XArmConnection._shared


def test_another_program_stopping_the_arm_is_a_named_stop_and_enable_resumes(make_emulator, connect):
    emu = make_emulator("xarm7")
    with lifecycle(XArm(ip=emu.host, model="xarm7")) as arm:
        spin(arm, 0.1)
        other = connect(emu)  # UFACTORY Studio, a script: the controller takes several clients
        assert other.set_state(4) == 0
        s = run_until(arm, lambda s: s["fault_code"] != 0, timeout=3)
        assert s["fault_code"] == -1 and not s["enabled"] and arm.faults.fault.name == "stopped"
        assert arm.enable() and spin(arm, 0.1)["enabled"]
        assert arm.faults.fault is None and emu.state in (1, 2)


def test_after_a_drop_every_node_on_the_controller_comes_back(make_emulator):
    """The arm and its gripper share one SDK connection: whichever node reconnects it, the other one
    must come back enabled too (holding), not stay disabled waiting for a drop it no longer sees."""
    from rio_ufactory.gripper.xarm_gripper import XArmGripper

    emu = make_emulator("xarm7")
    with lifecycle(XArm(ip=emu.host, model="xarm7")) as arm, lifecycle(XArmGripper(ip=emu.host)) as grip:
        spin(arm, 0.1)
        Loop(grip).run(cycles=2)
        emu.drop_connections()
        g = Loop(grip).run(until=lambda s: not s["enabled"], timeout=5)
        assert not g["enabled"]  # the gripper saw the drop first
        s = run_until(arm, lambda s: s["connected"] and s["enabled"], timeout=15)  # the arm reconnects
        assert s["connected"] and s["enabled"]
        g = Loop(grip).run(until=lambda s: s["connected"] and s["enabled"], timeout=5)
        assert g["connected"] and g["enabled"]
