"""The unmodified `unitree.g1` driver against the MuJoCo DDS bridge over real DDS on loopback: holding
a pose, an arm over rt/arm_sdk beside the legs' hold, a command with a bad CRC, and the driver's own
stops (a stream that goes silent, a fall, a robot that goes quiet, none at all), each seen where it
matters: the simulated joints, the sample, and the bytes on the wire (a raw DDS tap)."""

from __future__ import annotations

import time

import numpy as np
import pytest
from rio_unitree.commands import is_damping
from rio_unitree.dds import ARM_SDK, LOWCMD, LOWSTATE, Participant
from rio_unitree.g1 import WEIGHT_SLOT, joint_names
from rio_unitree.testing import Tap, publishing
from rio_unitree.wire import LowCmd, LowState

from rio import clock
from rio.conformance.driving import Loop, build_node, resolve_driver
from rio.errors import InvalidRequest
from rio.interfaces.damping import FALL, STALE_COMMANDS, STATE_LOST, tilt_from_quat
from rio.testing import lifecycle, wait_until


def g1(domain_id: int, **fields):
    values = {"interface": "lo", "domain_id": domain_id, "rate_hz": 200.0, "state_timeout_s": 1.0, **fields}
    return build_node(resolve_driver("unitree.g1"), values, "g1")


def command(node, q, t_cmd_target):
    node.handle_request({"joint_pos": np.asarray(q, dtype=np.float64), "t_cmd_target": float(t_cmd_target)})


def test_commanding_the_current_pose_keeps_the_robot_there(make_bridge, domain_id):
    bridge = make_bridge()
    node = g1(domain_id, control="lowcmd")  # Unitree's deploy gains (the defaults)
    with lifecycle(node):
        loop = Loop(node)
        q0 = loop.run(cycles=3)["joint_pos"]
        t_end, worst = clock.now() + 1.5, 0.0
        while clock.now() < t_end:  # a policy streaming "stay" at the node's rate
            command(node, q0, clock.now() + 0.02)
            s = loop.tick()
            worst = max(worst, float(np.abs(s["joint_pos"] - q0).max()))
        assert worst < 0.05, worst
        assert s["fault_code"] == 0 and s["enabled"] and not s["holding"]
        assert np.abs(bridge.joint_pos() - q0).max() < 0.05
        assert bridge.counts.lowcmd > 100 and bridge.counts.bad_crc == 0


def test_an_arm_moves_over_arm_sdk_while_the_legs_keep_their_hold(make_bridge, domain_id):
    bridge = make_bridge()  # no lowcmd: its stand-in for Unitree's locomotion holds the body
    legs0 = bridge.joint_pos()[:12]
    node = g1(domain_id, arm_sdk_ramp_s=1.0, max_step_rad=0.02)  # control = "arm_sdk" by default
    names = node.joint_names()
    assert names == joint_names(29, upper_body_only=True)
    elbow, shoulder = names.index("left_elbow_joint"), names.index("left_shoulder_pitch_joint")
    with Tap(domain_id, ARM_SDK) as tap:
        with lifecycle(node):
            loop = Loop(node)
            q0 = loop.run(cycles=3)["joint_pos"]
            target = q0.copy()
            target[elbow] -= 0.6
            target[shoulder] -= 0.5
            command(node, target, clock.now() + 1.0)
            loop.run(until=lambda s: np.abs(s["joint_pos"] - target).max() < 0.05, timeout=5.0)
            loop.run(seconds=0.3)
            assert np.abs(loop.last["joint_pos"] - target).max() < 0.06, loop.last["joint_pos"] - target
            assert np.abs(bridge.joint_pos()[:12] - legs0).max() < 0.02  # the legs never left their hold
            tap.poll()
            weights = [float(m.q[WEIGHT_SLOT]) for m in tap.samples]
            assert weights[0] < 0.3 and weights[-1] == 1.0 and np.all(np.diff(weights) >= 0)  # ramped in
            assert all((m.kp[:12] == 0).all() and (m.mode[:12] == 0).all() for m in tap.samples)  # legs: not ours
        time.sleep(0.1)
        tap.poll()
    weights = [float(m.q[WEIGHT_SLOT]) for m in tap.samples]
    assert weights[-1] == 0.0  # close() ramped the weight down: the arms are Unitree's again
    i_top = len(weights) - 1 - weights[::-1].index(1.0)
    assert len(weights) - i_top > 10 and np.all(np.diff(weights[i_top:]) <= 0)  # gradually
    assert wait_until(lambda: abs(bridge.joint_pos()[18] - bridge.start_q[18]) < 0.1, timeout=3.0)
    assert bridge.counts.bad_crc == 0


def test_the_bridge_ignores_a_command_with_a_bad_crc(make_bridge, domain_id):
    bridge = make_bridge()
    time.sleep(0.5)  # the stand-in hold settles under gravity
    q0 = bridge.joint_pos()
    wild = LowCmd()
    wild.mode[:29], wild.kp[:29], wild.kd[:29] = 1, 200.0, 5.0
    wild.q[:29] = q0 + 0.4
    good = wild.encode()
    wild.crc ^= 0x5A5A5A5A
    bad = wild.encode(fix_crc=False)
    with Participant(domain_id, "lo") as p:
        out = p.writer(LOWCMD)

        def send(data, n=5):
            for _ in range(n):
                out.write(data)
                time.sleep(0.01)

        assert wait_until(lambda: send(bad) or bridge.counts.bad_crc >= 10, timeout=5.0)
        time.sleep(0.3)
        assert bridge.counts.lowcmd == 0
        assert np.abs(bridge.joint_pos() - q0).max() < 0.01  # nothing moved
        assert wait_until(lambda: send(good, 1) or bridge.counts.lowcmd > 0, timeout=5.0)
        assert wait_until(lambda: abs(bridge.joint_pos()[18] - (q0[18] + 0.4)) < 0.1, timeout=3.0)  # it would have


def test_a_stream_that_stops_is_damped_not_held_stiff(make_bridge, domain_id):
    make_bridge()
    node = g1(domain_id, control="lowcmd", watchdog_s=0.3)
    elbow = node.joint_names().index("left_elbow_joint")
    with Tap(domain_id, LOWCMD) as tap, lifecycle(node):
        loop = Loop(node)
        q0 = loop.run(cycles=3)["joint_pos"]
        target = q0.copy()
        target[elbow] -= 0.8
        for _ in range(10):  # a policy streaming toward a target still 5 s away ... then it crashes
            command(node, target, clock.now() + 5.0)
            loop.tick()
        assert tap.wait(lambda m: m.kp[18] > 0) is not None
        s = loop.run(until=lambda s: s["fault_code"] != 0, timeout=3.0)
        assert s["fault_code"] == STALE_COMMANDS and not s["enabled"]
        soft = tap.wait(is_damping, timeout=2.0)
        assert soft is not None and (soft.kd[:29] > 0).all() and soft.mode_machine == 5
        loop.run(cycles=10)
        assert all(is_damping(m) for m in tap.poll())  # damping every cycle from then on
        with pytest.raises(InvalidRequest, match="stale_commands"):
            command(node, target, clock.now() + 1.0)
        node.clear_faults()  # holds where the robot is now, stiff again
        s = loop.run(cycles=5)
        assert s["enabled"] and s["fault_code"] == 0
        assert tap.wait(lambda m: m.kp[18] > 0) is not None
        node.disable()  # and a disable is damping at once
        assert is_damping(tap.wait(lambda m: True))


def test_a_fall_damps_and_faults_until_the_robot_is_upright(make_bridge, domain_id):
    bridge = make_bridge()
    node = g1(domain_id, control="lowcmd")
    with Tap(domain_id, LOWCMD) as tap, lifecycle(node):
        loop = Loop(node)
        loop.run(cycles=3)
        bridge.tilt(70.0)  # the mount tilts: to the IMU, a fall forward
        s = loop.run(until=lambda s: s["fault_code"] != 0, timeout=3.0)
        assert s["fault_code"] == FALL and node.faults.fault.name == "fall" and not s["enabled"]
        assert tilt_from_quat(s["base_quat"]) == pytest.approx(70.0, abs=1.0)
        assert tap.wait(is_damping, timeout=2.0) is not None
        with pytest.raises(InvalidRequest, match="fall"):
            node.clear_faults()  # refused while it lies there
        bridge.tilt(0.0)
        loop.run(cycles=5)
        node.clear_faults()
        s = loop.run(cycles=3)
        assert s["enabled"] and s["fault_code"] == 0


def test_a_free_standing_robot_that_falls_over_is_caught(make_bridge, domain_id):
    make_bridge(mounted=False)  # on the floor, nothing balancing it: it topples
    node = g1(domain_id, control="lowcmd", enable_on_open=False)
    with lifecycle(node):
        s = Loop(node).run(until=lambda s: s["fault_code"] != 0, timeout=5.0)
        assert s["fault_code"] == FALL and tilt_from_quat(s["base_quat"]) > 45.0


def test_a_robot_that_goes_quiet_is_a_named_fault(make_bridge, domain_id):
    bridge = make_bridge()
    node = g1(domain_id, control="lowcmd", state_timeout_s=0.3)
    with lifecycle(node):
        loop = Loop(node)
        loop.run(cycles=3)
        bridge.stop()
        s = loop.run(until=lambda s: s["fault_code"] != 0, timeout=3.0)
        assert s["fault_code"] == STATE_LOST and "no rt/lowstate" in str(node.faults.fault)
        with pytest.raises(InvalidRequest, match="lowstate_timeout"):
            node.enable()


def test_the_bridge_keeps_publishing_while_its_physics_is_slow(make_bridge, monkeypatch):
    """A physics step that takes 0.3 s (a host too loaded to run MuJoCo in real time): rt/lowstate goes out at
    its rate meanwhile, the latest state each time, as a robot's does (published from the physics thread at
    simulated times, the stream stopped with the physics: Dex3 state gaps of up to 0.9 s under load)."""
    from rio_unitree.bridge.sim import Bridge

    slow: list[float] = []
    sent: list[float] = []
    step = Bridge._step

    def slow_step(self):
        if not slow and len(sent) > 20:
            slow.append(time.monotonic())
            time.sleep(0.3)
        step(self)

    monkeypatch.setattr(Bridge, "_step", slow_step)
    bridge = make_bridge(state_rate_hz=200.0)
    writer = bridge._state_out

    class Timed:  # the bridge's rt/lowstate writer, noting when each state went out
        def write(self, data):
            sent.append(time.monotonic())
            return writer.write(data)

    bridge._state_out = Timed()
    assert wait_until(lambda: bool(slow) and time.monotonic() > slow[0] + 0.35, 10.0), "the physics never ran"
    during = [t for t in sent if slow[0] + 0.05 < t < slow[0] + 0.25]
    assert len(during) >= 5, (len(during), bridge.counts)  # 200 Hz: ~40 in 0.2 s on a quiet machine


def test_no_lowstate_at_open_is_a_named_error_within_the_timeout(domain_id):
    node = g1(domain_id, connect_timeout_s=0.5)
    t0 = time.monotonic()
    named = rf"no rt/lowstate on interface 'lo' \(DDS domain {domain_id}\) within 0.5 s"
    with pytest.raises(TimeoutError, match=named):
        node.open()
    assert time.monotonic() - t0 < 3.0
    assert node.dds is None  # its participant is closed


def test_a_station_that_stops_ends_the_wait_for_lowstate(domain_id):
    """Another node of the station failed while this one waited for its robot: the station's stop ends the
    wait (seen: a thread left waiting out its 30 s after the bridge beside it failed to start)."""
    import threading

    node = g1(domain_id, connect_timeout_s=60.0)
    threading.Timer(0.3, node.exit_event.set).start()
    t0 = time.monotonic()
    with pytest.raises(ConnectionAbortedError, match="stopped while waiting for rt/lowstate on 'lo'"):
        node.open()
    assert time.monotonic() - t0 < 10.0  # not the 60 s timeout
    assert node.dds is None


def test_a_lowstate_with_a_wrong_crc_is_not_believed(domain_id):
    wrong = LowState()
    wrong.crc = 1
    with Participant(domain_id, "lo") as p, publishing(p.writer(LOWSTATE), wrong.encode(fix_crc=False)):
        for peer in ("robot", "simulator"):  # a simulator's state may be unsigned, never wrongly signed
            with pytest.raises(TimeoutError, match="arrived with a wrong CRC"):
                g1(domain_id, connect_timeout_s=0.5, peer=peer, control="lowcmd").open()


def test_a_simulator_s_unsigned_state_is_believed_when_the_station_says_so(domain_id):
    """Unitree's unitree_mujoco publishes rt/lowstate with CRC 0: refused from a robot (the error says what
    to set), believed with peer = "simulator" (and with the field's old name, check_state_crc = false)."""
    unsigned = LowState().encode(fix_crc=False)
    with Participant(domain_id, "lo") as p, publishing(p.writer(LOWSTATE), unsigned):
        with pytest.raises(TimeoutError, match=r'arrived unsigned, CRC 0.*set peer = "simulator"'):
            g1(domain_id, connect_timeout_s=0.5, control="lowcmd").open()
        for fields in ({"peer": "simulator"}, {"check_state_crc": False}):
            trusting = g1(domain_id, control="lowcmd", enable_on_open=False, **fields)
            assert trusting.config.peer == "simulator"
            with lifecycle(trusting):
                assert trusting.cycle()["joint_pos"].shape == (29,)


def test_arm_sdk_that_nobody_reads_is_an_error(domain_id):
    """unitree_mujoco does not listen on rt/arm_sdk: a station left on control = "arm_sdk" would run to a
    normal end with the arms never moved. The driver refuses to start, naming the fix."""
    with Participant(domain_id, "lo") as p, publishing(p.writer(LOWSTATE), LowState().encode()):
        with pytest.raises(ConnectionError, match=r'nothing reads rt/arm_sdk.*set control = "lowcmd"'):
            g1(domain_id, connect_timeout_s=0.5).open()


@pytest.mark.parametrize("fields, problem", [
    ({"joint_names": ["left_knee_joint", "left_elbow_joint"]}, "drives the waist and arms only"),
    ({"dof": 23, "control": "lowcmd", "joint_names": ["waist_roll_joint"]}, "has no joints"),
    ({"control": "lowcmd", "kp": [100.0]}, "kp has 1 values"),
    ({"joint_names": ["left_elbow_jont"]}, "unknown G1 joints"),
])
def test_config_mistakes_are_named(fields, problem):
    with pytest.raises(Exception, match=problem):
        g1(0, **fields)


def test_the_23_dof_preset_drives_its_23_joints():
    node = build_node(resolve_driver("unitree.g1_23dof"), {"control": "lowcmd"}, "g1")
    assert node.dof == 23 and node.joint_names() == joint_names(23)
    assert build_node(resolve_driver("unitree.g1_23dof"), {}, "g1").dof == 11  # arm_sdk: waist yaw + 2 x 5
