"""LeKiwi's wheels: the `lekiwi.base` driver (the real scservo_sdk path) against emulated STS3215 servos in
wheel mode, down to the bytes of the goal speeds; and the base conformance kit on it."""

from __future__ import annotations

import numpy as np
import pytest
from rio_so100.feetech import control_table as T
from rio_so100.lekiwi import geometry as G
from rio_so100.lekiwi.wheels import LeKiwiBase

from rio import clock
from rio.conformance.drivers import BaseConformance
from rio.testing import lifecycle, wait_until


class TestLeKiwiBase(BaseConformance):
    driver = "lekiwi.base"
    config = {"port": "emulator"}
    tracking_tol = 0.05  # the servo's speed lags its goal (tau 40 ms) and is whole steps/s
    settle_s = 0.4


def _goal_bytes(servo) -> bytes:
    a, n = T.GOAL_VELOCITY
    return bytes(servo.mem[a:a + n])


def test_open_puts_the_wheels_in_wheel_mode_and_commands_signed_speeds():
    node = LeKiwiBase(port="emulator", enable_on_open=False)
    with lifecycle(node):
        vb = node.emulator
        for sid in G.WHEEL_IDS:
            assert vb.servo(sid).reg(T.OPERATING_MODE) == T.VELOCITY_MODE
            assert vb.servo(sid).reg(T.LOCK) == 1  # locked again after the EEPROM write
        node.enable()
        # a pure spin: every wheel forward at R * wz / r rad/s
        steps = node.wheel_steps(np.array([0.0, 0.0, 1.0]))
        expected = round(G.BASE_RADIUS / G.WHEEL_RADIUS * G.STEPS_PER_RAD)
        assert steps.tolist() == [expected] * 3
        node.write_twist(np.array([0.0, 0.0, 1.0]))
        node.read_wheels()  # a round trip after the broadcast write: the servos have applied it
        for sid in G.WHEEL_IDS:
            assert _goal_bytes(vb.servo(sid)) == bytes([expected & 0xFF, expected >> 8])  # little-endian, sign 0
        # straight back: the left wheel forward, the right one backward (sign in bit 15), the back wheel still
        node.write_twist(np.array([-0.2, 0.0, 0.0]))
        node.read_wheels()
        left, back, right = (vb.servo(s) for s in G.WHEEL_IDS)
        speed = node.wheel_steps(np.array([-0.2, 0.0, 0.0]))
        assert speed[0] > 0 and speed[2] == -speed[0] and speed[1] == 0
        raw = speed[0] | 0x8000
        assert _goal_bytes(right) == bytes([raw & 0xFF, raw >> 8]) and _goal_bytes(back) == b"\x00\x00"
        assert _goal_bytes(left) == bytes([speed[0] & 0xFF, speed[0] >> 8])


def test_a_fast_twist_is_scaled_down_as_a_whole():
    node = LeKiwiBase(port="emulator", max_linear_speed=5.0, max_angular_speed=20.0)
    twist = np.array([2.0, 1.0, 3.0])
    steps = node.wheel_steps(twist)
    assert np.abs(steps).max() == G.MAX_WHEEL_STEPS
    exact = node.kinematics.to_wheels(twist)
    assert np.allclose(steps / np.abs(steps).max(), exact / np.abs(exact).max(), atol=1e-3)  # direction kept


def test_the_base_drives_and_its_wheels_report_it():
    node = LeKiwiBase(port="emulator")
    with lifecycle(node):
        rate = clock.Rate(node.rate_hz)
        t_end = clock.now() + 1.0
        while clock.now() < t_end:
            node.command("twist", np.array([0.1, 0.05, 0.4]), clock.now() + 0.02)
            s = node.cycle()
            rate.sleep()
        assert np.allclose(s["body_twist"], [0.1, 0.05, 0.4], atol=0.02), s["body_twist"]
        assert np.abs(s["wheel_pos"]).max() > 0.5  # the wheels turned, counted past the register's wrap
        pose = s["odom_pose"]
        assert 0.05 < pose[0] < 0.12 and 0.15 < pose[2] < 0.45, pose
        node.disable()  # acknowledged writes of torque: the zero speeds before them have been applied
        for sid in G.WHEEL_IDS:  # torque off with a zero goal speed: nothing spins on at an old speed
            servo = node.emulator.servo(sid)
            assert servo.reg(T.TORQUE_ENABLE) == 0 and _goal_bytes(servo) == b"\x00\x00"


def test_a_servo_fault_stops_the_wheels_and_names_the_servo():
    from rio_so100.errors import ServoFault
    from rio_so100.feetech import protocol as P

    node = LeKiwiBase(port="emulator")
    with lifecycle(node):
        node.command("twist", np.array([0.1, 0.0, 0.0]), clock.now())
        for _ in range(5):
            node.cycle()
        node.emulator.servo(8).forced_error = P.ERR_OVERHEAT
        with pytest.raises(ServoFault, match=r"servo 8 \(back_wheel\): overheat"):
            node.cycle()
        servos = [node.emulator.servo(sid) for sid in G.WHEEL_IDS]  # the stop is a broadcast: no answer to wait for
        assert wait_until(lambda: all(_goal_bytes(s) == b"\x00\x00" for s in servos), timeout=2.0)


def test_lekiwi_emulator_with_a_leader_arm_mirrors_the_arm_and_parks_the_base():
    """LeKiwi's usual setup: an SO-101 leader drives the arm; the base gets a zero twist each tick."""
    from rio.workflows.teleop import run_teleop

    seen = []
    s = run_teleop("lekiwi-emulator", "so101.leader", device_config={"port": "emulator", "emulator_motion": "wave"},
                   middleware="thread", duration=3.0, log=None,
                   on_tick=lambda tick: seen.append((tick.action[-3:].copy(), tick.step.observation.base_odom)))
    assert s.ticks > 30 and seen
    assert all(not a.any() for a, _ in seen)  # the base's part of every action: stand still
    assert np.abs(seen[-1][1]).max() < 1e-3
