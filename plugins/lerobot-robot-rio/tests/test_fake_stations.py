"""Feature naming, teleop and errors on stations of RIO's in-process fake devices (fast, no simulator)."""

import pytest

pytest.importorskip("lerobot")
pytest.importorskip("lerobot_robot_rio")

import time  # noqa: E402

import numpy as np  # noqa: E402
from lerobot_robot_rio import RioRobot, RioRobotConfig, RioTeleoperator, RioTeleoperatorConfig  # noqa: E402

from rio.testing import wait_until  # noqa: E402

EEF = ["x", "y", "z", "qw", "qx", "qy", "qz"]


def station(tmp_path, name: str, body: str) -> str:
    path = tmp_path / f"{name}.toml"
    path.write_text(f'name = "{name}"\nrate_hz = 30\n' + body)
    return str(path)


def robot_of(tmp_path, path: str, **kw) -> RioRobot:
    return RioRobot(RioRobotConfig(station=path, calibration_dir=tmp_path / "calib", **kw))


BIMANUAL_EEF = """
[embodiment]
action_space = "eef_pose"
[components.arm]
driver = "rio.fake_arm"
dof = 3
[components.arm2]
driver = "rio.fake_arm"
dof = 3
[components.gripper]
driver = "rio.fake_gripper"
[components.gripper2]
driver = "rio.fake_gripper"
[components.top_camera]
driver = "rio.fake_camera"
"""


def test_bimanual_end_effector_station(tmp_path):
    robot = robot_of(tmp_path, station(tmp_path, "lr-bimanual", BIMANUAL_EEF))
    names = [f"arm{i}_{n}" for i in (1, 2) for n in [*(f"eef.{c}" for c in EEF), "gripper.pos"]]
    assert list(robot.action_features) == names
    assert robot.observation_features == {**dict.fromkeys(names, float), "top": (48, 64, 3)}
    robot.connect()
    try:
        obs = robot.get_observation()
        proprio = robot.rio.env.get_state().observation.proprio
        np.testing.assert_allclose([obs[n] for n in names], proprio, atol=1e-9)
        assert obs["top"].shape == (48, 64, 3) and obs["top"].dtype == np.uint8
        target = {n: obs[n] for n in names}
        target["arm2_eef.x"] += 0.1
        arm2 = robot.rio.env.robot.arm2

        def moved() -> bool:
            robot.send_action(target)
            time.sleep(1 / 30)
            return abs(float(arm2.get_state()["eef_pose"][0]) - target["arm2_eef.x"]) < 1e-3

        assert wait_until(moved, timeout=10.0)
        assert robot.get_observation()["arm2_eef.x"] == pytest.approx(target["arm2_eef.x"], abs=1e-3)
    finally:
        robot.disconnect()


def test_names_that_collide_are_qualified_by_their_action_part(tmp_path):
    body = """
[components.arm]
driver = "rio.fake_arm"
dof = 2
[components.hand]
driver = "rio.fake_hand"
dof = 2
"""
    robot = robot_of(tmp_path, station(tmp_path, "lr-hand", body))
    assert list(robot.action_features) == ["joint_pos.joint1.pos", "joint_pos.joint2.pos", "hand.joint1.pos",
                                           "hand.joint2.pos"]


TWIST = """
[embodiment]
action_space = "eef_pose"
[components.arm]
driver = "rio.fake_arm"
dof = 3
[components.gripper]
driver = "rio.fake_gripper"
[components.teleop]
driver = "rio.fake_teleop"
twist = [0.05, 0.0, 0.0, 0.0, 0.0, 0.0]
gripper = 0.0
"""


def test_teleoperator_drives_the_robot_of_its_station(tmp_path):
    path = station(tmp_path, "lr-twist", TWIST)
    robot = robot_of(tmp_path, path)
    teleop = RioTeleoperator(RioTeleoperatorConfig(station=path, calibration_dir=tmp_path / "calib"))
    assert teleop.action_features == robot.action_features
    assert teleop.feedback_features == {}
    teleop.connect()  # lerobot-teleoperate connects the teleoperator first
    try:
        with pytest.raises(ValueError, match="no connected rio robot of station 'lr-twist'"):
            teleop.get_action()
        robot.connect()
        try:
            x0 = robot.get_observation()["eef.x"]
            for _ in range(30):  # one second of LeRobot's loop
                action = teleop.get_action()
                assert set(action) == set(robot.action_features)
                robot.send_action(action)
                time.sleep(1 / 30)
            # the device's twist (0.05 m/s along x), low-pass filtered and integrated by RIO's teleop
            assert 0.02 < action["eef.x"] - x0 < 0.06
            assert action["gripper.pos"] == 0.0  # the device says closed
            assert wait_until(lambda: robot.get_observation()["eef.x"] - x0 > 0.02, timeout=3.0)
        finally:
            robot.disconnect()
    finally:
        teleop.disconnect()


def test_errors_name_the_station_and_field(tmp_path):
    with pytest.raises(ValueError, match="no station given: set --robot.station="):
        robot_of(tmp_path, "")
    with pytest.raises(ValueError, match="unknown station 'no-such-station'"):
        robot_of(tmp_path, "no-such-station")
    with pytest.raises(ValueError, match="station file not found"):
        robot_of(tmp_path, str(tmp_path / "missing.toml"))
    path = station(tmp_path, "lr-bimanual", BIMANUAL_EEF)
    with pytest.raises(ValueError, match="rate_hz must be > 0"):
        robot_of(tmp_path, path, rate_hz=-1.0)

    def teleop(**kw):
        return RioTeleoperator(RioTeleoperatorConfig(calibration_dir=tmp_path / "calib", **kw))

    with pytest.raises(ValueError, match="'lr-bimanual' has no teleop component: name a device with --teleop.device"):
        teleop(station=path)
    with pytest.raises(ValueError, match="unknown teleop mode 'sideways'"):
        teleop(station=path, device="scripted", mode="sideways")
    with pytest.raises(ValueError, match="components.teleop.driver: unknown teleop driver 'nosuch'"):
        teleop(station=path, device="nosuch")
