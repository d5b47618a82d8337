"""The unmodified `booster.t1` driver against the emulated T1.

NOT the SDK's transport: the SDK offers no publisher for `rt/low_state`, no subscriber for
`rt/joint_ctrl`, and read-only `MotorState`s, so nothing can play the robot's side of its DDS with the
SDK's own types. The driver is pointed (`sdk = "rio_booster.emulator"`) at an SDK-object fake with the same
names and signatures (`ChannelFactory`, `B1LowStateSubscriber`, `B1LowCmdPublisher`, `B1LocoClient`)
backed by an emulated robot; the command objects (`LowCmd`, `MotorCmd`, `LowCmdType`, `RobotMode`) are the
SDK's own when it is installed, so what the driver would write to the robot is what is checked here.
`test_sdk.py` checks the fake's surface against the real SDK's."""

from __future__ import annotations

import time

import numpy as np
import pytest
from rio_booster.emulator import CUSTOM, DAMPING, PREPARE
from rio_booster.t1 import joint_names

from rio import clock
from rio.conformance.driving import Loop, build_node, resolve_driver
from rio.control.rotations import quat_to_euler
from rio.errors import InvalidRequest
from rio.interfaces.damping import FALL, STALE_COMMANDS, STATE_LOST, tilt_from_rpy
from rio.testing import lifecycle

ELBOW = joint_names().index("Left_Elbow_Pitch")


def t1(domain_id: int, **fields):
    values = {"sdk": "rio_booster.emulator", "domain_id": domain_id, "rate_hz": 200.0, "prepare_s": 0.1,
              "state_timeout_s": 1.0, **fields}
    return build_node(resolve_driver("booster.t1"), values, "t1")


def command(node, q, t_cmd_target):
    node.handle_request({"joint_pos": np.asarray(q, dtype=np.float64), "t_cmd_target": float(t_cmd_target)})


def test_enable_goes_prepare_then_custom_and_holds_the_pose(make_robot, domain_id):
    robot = make_robot(mode=DAMPING)  # as the robot is after power-on with the remote's damping
    node = t1(domain_id)
    with lifecycle(node):
        loop = Loop(node)
        q0 = loop.run(cycles=3)["joint_pos"]
        assert robot.modes == [DAMPING, PREPARE, CUSTOM]
        t_end, worst = clock.now() + 1.0, 0.0
        while clock.now() < t_end:  # a policy streaming "stay"
            command(node, q0, clock.now() + 0.02)
            s = loop.tick()
            worst = max(worst, float(np.abs(s["joint_pos"] - q0).max()))
        assert worst < 0.02, worst
        assert s["fault_code"] == 0 and s["enabled"] and s["robot_mode"] == CUSTOM
        assert np.allclose(s["base_quat"], [1, 0, 0, 0]) and s["base_ang_vel"].shape == (3,)
        assert robot.counts.obeyed > 50 and robot.counts.parallel == 0
        f = robot.last_frame
        assert (f.kp > 0).all() and (f.dq == 0).all() and (f.tau == 0).all()
    assert robot.modes[-1] == DAMPING and robot.last_frame.is_damping()  # close() let go


def test_a_joint_moves_to_its_target(make_robot, domain_id):
    robot = make_robot()
    node = t1(domain_id, max_step_rad=0.01)
    with lifecycle(node):
        loop = Loop(node)
        q0 = loop.run(cycles=3)["joint_pos"]
        target = q0.copy()
        target[ELBOW] += 0.6
        command(node, target, clock.now() + 0.5)
        s = loop.run(until=lambda s: abs(s["joint_pos"][ELBOW] - target[ELBOW]) < 0.01, timeout=5.0)
        assert abs(s["joint_pos"][ELBOW] - target[ELBOW]) < 0.01
        assert abs(robot.joint_pos()[ELBOW] - target[ELBOW]) < 0.02
        others = np.delete(np.arange(23), ELBOW)
        assert np.abs(s["joint_pos"][others] - q0[others]).max() < 0.02


def test_a_target_beyond_the_limit_ends_at_the_limit_on_the_wire(make_robot, domain_id):
    robot = make_robot()
    node = t1(domain_id, max_step_rad=0.05)
    with lifecycle(node):
        loop = Loop(node)
        q0 = loop.run(cycles=3)["joint_pos"]
        target = q0.copy()
        target[ELBOW] = 10.0
        command(node, target, clock.now())
        loop.run(seconds=0.5)
        upper = node.joint_limits()[1][ELBOW]
        assert max(f.q[ELBOW] for f in robot.frames) <= upper + 1e-6
        assert loop.last["joint_pos"][ELBOW] == pytest.approx(upper, abs=0.02)


def test_a_stream_that_stops_is_damped_not_held_stiff(make_robot, domain_id):
    robot = make_robot()
    node = t1(domain_id, watchdog_s=0.3)
    with lifecycle(node):
        loop = Loop(node)
        q0 = loop.run(cycles=3)["joint_pos"]
        target = q0.copy()
        target[ELBOW] += 0.8
        for _ in range(10):  # a policy streaming toward a target still 5 s away ... then it crashes
            command(node, target, clock.now() + 5.0)
            loop.tick()
        s = loop.run(until=lambda s: s["fault_code"] != 0, timeout=3.0)
        assert s["fault_code"] == STALE_COMMANDS and not s["enabled"]
        assert robot.last_frame.is_damping() and robot.mode == DAMPING
        n = len(robot.frames)
        loop.run(cycles=10)
        assert len(robot.frames) > n and all(f.is_damping() for f in robot.frames[n:])  # damping every cycle
        with pytest.raises(InvalidRequest, match="stale_commands"):
            command(node, target, clock.now() + 1.0)
        node.clear_faults()  # prepare -> custom again, holding where the robot is
        s = loop.run(cycles=5)
        assert s["enabled"] and s["fault_code"] == 0 and robot.mode == CUSTOM and not robot.last_frame.is_damping()
        node.disable()  # a disable is damping at once, on the wire and in the robot's mode
        assert robot.last_frame.is_damping() and robot.mode == DAMPING


def test_a_fall_damps_and_faults_until_the_robot_is_upright(make_robot, domain_id):
    robot = make_robot()
    node = t1(domain_id)
    with lifecycle(node):
        loop = Loop(node)
        loop.run(cycles=3)
        robot.tilt(70.0)
        s = loop.run(until=lambda s: s["fault_code"] != 0, timeout=3.0)
        assert s["fault_code"] == FALL and node.faults.fault.name == "fall" and not s["enabled"]
        assert tilt_from_rpy(quat_to_euler(s["base_quat"])) == pytest.approx(70.0, abs=0.5)
        assert robot.last_frame.is_damping() and robot.mode == DAMPING
        with pytest.raises(InvalidRequest, match="fall"):
            node.clear_faults()  # refused while it lies there
        robot.tilt(0.0)
        loop.run(cycles=5)
        node.clear_faults()
        s = loop.run(cycles=3)
        assert s["enabled"] and s["fault_code"] == 0 and robot.mode == CUSTOM


def test_a_robot_that_goes_quiet_is_a_named_fault(make_robot, domain_id):
    robot = make_robot()
    node = t1(domain_id, state_timeout_s=0.3)
    with lifecycle(node):
        loop = Loop(node)
        loop.run(cycles=3)
        robot.publishing = False
        s = loop.run(until=lambda s: s["fault_code"] != 0, timeout=3.0)
        assert s["fault_code"] == STATE_LOST and "no rt/low_state" in str(node.faults.fault)
        assert robot.last_frame.is_damping() and robot.mode == DAMPING
        with pytest.raises(InvalidRequest, match="lowstate_timeout"):
            node.enable()


def test_the_state_keeps_coming_while_a_physics_tick_is_slow(make_robot):
    """A physics tick that takes 0.3 s (a loaded host; MuJoCo's steps): the robot's state stream goes on at
    its rate meanwhile, as a real robot's does (with one thread for both, it stopped for the whole tick
    and the driver took the robot for lost)."""
    robot = make_robot(rate_hz=200.0)
    seen: list[float] = []
    step, slow = robot.step, []

    def slow_step(*args) -> None:
        if not slow:
            slow.append(time.monotonic())
            time.sleep(0.3)
        step(*args)

    robot.subscribe(lambda _msg: seen.append(time.monotonic()))
    robot.step = slow_step
    t_end = time.monotonic() + 1.0
    while not slow or time.monotonic() < slow[0] + 0.35:
        assert time.monotonic() < t_end, "the physics never ran"
        time.sleep(0.01)
    during = [t for t in seen if slow[0] + 0.05 < t < slow[0] + 0.25]
    assert len(during) >= 5, (len(during), robot.counts)  # 200 Hz: 40 in 0.2 s on a quiet machine


def test_a_late_physics_tick_obeys_each_command_from_when_it_arrived(monkeypatch):
    """The physics thread 20 ms late, a command to bend the elbow arriving 1 ms before it runs: the joints
    obey the command before it until then and the new one for that 1 ms, as a robot's motors would, not
    for the whole 20 ms. Simulated time and the ideal joints (no thread started), so it is exact."""
    from rio_booster import emulator as em
    from rio_booster.commands import Frame, to_low_cmd

    now = [100.0]
    monkeypatch.setattr(em, "time", type("Clock", (), {"monotonic": staticmethod(lambda: now[0])}))

    def frame(q):
        n = len(q)
        return to_low_cmd(em, Frame(q=q, dq=np.zeros(n), tau=np.zeros(n), kp=np.full(n, 40.0), kd=np.full(n, 2.0)))

    late, reference = em.EmulatedT1(mode=CUSTOM), em.EmulatedT1(mode=CUSTOM)
    q0 = late.q.copy()
    bent = q0.copy()
    bent[ELBOW] += 0.5
    late.receive(frame(q0))  # hold where it is ...
    late.step(0.001, now=100.0)
    now[0] = 100.019
    late.receive(frame(bent))  # ... then bend, 1 ms before the late tick
    late.step(0.02, now=100.02)
    reference.receive(frame(bent))
    reference.step(0.001, now=100.02)
    np.testing.assert_allclose(late.q, reference.q, atol=1e-12)
    assert late.q[ELBOW] > q0[ELBOW]


def test_no_low_state_at_open_is_a_named_error_within_the_timeout(make_robot, domain_id):
    robot = make_robot()
    robot.publishing = False
    node = t1(domain_id, connect_timeout_s=0.3)
    t0 = time.monotonic()
    with pytest.raises(TimeoutError, match=rf"no rt/low_state .* \(DDS domain {domain_id}\) within 0.3 s"):
        node.open()
    assert time.monotonic() - t0 < 3.0 and node._pub is None  # its channels are closed


def test_a_mode_change_the_robot_refuses_is_named(make_robot, domain_id):
    make_robot(loco=False)  # the loco service does not answer
    node = t1(domain_id)
    with pytest.raises(RuntimeError, match=r"ChangeMode\(prepare\) failed"):
        with lifecycle(node):
            pass


def test_without_loco_the_driver_only_streams(make_robot, domain_id):
    robot = make_robot(mode=CUSTOM)  # put in custom mode by hand
    node = t1(domain_id, loco=False)
    with lifecycle(node):
        s = Loop(node).run(cycles=5)
        assert s["enabled"] and s["robot_mode"] == -1 and robot.counts.obeyed > 0
    assert robot.modes == [CUSTOM] and robot.last_frame.is_damping()
