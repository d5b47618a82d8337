"""The driver and the bridge put the robot's exact bytes on the wire: the numpy codec against cyclonedds'
own serializer of the SDK's IDL types, and the CRC against the SDK's `CRC().Crc()`, on random messages
both ways; the commands the driver builds (damping, arm_sdk weight in slot 29, limits and torque band)."""

from __future__ import annotations

import numpy as np
import pytest
import rio_unitree.wire as wire
from rio_unitree.commands import Commands, is_damping
from rio_unitree.g1 import JOINTS, WEIGHT_SLOT, joint_names, lookup
from rio_unitree.wire import LowCmd, LowState, cmd_crc_ok, crc32_words, state_crc_ok

rng = np.random.default_rng(7)


def _f(*shape):
    return rng.normal(size=shape).astype(np.float32)


def _u(hi, *shape, dtype=np.uint32):
    return rng.integers(0, hi, shape, dtype=np.uint64).astype(dtype)


def random_cmd() -> LowCmd:
    return LowCmd(int(rng.integers(256)), int(rng.integers(256)), _u(256, 35, dtype=np.uint8), _f(35), _f(35), _f(35),
                  _f(35), _f(35), _u(2**32, 35), _u(2**32, 4))


def random_state() -> LowState:
    return LowState(_u(2**32, 2), int(rng.integers(256)), int(rng.integers(256)), int(rng.integers(2**32)), _f(4),
                    _f(3), _f(3), _f(3), int(rng.integers(-30000, 30000)), _u(256, 35, dtype=np.uint8), _f(35), _f(35),
                    _f(35), _f(35), rng.integers(-300, 300, (35, 2)).astype(np.int16), _f(35), _u(2**32, 35, 2),
                    _u(2**32, 35), _u(2**32, 35, 4), _u(256, 40, dtype=np.uint8), _u(2**32, 4))


@pytest.mark.parametrize("i", range(5))
def test_lowcmd_bytes_and_crc_are_the_sdks(i):
    from unitree_sdk2py.idl.unitree_hg.msg.dds_ import LowCmd_
    from unitree_sdk2py.utils.crc import CRC

    cmd = random_cmd()
    data = cmd.encode()
    msg = LowCmd_.deserialize(data)
    assert msg.serialize() == data  # byte for byte what cyclonedds writes for the SDK's type
    assert CRC().Crc(msg) == cmd.crc == msg.crc
    assert (msg.mode_pr, msg.mode_machine, msg.motor_cmd[0].mode) == (cmd.mode_pr, cmd.mode_machine, cmd.mode[0])
    back = LowCmd.decode(msg.serialize())
    for name in ("mode", "q", "dq", "tau", "kp", "kd", "reserve", "tail"):
        assert np.array_equal(getattr(back, name), getattr(cmd, name)), name
    assert cmd_crc_ok(data)


@pytest.mark.parametrize("i", range(5))
def test_lowstate_bytes_and_crc_are_the_sdks(i):
    from unitree_sdk2py.idl.unitree_hg.msg.dds_ import LowState_
    from unitree_sdk2py.utils.crc import CRC

    st = random_state()
    data = st.encode()
    msg = LowState_.deserialize(data)
    assert msg.serialize() == data
    assert CRC().Crc(msg) == st.crc == msg.crc
    back = LowState.decode(data)
    assert back.imu_temperature == st.imu_temperature and back.tick == st.tick
    for name in ("quaternion", "mode", "q", "tau_est", "temperature", "sensor", "reserve", "wireless_remote"):
        assert np.array_equal(getattr(back, name), getattr(st, name)), name
    assert state_crc_ok(data)


def test_a_changed_byte_breaks_the_crc():
    data = bytearray(random_cmd().encode())
    data[4 + 28 * 3 + 4] ^= 0x01  # motor 3's q
    assert not cmd_crc_ok(bytes(data))
    assert not cmd_crc_ok(random_cmd().encode(fix_crc=False))


def test_the_python_crc_matches_the_sdks_compiled_one(monkeypatch):
    words = np.frombuffer(rng.bytes(2088), np.uint32)
    compiled = crc32_words(words)
    monkeypatch.setattr(wire, "_sdk_crc_core", lambda: None)
    assert crc32_words(words) == compiled


def test_malformed_samples_are_refused():
    with pytest.raises(ValueError, match="1004 bytes"):
        LowCmd.decode(b"\x00\x01\x00\x00" + bytes(10))
    with pytest.raises(ValueError, match="little-endian"):
        LowCmd.decode(b"\x00\x00\x00\x00" + bytes(1000))


def _commands(names, **kw):
    joints = lookup(names)
    return Commands(joints, [j.kp for j in joints], [j.kd for j in joints], [j.damping for j in joints],
                    np.array([j.lower for j in joints]), np.array([j.upper for j in joints]), **kw)


def test_damping_is_soft_everywhere_and_arm_sdk_carries_its_weight_in_slot_29():
    whole = _commands(joint_names(29))
    d = whole.damping(mode_machine=5)
    assert is_damping(d) and (d.kd[:29] > 0).all() and (d.mode[:29] == 1).all() and d.mode_machine == 5
    arms_names = joint_names(29, upper_body_only=True)
    arms = _commands(arms_names)
    q = np.array([j.lower + 0.1 for j in lookup(arms_names)])
    c = arms.position(q, q, mode_machine=5, weight=0.25)
    assert c.q[WEIGHT_SLOT] == np.float32(0.25) and (c.kp[:12] == 0).all() and (c.mode[:12] == 0).all()
    assert len(arms_names) == 17 and (c.kp[12:29] > 0).all()


def test_a_whole_body_command_damps_the_joints_the_node_does_not_drive():
    c = _commands(["left_elbow_joint"]).position(np.array([0.5]), np.array([0.5]), mode_machine=0)
    assert c.kp[18] > 0 and (np.delete(c.kp[:29], 18) == 0).all() and (c.kd[:29] > 0).all()


def test_goals_are_clipped_to_the_limits_and_to_the_torque_band_at_the_wire():
    cmds = _commands(["left_elbow_joint", "left_wrist_pitch_joint"])
    elbow, wrist = lookup(["left_elbow_joint", "left_wrist_pitch_joint"])
    q = cmds.wire_q(np.array([5.0, 0.5]), measured=np.array([elbow.upper - 0.01, 0.0]))
    assert q[0] == pytest.approx(elbow.upper)  # the limit
    assert q[1] == pytest.approx(wrist.effort / wrist.kp)  # 5 N·m at kp 20: 0.25 rad from where it is
    free = _commands(["left_wrist_pitch_joint"], torque_limit=False)
    assert free.wire_q(np.array([0.5]), np.array([0.0]))[0] == pytest.approx(0.5)


def test_the_23_dof_g1_has_no_waist_roll_pitch_nor_wrist_pitch_yaw():
    names = joint_names(23)
    assert len(names) == 23 and "waist_roll_joint" not in names and "left_wrist_pitch_joint" not in names
    assert [j.slot for j in lookup(names)][-5:] == [22, 23, 24, 25, 26]
    assert [j.slot for j in JOINTS] == list(range(29))
