"""The real SDK (`booster_robotics_sdk_python`) as far as it can be exercised without a robot: the names,
signatures and enums the driver relies on, the fake's surface matching them, and the `LowCmd` the driver
writes built with the SDK's own types. Skipped where the SDK has no wheel."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

sdk = pytest.importorskip("booster_robotics_sdk_python")

from rio_booster import emulator  # noqa: E402
from rio_booster.commands import Commands, from_low_cmd, to_low_cmd  # noqa: E402
from rio_booster.t1 import JOINTS, NUM_JOINTS, SDK_INDEX_NAMES, joint_names, lookup  # noqa: E402


def test_the_t1_table_is_the_sdks_joint_order():
    assert int(sdk.kJointCnt) == NUM_JOINTS == len(JOINTS)
    assert [int(getattr(sdk.JointIndex, n)) for n in SDK_INDEX_NAMES] == list(range(NUM_JOINTS))
    assert list(sdk.JointIndex.__members__) == list(SDK_INDEX_NAMES)


def test_modes_topics_and_command_types_are_what_the_driver_assumes():
    assert {m: int(getattr(sdk.RobotMode, m)) for m in ("kDamping", "kPrepare", "kWalking", "kCustom")} == \
        {"kDamping": 0, "kPrepare": 1, "kWalking": 2, "kCustom": 3}
    assert int(sdk.LowCmdType.SERIAL) == 1 and int(sdk.LowCmdType.PARALLEL) == 0
    assert sdk.kTopicLowState == "rt/low_state" and sdk.kTopicJointCtrl == "rt/joint_ctrl"
    assert emulator.SDK_TYPES and emulator.LowCmd is sdk.LowCmd and emulator.RobotMode is sdk.RobotMode


@pytest.mark.parametrize(("cls", "methods"), [
    ("ChannelFactory", ["Instance", "Init"]),
    ("B1LowStateSubscriber", ["InitChannel", "CloseChannel", "GetChannelName"]),
    ("B1LowCmdPublisher", ["InitChannel", "CloseChannel", "Write", "GetChannelName"]),
    ("B1LocoClient", ["Init", "ChangeMode", "GetMode"]),
])
def test_the_fake_offers_what_the_driver_calls_as_the_sdk_does(cls, methods):
    real, fake = getattr(sdk, cls), getattr(emulator, cls)
    for m in methods:
        assert hasattr(real, m) and hasattr(fake, m), (cls, m)
    if cls == "ChannelFactory":
        assert "domain_id" in real.Init.__doc__ and "network_interface" in real.Init.__doc__
        assert list(inspect.signature(fake.Init).parameters) == ["self", "domain_id", "network_interface"]


def test_the_low_state_fields_the_driver_reads_exist_and_are_read_only():
    state = sdk.LowState()
    assert hasattr(state, "motor_state_serial") and hasattr(state, "imu_state")
    imu = state.imu_state
    assert len(imu.rpy) == 3 and len(imu.gyro) == 3 and len(imu.acc) == 3
    m = sdk.MotorState()
    assert all(hasattr(m, f) for f in ("q", "dq", "ddq", "tau_est"))
    with pytest.raises(TypeError):
        m.q = 1.0  # why the emulator cannot publish the SDK's own LowState


def test_the_driver_writes_a_serial_low_cmd_of_the_sdks_types():
    joints = lookup(joint_names())
    cmds = Commands(joints, [j.kp for j in joints], [j.kd for j in joints], [j.damping for j in joints],
                    np.array([j.lower for j in joints]), np.array([j.upper for j in joints]))
    q = np.array([0.5 * (j.lower + j.upper) for j in joints])
    cmd = to_low_cmd(sdk, cmds.position(q, q))
    assert isinstance(cmd, sdk.LowCmd) and cmd.cmd_type == sdk.LowCmdType.SERIAL and cmd.motor_cmd_size() == 23
    assert all(isinstance(m, sdk.MotorCmd) and m.weight == 1.0 for m in cmd.motor_cmd)
    back, serial = from_low_cmd(cmd)
    assert serial and np.allclose(back.q, q, atol=1e-6) and np.allclose(back.kp, [j.kp for j in joints])
    damp, _ = from_low_cmd(to_low_cmd(sdk, cmds.damping()))
    assert damp.is_damping() and (damp.kd > 0).all()


def test_goals_are_clipped_to_the_limits_and_to_the_torque_band_at_the_wire():
    joints = lookup(["Left_Elbow_Pitch", "AAHead_yaw"])
    cmds = Commands(joints, [40.0, 10.0], [2.0, 0.5], [1.0, 0.5], np.array([j.lower for j in joints]),
                    np.array([j.upper for j in joints]))
    q = cmds.wire_q(np.array([5.0, 1.5]), measured=np.array([joints[0].upper - 0.01, 0.0]))
    assert q[0] == pytest.approx(joints[0].upper)  # the limit
    assert q[1] == pytest.approx(joints[1].effort / 10.0)  # 7 N·m at kp 10: 0.7 rad from where it is
