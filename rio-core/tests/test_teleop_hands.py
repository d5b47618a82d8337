"""Hand-tracking teleop (`rio.teleop.hands`) end to end on the thread middleware: a scripted hand
tracker (`rio.fake_hand_tracker`, the contract a headset's node publishes) moves arms by its wrists'
motion, closes grippers with a pinch, freezes when a hand is lost, and drives a humanoid's wrists (by
IK on its model) and its dexterous hands (retargeted keypoints)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rio.control.rotations import quat_angle, quat_conj, quat_mul, quat_to_rotvec
from rio.fakes.hands import five_finger_hand_joints
from rio.testing import fake_eef_station, skip_tests_without
from rio.workflows.teleop import run_teleop

skip_tests_without("mink")  # found, not imported: its import costs every test process 0.5 s

HEAD = """
name = "hands-test"
rate_hz = 50
[middleware]
name = "thread"
"""
def station(tmp_path: Path, body: str, tracker: str) -> str:
    path = tmp_path / "hands.toml"
    path.write_text(HEAD + body + "\n[components.teleop]\ndriver = \"rio.fake_hand_tracker\"\n" + tracker)
    return str(path)


def eef_station(tmp_path: Path, tracker: str) -> str:
    """A fake arm in end-effector space with a gripper, driven by the scripted hand tracker."""
    path = tmp_path / "hands-eef.toml"
    path.write_text(fake_eef_station("hands-eef", 'driver = "rio.fake_hand_tracker"\n' + tracker))
    return str(path)


def run(path: str, seconds: float, **kw):
    ticks = []
    summary = run_teleop(path, duration=seconds, on_tick=ticks.append, log=None, **kw)
    return summary, ticks


def test_a_wrist_moves_the_tool_by_its_motion_and_a_pinch_closes_the_gripper(tmp_path):
    path = eef_station(tmp_path, "move = [0.06, 0.03, -0.04]\nturn_deg = 30\npinch_after_s = 1.0\n"
                                      "seconds = 0.6\n")
    _, ticks = run(path, 2.5)
    first, last = ticks[0].step.observation, ticks[-1].step.observation
    start, end = first.proprio_eef, last.proprio_eef
    assert np.allclose(end[:3] - start[:3], [0.06, 0.03, -0.04], atol=3e-3)
    turn = quat_to_rotvec(quat_mul(end[3:], quat_conj(start[3:])))  # in the base frame: about z
    assert np.allclose(turn, [0, 0, np.deg2rad(30)], atol=np.deg2rad(2))
    assert first.gripper_width == pytest.approx(0.08, abs=1e-3)
    assert last.gripper_width < 0.01  # the pinch closed it


def test_translation_mode_keeps_the_tool_orientation(tmp_path):
    path = eef_station(tmp_path, "move = [0.05, 0, 0]\nturn_deg = 40\nseconds = 0.5\n")
    _, ticks = run(path, 1.8, mode="translation")
    start, end = ticks[0].step.observation.proprio_eef, ticks[-1].step.observation.proprio_eef
    assert end[0] - start[0] == pytest.approx(0.05, abs=3e-3)
    assert quat_angle(end[3:], start[3:]) < np.deg2rad(1)


def test_a_lost_hand_freezes_the_tool_and_the_done_button_ends_the_run(tmp_path):
    """The hand moves 0.1 m over 1 s but is lost after 0.5 s of it: the tool stops near half-way and
    stays there, though the (untracked) wrist goes on."""
    path = eef_station(tmp_path, "move = [0.1, 0, 0]\nseconds = 1.0\nlose_after_s = 1.1\ndone_after_s = 2.5\n"
                                      "buttons = 2\n")
    summary, ticks = run(path, 10.0)
    assert summary.reason == "the device finished" and summary.seconds < 8
    dx = ticks[-1].step.observation.proprio_eef[0] - ticks[0].step.observation.proprio_eef[0]
    assert 0.02 < dx < 0.07


def test_two_arms_follow_the_hand_of_their_side(tmp_path):
    body = """
[embodiment]
action_space = "eef_pose"
[components.arm]
driver = "rio.fake_arm"
[components.arm2]
driver = "rio.fake_arm"
"""
    path = station(tmp_path, body, "hands = \"left\"\nmove = [0, 0, 0.05]\nseconds = 0.5\n")
    _, ticks = run(path, 1.8)
    a, b = ticks[0].step.observation, ticks[-1].step.observation
    assert b.arm1_proprio_eef[2] - a.arm1_proprio_eef[2] == pytest.approx(0.05, abs=3e-3)  # left hand: left arm
    assert np.allclose(b.arm2_proprio_eef[:3], a.arm2_proprio_eef[:3], atol=1e-6)  # right hand untracked


def test_a_humanoid_follows_with_its_wrists_and_curls_its_fingers(tmp_path):
    from rio.fakes.humanoid import upper_body_description, upper_body_joints
    from rio.kinematics import MultiFrameIK

    body = """
[components.humanoid]
driver = "rio.fake_model_humanoid"
[components.hand]
driver = "rio.fake_model_hand"
side = "left"
[components.hand2]
driver = "rio.fake_model_hand"
"""
    path = station(tmp_path, body, "hands = \"both\"\nmove = [0.05, 0, 0.05]\ncurl = 1.0\nseconds = 0.6\n")
    _, ticks = run(path, 2.5)
    first, last = ticks[0].step.observation, ticks[-1].step.observation
    ik = MultiFrameIK(upper_body_description())
    for frame in ("left", "right"):
        d = ik.fk(last.joint_pos, frame)[:3] - ik.fk(first.joint_pos, frame)[:3]
        assert np.allclose(d, [0.05, 0.0, 0.05], atol=5e-3), frame
    moved = np.abs(last.joint_pos - first.joint_pos) > 1e-6
    names = upper_body_joints()
    assert not any(moved[i] for i, n in enumerate(names) if "leg" in n or "knee" in n or "hip" in n)
    flex = [i for i, n in enumerate(five_finger_hand_joints()) if n.endswith(("_mcp", "_pip")) and "thumb" not in n]
    for hand in (last.hand1_joints, last.hand2_joints):  # a fist: every finger flexed at its knuckles
        assert hand[flex].min() > 0.6
    assert np.abs(first.hand1_joints).max() < 0.3


def test_an_arm_in_joint_space_follows_by_ik_and_its_dexterous_hand_curls(tmp_path):
    body = """
[components.arm]
driver = "rio.fake_model_arm"
home = [0.0, 0.5, 1.2, 0.0, 1.4, 0.0]
[components.hand]
driver = "rio.fake_model_hand"
"""
    path = station(tmp_path, body, "move = [0.0, 0.04, 0.03]\ncurl = 1.0\nseconds = 0.6\n")
    _, ticks = run(path, 2.5)
    first, last = ticks[0].step.observation, ticks[-1].step.observation
    assert np.allclose(last.proprio_eef[:3] - first.proprio_eef[:3], [0.0, 0.04, 0.03], atol=4e-3)
    flex = [i for i, n in enumerate(five_finger_hand_joints()) if n.endswith("_pip") and "thumb" not in n]
    assert np.asarray(last.hand_joints)[flex].min() > 0.6


def test_a_twist_device_drives_a_humanoids_wrists(tmp_path):
    """The twist teleop (keyboard, SpaceMouse, scripted) on a humanoid: its wrists stand for two arms,
    solved together by IK; one device moves both, the legs stay."""
    from rio.fakes.humanoid import upper_body_description, upper_body_joints
    from rio.kinematics import MultiFrameIK

    path = tmp_path / "twist-humanoid.toml"
    path.write_text(HEAD + '[components.humanoid]\ndriver = "rio.fake_model_humanoid"\n'
                    '[components.teleop]\ndriver = "rio.fake_teleop"\ntwist = [0.0, 0.0, 0.03, 0, 0, 0]\n')
    ticks: list = []
    run_teleop(str(path), duration=1.5, on_tick=ticks.append, log=None, filter_hz=None)
    first, last = ticks[0].step.observation, ticks[-1].step.observation
    ik = MultiFrameIK(upper_body_description())
    for frame in ("left", "right"):
        dz = ik.fk(last.joint_pos, frame)[2] - ik.fk(first.joint_pos, frame)[2]
        assert 0.025 < dz < 0.065, frame  # 0.03 m/s for the 1.5 s run (give or take its first and last cycles)
    legs = [i for i, n in enumerate(upper_body_joints()) if "hip" in n or "knee" in n]
    assert np.array_equal(last.joint_pos[legs], first.joint_pos[legs])
