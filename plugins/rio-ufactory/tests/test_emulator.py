"""The xArm controller emulator through the unmodified xArm Python SDK (`XArmAPI`): identity on
connect, servo streaming, Cartesian servo, position moves, faults and recovery, dropped connections,
and the grippers on the tool port. Everything waits for outcomes (tolerances hold on a loaded
machine); nothing asserts timing."""

from __future__ import annotations

import logging
import threading
import time

import numpy as np
import pytest
from rio_ufactory.emulator import XArmEmulator
from rio_ufactory.emulator.protocol import feedback_frame, split_frames
from rio_ufactory.models import ARMS, get_arm

from rio.testing import wait_until

pytestmark = pytest.mark.timeout(120)


def _start(arm, mode: int = 1) -> None:
    assert arm.motion_enable(True) == 0
    assert arm.set_mode(mode) == 0
    assert arm.set_state(0) == 0
    assert wait_until(lambda: arm.state in (1, 2) and arm.mode == mode, 5.0), (arm.state, arm.mode)


def _target(model: str, scale: float = 1.0) -> np.ndarray:
    """A pose some way from home, inside the model's joint limits."""
    m = get_arm(model)
    delta = np.array([0.3, 0.2, -0.3, 0.3, -0.2, 0.3, 0.2])[: m.axis] * scale
    lo, hi = np.array(m.limits).T
    return np.clip(np.array(m.home) + delta, lo + 0.05, hi - 0.05)


def _angles(arm, axis: int) -> np.ndarray:
    return np.array(arm.angles[:axis])


class Streamer:
    """Streams set_servo_angle_j of a target at ~100 Hz in a thread, as a driver would."""

    def __init__(self, arm, target):
        self.arm, self.target, self.codes = arm, list(target), []
        self._stop = threading.Event()
        self._t = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        while not self._stop.is_set():
            self.codes.append(self.arm.set_servo_angle_j(self.target))
            time.sleep(0.01)

    def __enter__(self):
        self._t.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._t.join(5)


# -- identity ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("model", sorted(ARMS))
def test_connect_reports_the_models_identity(make_emulator, connect, model):
    emu = make_emulator(model)
    arm = connect(emu)
    m = get_arm(model)
    assert arm.connected
    assert (arm.axis, arm.device_type) == (m.axis, m.device_type)
    assert arm._arm.is_lite6 == (model == "lite6") and arm._arm.is_850 == (model == "xarm850")
    assert arm.version_number >= (2, 0, 0) and arm.sn == emu.sn
    assert wait_until(lambda: arm._arm.report_data.data_size == 135, 5.0)  # the real-time report flows
    assert wait_until(lambda: np.allclose(_angles(arm, m.axis), m.home, atol=1e-5), 5.0), arm.angles
    assert arm.get_err_warn_code() == (0, [0, 0])
    assert arm.state == 4 and emu.state == 4 and not emu.enabled  # after power-on: stopped, motors off


def test_rich_and_normal_reports_carry_identity_and_errors(emulator, connect):
    rich = connect(emulator, report_type="rich")
    normal = connect(emulator, report_type="normal")
    assert wait_until(lambda: rich.motor_enable_states[0] == 0 and normal.motor_enable_states[0] == 0, 5.0)
    assert (rich.axis, rich.device_type) == (7, 7)
    assert rich.collision_sensitivity == 3 and normal.teach_sensitivity == 3
    _start(rich, mode=0)
    assert wait_until(lambda: normal.motor_enable_states[:7] == [1] * 7, 5.0)
    emulator.inject_fault("collision")
    # no get_err_warn_code: the normal/rich reports carry the error
    assert wait_until(lambda: rich.error_code == 31 and normal.error_code == 31 and normal.state == 4, 5.0)


# -- servo mode -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("model", ["xarm7", "lite6"])
def test_servo_j_stream_is_followed(make_emulator, connect, model):
    emu = make_emulator(model, gripper=None)
    arm = connect(emu)
    axis = get_arm(model).axis
    _start(arm, mode=1)
    target = _target(model)
    with Streamer(arm, target) as s:
        assert wait_until(lambda: np.abs(_angles(arm, axis) - target).max() < 2e-3, 10.0), arm.angles
    assert set(s.codes) == {0}
    assert emu.servo_commands >= len(s.codes) and np.allclose(emu.last_servo_target, target, atol=1e-6)
    assert emu.last_command_time is not None and emu.last_command_time <= time.monotonic()
    assert wait_until(lambda: np.abs(emu.joint_pos - target).max() < 1e-5, 5.0)  # settled on the target
    assert np.allclose(arm.get_servo_angle()[1][:axis], emu.joint_pos, atol=1e-5)
    code, (pos, vel, effort) = arm.get_joint_states(num=3)
    assert code == 0 and np.allclose(pos[:axis], target, atol=1e-4) and len(vel) == len(effort) == 7


def test_servo_target_is_approached_at_the_speed_limit(emulator, connect):
    arm = connect(emulator)
    _start(arm, mode=1)
    q0 = emulator.joint_pos
    far = q0.copy()
    far[0] += 3.0
    t0 = time.monotonic()
    assert arm.set_servo_angle_j(list(far)) == 0
    assert wait_until(lambda: abs(emulator.joint_pos[0] - q0[0]) > 0.05, 5.0)
    moved, elapsed = abs(emulator.joint_pos[0] - q0[0]), time.monotonic() - t0
    assert moved <= get_arm("xarm7").max_joint_speed * elapsed + 1e-3  # no jump to a far target
    assert wait_until(lambda: abs(emulator.joint_pos[0] - far[0]) < 2e-3, 10.0)


def test_a_stalled_tick_walks_toward_a_new_servo_target_only_from_when_it_arrived():
    """The emulator's control thread descheduled for 100 ms, a far target arriving 10 ms before it runs
    again: the setpoint walks toward the old target until the new one came, then 10 ms toward the new
    one, never the whole stall at full speed (which the speed-limit test above caught on a loaded
    machine). Simulated time, so the figure is exact."""
    from rio_ufactory.emulator.motion import ModelJoints, MotionModel

    vmax = get_arm("xarm7").max_joint_speed
    m = MotionModel(ModelJoints(np.zeros(7)), vmax)
    m.step(10.0, 0.004, run=True, servo_mode=True)
    near = np.zeros(7)
    near[0] = 0.02
    m.servo(near, 10.0)  # walked to in 20 ms at full speed ...
    far = np.zeros(7)
    far[0] = -3.0
    m.servo(far, 10.09)  # ... then a far target the other way, 90 ms into the stall
    m.step(10.1, 0.1, run=True, servo_mode=True)
    assert m.q_cmd[0] == pytest.approx(0.02 - vmax * 0.01)
    m.step(10.2, 0.1, run=False, servo_mode=True)  # held: the time passes without a walk
    m.step(10.21, 0.01, run=True, servo_mode=True)
    assert m.q_cmd[0] == pytest.approx(0.02 - vmax * 0.02)


def test_servo_in_the_wrong_state_or_mode_is_refused(emulator, connect):
    arm = connect(emulator)
    target = list(_target("xarm7"))
    assert arm.set_servo_angle_j(target) == 9  # motors off, state 4: "not ready"
    _start(arm, mode=0)
    assert arm.set_servo_angle_j(target) == 10  # position mode: invalid command
    assert arm.set_mode(1) == 0
    assert wait_until(lambda: arm.state == 4, 5.0)  # changing the mode stops the arm ...
    assert arm.set_servo_angle_j(target) == 9
    assert arm.set_state(0) == 0  # ... until set_state(0)
    assert arm.set_servo_angle_j(target) == 0


@pytest.mark.parametrize("model", sorted(ARMS))
def test_servo_cartesian_moves_the_tcp_to_the_goal(make_emulator, connect, model):
    emu = make_emulator(model, gripper=None)
    if emu.machine.kin is None:
        pytest.skip(f"no kinematic model for {model}")
    arm = connect(emu)
    axis = get_arm(model).axis
    _start(arm, mode=1)
    ready = _target(model, 0.5)
    with Streamer(arm, ready):
        assert wait_until(lambda: np.abs(_angles(arm, axis) - ready).max() < 1e-4, 10.0)
    assert wait_until(lambda: np.allclose(emu.tcp_pose(), arm.position, atol=0.05), 5.0)  # report = FK
    start = np.array(arm.position)
    goal = start + np.array([15.0, -10.0, 20.0, 0.0, 0.0, 0.0])

    def near() -> bool:
        arm.set_servo_cartesian(list(goal), speed=100, mvacc=2000)
        return float(np.linalg.norm(np.array(arm.position[:3]) - goal[:3])) < 1.0

    assert wait_until(near, 10.0, period=0.01), (arm.position, goal)
    err = (np.array(arm.position[3:]) - goal[3:] + np.pi) % (2 * np.pi) - np.pi
    assert np.abs(err).max() < (0.05 if axis > 5 else 0.5)  # a 5-axis arm cannot hold every orientation
    assert np.allclose(emu.tcp_pose()[:3], arm.position[:3], atol=0.5)


def test_tool_frame_servo_cartesian_and_fk_ik(emulator, connect):
    arm = connect(emulator)
    _start(arm, mode=1)
    ready = _target("xarm7", 0.5)
    with Streamer(arm, ready):
        assert wait_until(lambda: np.abs(_angles(arm, 7) - ready).max() < 2e-3, 10.0)
    code, pose = arm.get_forward_kinematics(list(ready), input_is_radian=True, return_is_radian=True)
    assert code == 0 and np.allclose(pose, arm.position, atol=0.5)
    code, q = arm.get_inverse_kinematics(pose, input_is_radian=True, return_is_radian=True)
    assert code == 0
    code, pose2 = arm.get_forward_kinematics(q[:7], input_is_radian=True, return_is_radian=True)
    assert np.allclose(pose2[:3], pose[:3], atol=0.5)
    start = np.array(arm.position)
    assert arm.set_servo_cartesian([0, 0, 10, 0, 0, 0], is_tool_coord=True) == 0  # 10 mm along the tool's z
    assert wait_until(lambda: np.linalg.norm(np.array(arm.position[:3]) - start[:3]) > 9.0, 10.0)


# -- position mode ------------------------------------------------------------------------------------------
def test_position_moves_wait_for_completion(emulator, connect):
    arm = connect(emulator)
    _start(arm, mode=0)
    target = _target("xarm7")
    assert arm.set_servo_angle(angle=list(target), speed=1.5, mvacc=20, wait=True, timeout=20) == 0
    assert np.abs(_angles(arm, 7) - target).max() < 2e-3 and arm.state == 2
    assert arm.set_servo_angle(servo_id=1, angle=0.0, speed=1.5, wait=True) == 0  # one joint: the others stay
    assert abs(emulator.joint_pos[0]) < 2e-3 and np.allclose(emulator.joint_pos[1:], target[1:], atol=2e-3)
    start = np.array(arm.position)
    assert arm.set_position(z=start[2] + 20, speed=100, wait=True, timeout=20) == 0
    assert np.allclose(arm.position[:3], start[:3] + [0, 0, 20], atol=1.0)
    assert arm.move_gohome(speed=2.0, wait=True, timeout=20) == 0  # the controller's home: zero joints
    assert np.abs(emulator.joint_pos).max() < 2e-3
    flange = emulator.tcp_pose()  # xArm 7 at zero: flange at [206, 0, 120.5] mm, pointing down
    assert np.allclose(flange[:3], [206.0, 0.0, 120.5], atol=0.5) and abs(abs(flange[3]) - np.pi) < 1e-3
    assert arm.set_tcp_load(0.5, [0, 0, 30]) == 0 and arm.set_tcp_offset([0, 0, 50, 0, 0, 0]) == 0
    assert arm.set_collision_sensitivity(2) == 0
    assert wait_until(lambda: emulator.machine.tcp_load[0] == 0.5 and emulator.machine.collision_sens == 2, 5.0)
    # the TCP is now 50 mm out of the flange, which points down at home
    assert wait_until(lambda: abs(emulator.tcp_pose()[2] - (flange[2] - 50)) < 0.1, 5.0), emulator.tcp_pose()
    assert np.allclose(arm.position[:3], emulator.tcp_pose()[:3], atol=0.1)


def test_emergency_stop_halts_a_move(emulator, connect):
    arm = connect(emulator)
    _start(arm, mode=0)
    far = _target("xarm7", 2.0)
    assert arm.set_servo_angle(angle=list(far), speed=0.3, wait=False) == 0
    assert wait_until(lambda: arm.state == 1, 5.0)
    arm.emergency_stop()
    assert arm.state == 4 and emulator.state == 4
    held = emulator.joint_pos
    time.sleep(0.2)
    assert np.abs(emulator.joint_pos - held).max() < 1e-3 and np.abs(held - far).max() > 0.1


# -- faults -------------------------------------------------------------------------------------------------
def test_collision_stops_the_arm_and_recovers(emulator, connect):
    arm = connect(emulator)
    _start(arm, mode=1)
    target = np.array(get_arm("xarm7").home) + np.array([3.0, 0, 0, 0, 0, 0, 0])  # a second away at full speed
    with Streamer(arm, target) as s:
        assert wait_until(lambda: arm.state == 1, 5.0)
        assert emulator.inject_fault("collision") == 31
        assert wait_until(lambda: arm.state == 4 and s.codes and s.codes[-1] == 1, 5.0)  # "uxbus has error"
        held = emulator.joint_pos
        time.sleep(0.2)  # still streaming: the arm stays where it stopped
        assert np.abs(emulator.joint_pos - held).max() < 1e-3
        assert np.abs(held - target).max() > 0.01
    assert arm.get_err_warn_code() == (0, [31, 0]) and arm.error_code == 31
    assert arm.clean_error() == 0 and emulator.error_code == 0
    assert arm.get_err_warn_code() == (0, [0, 0]) and arm.error_code == 0
    assert arm.motion_enable(True) == 0 and arm.set_state(0) == 0
    with Streamer(arm, target) as s:
        assert wait_until(lambda: np.abs(emulator.joint_pos - target).max() < 2e-3, 10.0)
    assert s.codes[-1] == 0


def test_joint_limit_target_raises_the_limit_fault(make_emulator, connect):
    emu = make_emulator("xarm6")
    arm = connect(emu, check_joint_limit=False)  # the SDK would refuse the target itself
    _start(arm, mode=1)
    beyond = list(get_arm("xarm6").home)
    beyond[1] = get_arm("xarm6").limits[1][1] + 0.2
    assert arm.set_servo_angle_j(beyond) == 1  # the controller faults on it: the reply carries the error
    assert wait_until(lambda: arm.state == 4, 5.0)
    assert emu.error_code == 23 and arm.get_err_warn_code()[1][0] == 23
    assert arm.set_servo_angle_j(beyond) == 1
    assert np.abs(emu.joint_pos - get_arm("xarm6").home).max() < 1e-3
    assert emu.inject_fault("joint_limit") == 23


def test_estop_holds_until_released_and_needs_enable(emulator, connect):
    arm = connect(emulator)
    _start(arm, mode=1)
    assert emulator.inject_fault("estop") == 1
    assert wait_until(lambda: arm.state == 4, 5.0) and not emulator.enabled
    assert arm.clean_error() == 1 and arm.get_err_warn_code()[1][0] == 1  # still pressed
    emulator.release_estop()
    assert arm.clean_error() == 0 and emulator.error_code == 0
    assert arm.set_state(0) == 0 and emulator.state == 4  # motors are off: not yet
    _start(arm, mode=1)
    assert arm.set_servo_angle_j(list(_target("xarm7"))) == 0


def test_servo_fault_names_the_joint(emulator, connect):
    arm = connect(emulator, report_type="rich")
    assert emulator.inject_fault("servo", joint=3) == 13
    assert emulator.inject_fault("servo") == 10
    assert wait_until(lambda: arm.error_code == 10 and arm.state == 4, 5.0)
    with pytest.raises(ValueError):
        emulator.inject_fault("servo", joint=8)
    with pytest.raises(ValueError):
        emulator.inject_fault("meteor")


# -- connections ---------------------------------------------------------------------------------------------
def test_dropped_connections_are_noticed_and_a_new_client_connects(emulator, connect):
    arm = connect(emulator)
    _start(arm, mode=1)
    assert wait_until(lambda: emulator.clients >= 2, 5.0)
    assert emulator.drop_connections() >= 2
    assert wait_until(lambda: not arm.connected, 10.0)
    again = connect(emulator)
    assert again.connected and again.axis == 7
    assert wait_until(lambda: again.state == 2 and again.mode == 1, 5.0)  # the controller kept its state
    assert again.set_servo_angle_j(list(_target("xarm7"))) == 0
    assert wait_until(lambda: np.abs(emulator.joint_pos - _target("xarm7")).max() < 0.05, 10.0)


def test_unknown_command_answers_invalid_and_is_logged_once(emulator, connect, caplog):
    arm = connect(emulator)
    with caplog.at_level(logging.WARNING, logger="rio_ufactory.emulator"):
        assert arm._arm.arm_cmd.get_nu8(222, 4)[0] == 10
        assert arm._arm.arm_cmd.get_nu8(222, 4)[0] == 10
    assert sum("register 222" in r.getMessage() for r in caplog.records) == 1
    assert arm.get_state() == (0, 4)  # the connection is fine


def test_framing_round_trip():
    buf = bytearray(bytes([0, 7, 0, 2, 0, 2, 13, 0]) + bytes([0, 8, 0, 2, 0, 1]))
    reqs = list(split_frames(buf))
    assert [(r.transaction, r.register, r.params) for r in reqs] == [(7, 13, b"\x00")]
    assert buf == bytearray(bytes([0, 8, 0, 2, 0, 1]))  # the partial frame waits
    fb = feedback_frame(7, 3, 0, 2, 23, 0, t_us=5)
    assert (fb[6], fb[8], fb[9], fb[12]) == (0xFF, 2, 23, 0)  # feedback register, kind, command, code
    assert int.from_bytes(fb[4:6], "big") == len(fb) - 6


# -- tool port: grippers --------------------------------------------------------------------------------------
def test_xarm_gripper_opens_closes_and_stops_on_an_object(emulator, connect):
    arm = connect(emulator)
    assert arm.set_gripper_enable(True) == 0 and arm.set_gripper_mode(0) == 0 and arm.set_gripper_speed(5000) == 0
    assert arm.get_gripper_position() == (0, 850)  # open at power-on
    assert arm.set_gripper_position(0, wait=True) == 0
    assert wait_until(lambda: arm.get_gripper_position()[1] == 0, 5.0)
    assert arm.set_gripper_position(850, wait=True) == 0
    assert abs(arm.get_gripper_position()[1] - 850) <= 1
    emulator.gripper.fingers.object_width = 0.03
    assert arm.set_gripper_position(0, wait=True) == 0
    assert wait_until(lambda: arm.get_gripper_position()[1] == 300, 5.0), arm.get_gripper_position()
    assert emulator.gripper.fingers.object_detected
    assert arm.get_gripper_err_code() == (0, 0)
    assert arm.get_gripper_status()[1] & 0x03 == 2  # stopped on the object


def test_xarm_gripper_needs_enable(emulator, connect):
    arm = connect(emulator)
    assert arm.set_gripper_position(0, wait=False) == 0
    time.sleep(0.2)
    assert arm.get_gripper_position() == (0, 850)


def test_xarm_gripper_g2(make_emulator, connect):
    emu = make_emulator(gripper="xarm_g2")
    arm = connect(emu)
    assert arm.set_gripper_g2_position(40, speed=150, wait=True) == 0
    assert wait_until(lambda: abs(arm.get_gripper_g2_position()[1] - 40) <= 1, 5.0), arm.get_gripper_g2_position()
    assert emu.gripper.fingers.position == pytest.approx(0.040, abs=0.0015)


def test_bio_gripper(make_emulator, connect):
    emu = make_emulator("lite6", gripper="bio")
    arm = connect(emu)
    assert arm.set_bio_gripper_enable(True) == 0
    assert arm.get_bio_gripper_status()[0] == 0 and arm._arm.bio_gripper_is_enabled
    assert arm.close_bio_gripper(speed=3000, wait=True) == 0
    assert wait_until(lambda: arm.get_bio_gripper_g2_position() == (0, 71), 5.0), arm.get_bio_gripper_g2_position()
    assert arm.set_bio_gripper_g2_position(120, speed=3000, wait=True) == 0
    assert arm.get_bio_gripper_g2_position() == (0, 120)
    emu.gripper.fingers.object_width = 0.100
    assert arm.close_bio_gripper(speed=3000, wait=True) == 0
    assert wait_until(lambda: arm.get_bio_gripper_g2_position() == (0, 100), 5.0)
    assert arm.get_bio_gripper_status()[1] & 0x03 == 2


def test_lite6_gripper_and_vacuum_on_tool_gpio(make_emulator, connect):
    emu = make_emulator("lite6", gripper="lite6")
    arm = connect(emu)
    fingers = emu.gripper.fingers
    assert arm.close_lite6_gripper() == 0
    assert wait_until(lambda: fingers.update() < 1e-9, 5.0)
    assert arm.get_tgpio_output_digital()[1][:2] == [0, 1]
    assert arm.open_lite6_gripper() == 0
    assert wait_until(lambda: fingers.update() > fingers.max_width - 1e-9, 5.0)
    assert arm.close_lite6_gripper() == 0
    time.sleep(0.1)
    assert arm.stop_lite6_gripper() == 0
    held = fingers.update()
    time.sleep(0.1)
    assert 0.0 < fingers.update() == held < fingers.max_width
    assert arm.set_vacuum_gripper(True) == 0
    assert arm.get_vacuum_gripper() == (0, 0)  # sucking air
    emu.gripper.vacuum_object = True
    assert arm.set_vacuum_gripper(True, wait=True, timeout=3) == 0
    assert arm.get_vacuum_gripper() == (0, 1)
    assert arm.set_vacuum_gripper(False) == 0
    assert arm.get_vacuum_gripper() == (0, -1)  # off


def test_tool_gpio_delayed_output(emulator, connect):
    arm = connect(emulator)
    _start(arm, mode=0)
    assert arm.set_tgpio_digital(0, 1, delay_sec=0.1) == 0
    assert wait_until(lambda: arm.get_tgpio_output_digital()[1][0] == 1, 5.0)


class _FakeRobotiq:
    """A minimal slave 9: echoes writes, answers reads with a recognisable status."""

    def __init__(self):
        self.frames = []

    def handle(self, frame: bytes) -> bytes:
        self.frames.append(frame)
        if frame[1] == 0x10:
            return frame[:6]
        count = frame[5]
        return bytes([frame[0], frame[1], 2 * count]) + bytes([0x31] + [0] * (2 * count - 1))


def test_robotiq_frames_reach_the_register_object(make_emulator, connect):
    fake = _FakeRobotiq()
    emu = make_emulator(gripper="robotiq", robotiq=fake)
    arm = connect(emu)
    code, _ = arm.robotiq_reset()
    assert code == 0 and fake.frames[-1][:2] == bytes([9, 0x10])
    code, ret = arm.robotiq_get_status()
    assert code == 0 and ret[3] == 0x31 and arm.robotiq_status["gSTA"] == 3


def test_robotiq_2f85_through_the_sdk(make_emulator, connect):
    pytest.importorskip("rio_robotiq.emulator.registers", reason="rio_robotiq's register model is not installed")
    emu = make_emulator(gripper="robotiq")
    arm = connect(emu)
    assert arm.robotiq_reset()[0] == 0
    assert arm.robotiq_set_activate(wait=True)[0] == 0
    assert arm.robotiq_close(wait=True)[0] == 0
    assert wait_until(lambda: arm.robotiq_get_status()[0] == 0 and arm.robotiq_status["gPO"] >= 0xE0, 5.0)
    emu.gripper.fingers.object_width = 0.04
    assert arm.robotiq_open(wait=True)[0] == 0
    assert arm.robotiq_close(wait=True)[0] == 0
    assert wait_until(lambda: arm.robotiq_get_status()[0] == 0 and arm.robotiq_status["gOBJ"] == 2, 5.0)


def test_baud_rate_mismatch_silences_the_gripper(emulator, connect):
    arm = connect(emulator)
    assert arm.set_gripper_enable(True) == 0  # the SDK checks and sets 2 Mbaud first
    assert arm.set_tgpio_modbus_baudrate(115200) == 0
    assert arm.get_gripper_position(check_baud=False)[0] != 0  # nobody answers at the wrong speed
    assert arm.get_gripper_position()[0] == 0  # the SDK puts it back


# -- lifecycle --------------------------------------------------------------------------------------------------
def _emulator_threads() -> set[threading.Thread]:
    return {t for t in threading.enumerate() if t.name.startswith(("rio-tcp", "rio-xarm"))}


def test_stop_releases_ports_and_threads(make_emulator, connect):
    before = _emulator_threads()
    emu = make_emulator()
    host = emu.host
    arm = connect(emu)
    assert arm.connected and wait_until(lambda: emu.clients == 2, 5.0)
    assert len(_emulator_threads() - before) >= 4 + 1 + 2  # accept loops, control loop, clients
    emu.stop()
    assert not (_emulator_threads() - before)  # stop() joined them all
    assert wait_until(lambda: not arm.connected, 10.0)
    with XArmEmulator("xarm7", host=host) as emu:  # the same address again
        assert emu.state == 4
    with pytest.raises(ValueError):
        XArmEmulator("xarm7", host=host, gripper="hook")
    with pytest.raises(ValueError):
        XArmEmulator("xarm7", host=host, backend="gazebo")


# -- rio-sim backend ----------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def sim_world():
    pytest.importorskip("rio_sim.world_arm", reason="rio-sim is not installed")
    pytest.importorskip("mujoco")
    from rio_sim.testing import running_world

    with running_world("xarm7", "ufemu"):
        yield "ufemu"


def test_sim_backend_moves_the_world_arm(sim_world, make_emulator, connect):
    from rio_sim.robots import get_robot

    emu = make_emulator("xarm7", backend=f"sim:arm@{sim_world}", gripper="xarm")
    world = emu._world_arm
    assert np.allclose(emu.joint_pos, world.joint_pos(), atol=1e-3)
    arm = connect(emu)
    assert wait_until(lambda: np.allclose(_angles(arm, 7), world.joint_pos(), atol=2e-3), 5.0)
    _start(arm, mode=1)
    target = np.array(get_robot("xarm7").home) + np.array([0.2, 0.1, -0.1, 0.2, 0.1, -0.1, 0.2])
    with Streamer(arm, target):
        assert wait_until(lambda: np.abs(world.joint_pos() - target).max() < 0.01, 15.0), world.joint_pos()
    assert np.allclose(_angles(arm, 7), world.joint_pos(), atol=0.01)
    assert arm.set_gripper_enable(True) == 0 and arm.set_gripper_speed(5000) == 0
    assert arm.set_gripper_position(400, wait=True) == 0
    assert wait_until(lambda: abs(world.finger_width() - 0.04) < 0.003, 10.0), world.finger_width()
    assert abs(arm.get_gripper_position()[1] - 400) < 30


def test_sim_backend_refuses_an_arm_with_other_joints(sim_world):
    with pytest.raises(ValueError, match="7 joints"):
        XArmEmulator("xarm6", host="127.0.0.1", backend=f"sim:arm@{sim_world}", sim_timeout=10)
