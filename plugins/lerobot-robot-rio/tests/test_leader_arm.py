"""RioTeleoperator with a leader arm: RIO's leader-follower teleop (align, then mirror) under LeRobot's loop,
on rio-so100's emulated buses (the real Feetech driver code against emulated servos; a scripted hand waves
the leader)."""

import pytest

pytest.importorskip("lerobot")
pytest.importorskip("lerobot_robot_rio")
pytest.importorskip("rio_so100")

import time  # noqa: E402

import numpy as np  # noqa: E402
from lerobot_robot_rio import RioRobot, RioRobotConfig, RioTeleoperator, RioTeleoperatorConfig  # noqa: E402


def test_follower_mirrors_its_leader(tmp_path):
    robot = RioRobot(RioRobotConfig(station="so100-emulator", calibration_dir=tmp_path))
    teleop = RioTeleoperator(RioTeleoperatorConfig(station="so100-emulator", calibration_dir=tmp_path))
    assert teleop.rio.leader and teleop.action_features == robot.action_features
    joints = list(robot.action_features)[:5]
    teleop.connect()
    robot.connect()
    try:
        for _ in range(200):  # 4 s of LeRobot's loop at the station's 50 Hz
            robot.send_action(teleop.get_action())
            time.sleep(1 / 50)
        pair = teleop.rio.controller.pairs[0]
        assert pair.aligned, "the follower never caught up with its leader"
        lead = np.asarray(pair.leader.get_state()["joint_pos"])
        follow = np.array([robot.get_observation()[j] for j in joints])
        np.testing.assert_allclose(follow, lead, atol=0.1)  # mirroring a waving leader, a cycle or two behind
    finally:
        teleop.disconnect()
        robot.disconnect()
