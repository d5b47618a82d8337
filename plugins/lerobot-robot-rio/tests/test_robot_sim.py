"""RioRobot on the simulated SO-100 station (rio-sim): features, observation, action, clean disconnect."""

import pytest

pytest.importorskip("lerobot")
pytest.importorskip("lerobot_robot_rio")
pytest.importorskip("rio_sim")

import os  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from lerobot.robots.utils import make_robot_from_config  # noqa: E402
from lerobot.utils.errors import DeviceNotConnectedError  # noqa: E402
from lerobot_robot_rio import RioRobot, RioRobotConfig  # noqa: E402
from rio_sim.session import SESSION_ENV  # noqa: E402

from rio.testing import wait_until  # noqa: E402

JOINTS = ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"]


def test_sim_so100_as_a_lerobot_robot(tmp_path, shm_entries):
    robot = make_robot_from_config(RioRobotConfig(station="sim-so100", calibration_dir=tmp_path / "calib"))
    assert isinstance(robot, RioRobot) and robot.name == "rio"
    names = [f"{j}.pos" for j in JOINTS] + ["gripper.pos"]
    # known before connecting: LeRobot builds the dataset's features first
    assert robot.action_features == dict.fromkeys(names, float)
    assert robot.observation_features == {**dict.fromkeys(names, float), "front": (240, 320, 3),
                                          "wrist": (240, 320, 3)}
    assert not robot.is_connected
    with pytest.raises(DeviceNotConnectedError):
        robot.get_observation()

    before = shm_entries()
    robot.connect()
    try:
        assert robot.is_connected
        sim_session = os.environ.get(SESSION_ENV, "")  # names this process tree's simulator blocks
        mine = tuple(f"rio_{r}_" for r in robot.rio.run_ids)
        started = {n for n in shm_entries() - before if n.startswith(mine) or (sim_session and sim_session in n)}
        assert any(n.startswith(mine) for n in started), "the station's nodes created no shared memory"

        rio = robot.rio.env.robot  # the station's embodiment: its arm and gripper clients
        obs = robot.get_observation()
        assert set(obs) == set(robot.observation_features)
        q = np.asarray(rio.arm.get_state()["joint_pos"])
        np.testing.assert_allclose([obs[n] for n in names[:5]], q, atol=1e-3)
        assert obs["gripper.pos"] == pytest.approx(float(rio.gripper.get_state()["width"]), abs=1e-3)
        for cam in ("front", "wrist"):
            assert obs[cam].shape == (240, 320, 3) and obs[cam].dtype == np.uint8

        target = {n: obs[n] for n in names}
        target["shoulder_pan.pos"] += 0.3
        target["gripper.pos"] = 0.02
        sent = robot.send_action(target)
        assert sent == pytest.approx(target)

        def arrived() -> bool:
            robot.send_action(target)  # a stream, as LeRobot's loop sends it (the watchdog holds a silent one)
            time.sleep(1 / 30)
            o = robot.get_observation()
            return abs(o["shoulder_pan.pos"] - target["shoulder_pan.pos"]) < 0.02 and \
                abs(o["gripper.pos"] - 0.02) < 0.005

        assert wait_until(arrived, timeout=15.0), robot.get_observation()
        assert float(rio.arm.get_state()["joint_pos"][0]) == pytest.approx(target["shoulder_pan.pos"], abs=0.02)

        # what is sent is what the nodes hold: clipped to the gripper's range and the joint limits
        wide = {**target, "gripper.pos": 5.0, "shoulder_pan.pos": 100.0}
        sent = robot.send_action(wide)
        assert sent["gripper.pos"] == pytest.approx(float(rio.gripper.max_width()))
        assert sent["shoulder_pan.pos"] == pytest.approx(float(rio.arm.joint_limits()[1][0]))
        robot.send_action(target)

        bad = dict(target)
        del bad["gripper.pos"]
        with pytest.raises(ValueError, match=r"rio station 'sim-so100': action lacks 'gripper.pos'"):
            robot.send_action(bad)
        with pytest.raises(ValueError, match=r"'elbow_flex.pos' is NaN or infinite; nothing was sent"):
            robot.send_action({**target, "elbow_flex.pos": float("nan")})
        with pytest.raises(ValueError, match=r"'wrist_roll.pos' must be one number"):
            robot.send_action({**target, "wrist_roll.pos": [1.0, 2.0]})
    finally:
        robot.disconnect()
    assert not robot.is_connected
    left = started & shm_entries()
    assert not left, f"left in /dev/shm after disconnect: {sorted(left)}"
    with pytest.raises(DeviceNotConnectedError):
        robot.send_action(target)
