"""The arm driver: the real ur-rtde receive interface and dashboard client against the emulator's
protocols; the control path is the fake (`control = "emulator"`, the emulator's servo port), since the
control script ur-rtde uploads cannot be emulated. Joint and Cartesian streaming, faults named, held
and recovered through the dashboard, speed scaling, a dropped link."""

from __future__ import annotations

import numpy as np
import pytest
from rio_ur.arm.driver import URArm

from rio import clock
from rio.conformance.driving import Loop
from rio.errors import InvalidRequest
from rio.testing import lifecycle, wait_until


def run_until(arm, pred, timeout: float = 8.0) -> dict:
    return Loop(arm).run(until=pred, timeout=timeout)


def test_joint_targets_stream_as_servoj_and_rtde_reports_them(emulator):
    with lifecycle(URArm(**emulator.driver_fields, model="ur5e")) as arm:
        s = arm.cycle()
        assert s["enabled"] and s["connected"] and s["fault_code"] == 0 and s["robot_mode"] == 7
        np.testing.assert_allclose(s["joint_pos"], emulator.state()["q"], atol=1e-3)
        goal = s["joint_pos"] + np.array([0.2, -0.1, 0.15, 0.1, -0.1, 0.2])
        n0 = emulator.state()["servo_commands"]
        arm.command_joints(goal, clock.now() + 0.8)
        s = run_until(arm, lambda s: np.abs(s["joint_pos"] - goal).max() < 3e-3)
        np.testing.assert_allclose(s["joint_pos"], goal, atol=3e-3)
        assert emulator.state()["servo_commands"] - n0 > 50


def test_eef_targets_go_through_servol(emulator):
    with lifecycle(URArm(**emulator.driver_fields, model="ur5e")) as arm:
        start = arm.cycle()["eef_pose"]
        goal = start.copy()
        goal[:3] += [0.03, -0.02, -0.04]
        arm.command_eef(goal, clock.now() + 1.0)
        s = run_until(arm, lambda s: np.linalg.norm(s["eef_pose"][:3] - goal[:3]) < 2e-3)
        assert np.linalg.norm(s["eef_pose"][:3] - goal[:3]) < 2e-3


def test_protective_stop_is_named_held_and_recovered_through_the_dashboard(emulator):
    with lifecycle(URArm(**emulator.driver_fields, model="ur5e")) as arm:
        emulator.inject("protective_stop")
        s = run_until(arm, lambda s: s["fault_code"] != 0)
        assert s["fault_code"] == 3 and not s["enabled"]
        with pytest.raises(InvalidRequest, match="protective_stop"):
            arm.handle_request({"mode": 0, "joint_pos": s["joint_pos"], "eef_pose": s["eef_pose"],
                                "t_cmd_target": clock.now()})
        assert arm.clear_faults() == "cleared"
        s = arm.cycle()
        assert s["enabled"] and s["fault_code"] == 0 and emulator.state()["safety_mode"] == 1


def test_emergency_stop_needs_the_button_then_power_and_brakes(emulator):
    with lifecycle(URArm(**emulator.driver_fields, model="ur5e")) as arm:
        emulator.inject("emergency_stop")
        s = run_until(arm, lambda s: s["fault_code"] != 0)
        assert s["fault_code"] == 7
        with pytest.raises(InvalidRequest, match="emergency_stop"):
            arm.clear_faults()  # the button is still pressed
        emulator.inject("release_emergency_stop")
        assert arm.clear_faults() == "cleared"  # dashboard: power on, brake release
        assert emulator.state()["robot_mode"] == 7 and arm.cycle()["enabled"]


def test_speed_slider_is_reported(emulator, caplog):
    emulator.inject("speed 0.5")
    with lifecycle(URArm(**emulator.driver_fields, model="ur5e")) as arm:
        s = run_until(arm, lambda s: s["speed_scaling"] < 0.6)
        assert abs(s["speed_scaling"] - 0.5) < 1e-9
        assert "speed slider" in caplog.text


def test_a_dropped_link_is_held_then_reconnected(emulator):
    with lifecycle(URArm(**emulator.driver_fields, model="ur5e")) as arm:
        emulator.inject("drop")
        assert wait_until(lambda: not arm.cycle()["enabled"], timeout=5)
        s = run_until(arm, lambda s: s["connected"] and s["enabled"], timeout=10)
        assert s["connected"] and s["enabled"]
