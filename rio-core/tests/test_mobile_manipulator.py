"""The MobileManipulator embodiment on a station of fakes (`rio.fake_arm`, `rio.fake_gripper`,
`rio.fake_base`): the recorded observation schema, teleop's mode key switching the device's axes between
the arm and the base, and a recorded run replayed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rio import ServerManager
from rio.control.teleop import ARM_MODES, ModeSwitch, TeleopMode, base_twist
from rio.recording.dataset import Dataset
from rio.schema import MobileManipulatorObs
from rio.station import make_station
from rio.testing import fake_eef_station
from rio.workflows.replay import replay_episode
from rio.workflows.teleop import run_teleop

BASE = '[components.base]\ndriver = "rio.fake_base"\nmax_linear_speed = 0.3\n'
#: a device held at 0.1 m/s forward and 0.3 rad/s of yaw
DEVICE = 'driver = "rio.fake_teleop"\nbuttons = 2\ntwist = [0.1, 0.0, 0.0, 0.0, 0.0, 0.3]'


@pytest.fixture
def station(tmp_path: Path) -> Path:
    path = tmp_path / "mobile.toml"
    path.write_text(fake_eef_station("mobile-test", DEVICE) + BASE)
    return path


def test_roles_make_a_mobile_manipulator_with_the_base_in_its_action(station):
    servers, _, env = make_station(str(station))
    with ServerManager(servers), env:
        robot = env.robot
        assert robot.name == "mobile_manipulator"
        assert [label for label, _ in robot.action_parts()] == ["eef_pose", "gripper", "base_twist"]
        step = env.reset()
        obs = step.observation
        assert isinstance(obs, MobileManipulatorObs)
        assert obs.proprio.shape == (7 + 1 + 3,) and np.array_equal(obs.proprio[-3:], obs.base_twist)
        assert obs.base_odom.shape == (3,) and obs.base_wheel_pos.shape == (3,)


def test_mode_switch_reaches_base_only_where_there_is_one():
    s = ModeSwitch(TeleopMode.ROTATION, debounce_s=0.0, modes=tuple(TeleopMode))
    assert s.update(True, 1.0) == TeleopMode.BASE and s.update(True, 2.0) == TeleopMode.TRANSLATION
    s = ModeSwitch(TeleopMode.ROTATION, debounce_s=0.0)
    assert s.modes == ARM_MODES and s.update(True, 1.0) == TeleopMode.TRANSLATION
    tw = np.array([0.5, -0.1, 0.3, 0.2, 0.1, 2.0])
    assert np.allclose(base_twist(tw, TeleopMode.BASE, 0.2, 1.0), [0.2 * 0.5 / np.hypot(0.5, 0.1),
                                                                   -0.2 * 0.1 / np.hypot(0.5, 0.1), 1.0])
    assert not base_twist(tw, TeleopMode.TRANSLATION, 0.2, 1.0).any()


def _odom(ep) -> np.ndarray:
    return ep.column("obs.base_odom")


def test_teleop_in_base_mode_drives_the_base_and_records_it(station, tmp_path):
    root = tmp_path / "data"
    s = run_teleop(str(station), mode="base", duration=1.5, record=str(root), log=None)
    assert s.details["mode"] == "base"
    ep = Dataset(root).episode(0)
    odom, tool = _odom(ep), ep.column("obs.proprio_eef")
    assert ep.meta["embodiment"] == "mobile_manipulator"
    # about 1.3 s at 0.1 m/s after the ramp: forward, turning left; the tool held still
    assert 0.08 < odom[-1, 0] < 0.16 and 0.2 < odom[-1, 2] < 0.5, odom[-1]
    assert np.abs(tool[-1, :3] - tool[0, :3]).max() < 1e-6
    twist = ep.column("obs.base_twist")
    assert np.allclose(twist[-1], [0.1, 0.0, 0.3], atol=1e-6)
    actions = ep.column("action")
    assert np.allclose(actions[-1, -3:], [0.1, 0.0, 0.3], atol=1e-6)

    # the recorded actions drive the base again on replay: it ends about where it ended
    seen = []
    replay_episode(str(root), 0, str(station), log=None,
                   on_tick=lambda tick: seen.append(np.asarray(tick.step.observation.base_odom)))
    assert np.allclose(seen[-1][:2] - seen[0][:2], odom[-1, :2] - odom[0, :2], atol=0.03), (seen[-1], odom[-1])


def test_teleop_in_an_arm_mode_keeps_the_base_still(station):
    seen = []
    run_teleop(str(station), mode="translation", duration=1.0, log=None,
               on_tick=lambda tick: seen.append(tick.step.observation))
    first, last = seen[0], seen[-1]
    assert np.abs(last.base_odom).max() < 1e-9 and not last.base_twist.any()
    assert last.proprio_eef[0] - first.proprio_eef[0] > 0.05  # the tool moved forward instead
