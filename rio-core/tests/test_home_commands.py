"""Homing on a fake arm (thread middleware, fast): `--home` before a teleop run, the warning when end-effector
teleop starts far from home, rest poses, and when the command line asks before moving a robot."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
import typer

from rio.cli.home_cmd import confirm_homing
from rio.station.load import load_station
from rio.testing import fake_eef_station
from rio.workflows.home import HOME_SPEED, HOME_TOL, is_stand_in, run_home
from rio.workflows.teleop import run_teleop

HOME = [0.6, -0.4, 0.0, 0.0, 0.0, 0.0]


@pytest.fixture
def station(tmp_path):
    text = fake_eef_station("home-test", 'driver = "rio.fake_teleop"', gripper=False)
    text = text.replace('dof = 6\n', f'dof = 6\nhome = {HOME}\nstart = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]\n')
    path = tmp_path / "home.toml"
    path.write_text(text)
    return path


def test_teleop_far_from_home_is_warned_about_and_home_first_silences_it(station):
    s = run_teleop(str(station), duration=0.5, log=None)
    assert any("0.60 rad from its home pose (joint 0)" in w for w in s.warnings), s.warnings
    s = run_teleop(str(station), duration=0.5, log=None, home_speed=2.0)
    assert not any("home pose" in w for w in s.warnings), s.warnings


def test_rio_home_on_a_fake_arm_and_a_rest_pose_it_does_not_declare(station):
    result = run_home(str(station), speed=2.0, log=None)
    assert result.arrived and result.error_rad["arm"] <= HOME_TOL
    assert result.seconds["arm"] == pytest.approx(0.6 / 2.0, rel=0.05)  # the farthest joint at 2 rad/s
    rest = run_home(str(station), speed=2.0, rest=True, log=None)
    assert rest.skipped == ["arm"] and "arm: declares no rest pose; left where it is" in rest.lines()


def test_only_real_hardware_is_asked_about(station, monkeypatch):
    assert is_stand_in(load_station(str(station)))
    real = SimpleNamespace(name="lab", components={"arm": SimpleNamespace(driver="ufactory.xarm7"),
                                                   "gripper": SimpleNamespace(driver="ufactory.gripper")})
    assert not is_stand_in(real)
    assert confirm_homing(load_station(str(station)), 0.2, yes=False) == 0.2  # a stand-in: no question
    assert confirm_homing(real, 0.2, yes=True) == 0.2
    monkeypatch.setattr("sys.stdin.isatty", lambda: False)
    with pytest.raises(typer.BadParameter, match="pass --yes"):
        confirm_homing(real, HOME_SPEED, yes=False)
