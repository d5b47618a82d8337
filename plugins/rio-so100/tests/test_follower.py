"""The driver nodes over emulated buses, through the runtime (thread middleware): the follower moves
in radians, stops and names the servo on an overload / overheat / voltage fault, the gripper works
in meters, and calibration is required on a real port."""

from __future__ import annotations

import time

import numpy as np
import pytest
from rio_so100.calibration import RAD_PER_STEP, default_calibration
from rio_so100.feetech import control_table as T
from rio_so100.follower.driver import So100Follower
from rio_so100.gripper.driver import So100Gripper

from rio import ServerManager, connect, serve
from rio.errors import NodeDiedError, RioError
from rio.testing import wait_until

MW = "thread"



def test_follower_moves_to_joint_targets_within_limits(vbus, calibrated):
    calibrated()
    with ServerManager(MW, [serve(So100Follower, name="arm", port=vbus.port, rate_hz=100)]):
        with connect(So100Follower, MW, name="arm", port=vbus.port) as arm:
            s = arm.get_state()
            assert np.allclose(s["joint_pos"], 0.0) and s["enabled"] and np.all(np.isnan(s["eef_pose"]))
            lower, upper = (np.array(x) for x in arm.joint_limits())
            cal = default_calibration("so100", "follower")
            assert np.allclose(np.transpose([lower, upper]), [cal.joint(j).limits_rad() for j in arm.joint_names()])
            q = np.array([0.5, -0.4, 0.3, 0.2, -0.6])
            arm.move_joints(q, time.monotonic() + 0.3)
            assert wait_until(lambda: np.allclose(arm.get_state()["joint_pos"], q, atol=2 * RAD_PER_STEP))
            arm.move_joints([9.0, 0, 0, 0, 0], time.monotonic() + 0.1)  # far outside: clipped to the limit
            assert wait_until(lambda: abs(arm.get_state()["joint_pos"][0] - upper[0]) < 2 * RAD_PER_STEP)
            assert vbus.servo(1).reg(T.GOAL_POSITION) == cal.joint("shoulder_pan").range_max
            arm.disable()
            assert vbus.servo(1).reg(T.TORQUE_ENABLE) == 0 and wait_until(lambda: not arm.get_state()["enabled"])
    assert all(vbus.servo(i).reg(T.TORQUE_ENABLE) == 0 for i in range(1, 6))  # released on close


def test_overload_stops_the_arm_and_names_the_servo(vbus, calibrated):
    calibrated()
    vbus.servo(3).stops = (-1e9, 2048 + 100)  # an obstacle just past the elbow's start
    with ServerManager(MW, [serve(So100Follower, name="arm", port=vbus.port, rate_hz=100)]):
        with connect(So100Follower, MW, name="arm", port=vbus.port) as arm:
            arm.move_joints([0.6, 0.0, 0.6, 0.0, 0.0], time.monotonic() + 1.0)  # the elbow hits it at ~0.25 s
            with pytest.raises(NodeDiedError, match=r"servo 3 \(elbow_flex\): overload"):
                wait_until(lambda: arm.get_state() is None, timeout=3.0)
    # the stop froze every joint where it was (goal = present), not at the commanded target
    assert vbus.servo(3).overloaded
    shoulder = vbus.servo(1)
    assert abs(shoulder.reg(T.GOAL_POSITION) - shoulder.present()) <= 1
    assert shoulder.present() < 2048 + (0.6 - 0.1) / RAD_PER_STEP


@pytest.mark.parametrize("fault, message", [("temperature", "overheat"), ("voltage", "input voltage out of range")])
def test_overheat_and_voltage_faults_stop_the_node(vbus, calibrated, fault, message):
    calibrated()
    with ServerManager(MW, [serve(So100Follower, name="arm", port=vbus.port)]):
        with connect(So100Follower, MW, name="arm", port=vbus.port) as arm:
            with vbus.lock:
                if fault == "temperature":
                    vbus.servo(5).temperature = 80.0
                else:
                    vbus.servo(5).voltage = 3.1
            with pytest.raises(NodeDiedError, match=rf"servo 5 \(wrist_roll\): {message}"):
                wait_until(lambda: arm.get_state() is None, timeout=2.0)


def test_gripper_in_meters_and_a_grasp_does_not_trip_overload(vbus, calibrated):
    calibrated()
    with ServerManager(MW, [serve(So100Gripper, name="gripper", port=vbus.port)]):
        with connect(So100Gripper, MW, name="gripper", port=vbus.port) as g:
            assert g.max_width() == pytest.approx(0.06) and g.get_state()["width"] == pytest.approx(0.0)
            g.move(0.03, time.monotonic() + 0.2)
            assert wait_until(lambda: abs(g.get_state()["width"] - 0.03) < 0.0005)
            vbus.servo(6).stops = (-1e9, vbus.servo(6).encoder)  # an object between the jaws
            g.move(0.06, time.monotonic() + 0.1)  # squeeze: stalls at the torque limit (50 %)
            time.sleep(0.5)
            s = g.get_state()
            assert abs(s["width"] - 0.03) < 0.001 and s["error"] == 0 and 0.4 < abs(s["load"]) <= 0.5


def test_a_real_port_needs_a_calibration(vbus):
    with pytest.raises(RioError, match=r"no calibration 'left' for the so100 follower .*rio so100 calibrate"):
        with ServerManager(MW, [serve(So100Follower, name="arm", port=vbus.port, calibration="left")]):
            pass


def test_missing_servo_is_named_at_start(make_vbus, calibrated):
    calibrated()
    bus = make_vbus(ids=(1, 2, 3, 5, 6))
    with pytest.raises(RioError, match=r"servo 4 \(wrist_flex\) did not answer a ping"):
        with ServerManager(MW, [serve(So100Follower, name="arm", port=bus.port, retries=0)]):
            pass


def test_port_emulator_runs_the_sdk_against_a_private_emulated_arm():
    with ServerManager(MW, [serve(So100Follower, name="arm", port="emulator")]):
        with connect(So100Follower, MW, name="arm", port="emulator") as arm:
            arm.move_joints([0.2, 0.2, 0.2, 0.2, 0.2], time.monotonic() + 0.2)
            assert wait_until(lambda: np.allclose(arm.get_state()["joint_pos"], 0.2, atol=2 * RAD_PER_STEP))
