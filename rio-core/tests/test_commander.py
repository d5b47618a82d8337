"""The commanders every driver kind feeds its hardware through: interpolation, joint limits or workspace,
maximum step per cycle, stale-command watchdog."""

from __future__ import annotations

import numpy as np
import pytest

from rio.control.commander import JointCommander, PoseCommander
from rio.control.rotations import quat_angle, rotvec_to_quat


def _cmd(max_step=0.1, watchdog=0.5):
    c = JointCommander([-1.0, -1.0], [1.0, 1.0], max_step, watchdog)
    c.reset([0.0, 0.0], t=0.0)
    return c


def test_interpolates_towards_a_timed_target():
    c = _cmd(max_step=10.0)
    c.command([0.4, -0.4], t_target=1.0, now=0.0)
    assert np.allclose(c.step(0.25), [0.1, -0.1])
    assert np.allclose(c.step(0.5), [0.2, -0.2])
    assert np.allclose(c.step(1.1), [0.4, -0.4])


def test_targets_are_clipped_to_the_joint_limits():
    c = _cmd(max_step=10.0)
    c.command([5.0, -5.0], t_target=0.0, now=0.0)
    assert np.allclose(c.step(0.01), [1.0, -1.0])


def test_a_jump_becomes_bounded_steps():
    c = _cmd(max_step=0.1)
    c.command([0.35, 0.0], t_target=0.0, now=0.0)
    goals = [c.step(0.01 * (k + 1))[0] for k in range(5)]
    assert np.allclose(goals, [0.1, 0.2, 0.3, 0.35, 0.35])


def test_a_goal_held_back_by_the_step_takes_up_where_a_coasting_arm_already_is():
    """A velocity-commanded base went on through a late cycle: the goal starts from the arm where the arm is
    between the goal and where the move is now, never backwards, never past the move, and is still at most
    max_step from it after the step."""
    c = _cmd(max_step=0.1)
    c.command([0.8, -0.8], t_target=0.8, now=0.0)
    c.step(0.1)  # on time: [0.1, -0.1]
    c.follow_measured([0.35, -0.05], now=0.5)  # 0.4 s late; joint 1 went on, joint 2 lagged behind the goal
    assert np.allclose(c.goal, [0.35, -0.1])
    assert np.allclose(c.step(0.5), [0.45, -0.2])
    c.follow_measured([0.9, 0.3], now=0.6)  # past the move (now at 0.6) and the wrong way: neither counts
    assert np.allclose(c.goal, [0.6, -0.2])
    c.hold(0.6)
    c.follow_measured([0.7, -0.7], now=0.7)  # holding: the goal stays
    assert np.allclose(c.goal, [0.6, -0.2])


def test_watchdog_holds_a_move_whose_commands_stopped():
    c = _cmd(max_step=10.0, watchdog=0.2)
    c.command([0.0, 0.0], t_target=0.0, now=-0.1)  # a controller streaming commands ...
    c.command([1.0, 0.0], t_target=2.0, now=0.0)  # ... sends a target far ahead, then goes quiet
    assert c.step(0.1)[0] == 0.05 and not c.holding
    held = c.step(0.3)[0]  # 0.3 s without a command: stop where the goal is
    assert c.holding and held == 0.05
    assert c.step(1.0)[0] == held and c.step(3.0)[0] == held
    c.command([0.0, 0.0], t_target=3.0, now=3.0)  # a fresh command takes over again
    assert not c.holding and c.step(3.01)[0] == 0.0


def test_a_single_deliberate_move_runs_to_its_end():
    """One command with a far target (home over 2 s, a script's move) is not a stalled stream."""
    c = _cmd(max_step=10.0, watchdog=0.2)
    c.command([1.0, 0.0], t_target=2.0, now=0.0)
    assert c.step(1.0)[0] == pytest.approx(0.5) and not c.holding
    assert c.step(2.5)[0] == pytest.approx(1.0) and c.holding  # arrived; nothing fresh is followed


def test_a_finished_move_is_not_cut_short_by_the_watchdog():
    c = _cmd(max_step=10.0, watchdog=0.5)
    c.command([0.5, 0.0], t_target=0.49, now=0.0)
    for t in np.arange(0.01, 1.0, 0.01):
        c.step(t)
    assert c.holding and c.goal[0] == 0.5


def test_limits_must_be_ordered():
    with pytest.raises(ValueError, match="lower <= upper"):
        JointCommander([1.0], [-1.0], 0.1, 0.5)


def test_a_target_of_the_wrong_size_is_refused():
    with pytest.raises(ValueError, match="3 values"):
        _cmd().command([0.0, 0.0, 0.0], 1.0, 0.0)


def _pose_cmd(max_m=0.01, max_rad=0.05, watchdog=0.5):
    c = PoseCommander([-0.5, -0.5, 0.0], [0.5, 0.5, 0.5], max_m, max_rad, watchdog)
    c.reset([0.1, 0.0, 0.2, 1.0, 0.0, 0.0, 0.0], t=0.0)
    return c


def test_pose_targets_are_clipped_to_the_workspace_and_step_limited():
    c = _pose_cmd(max_m=0.01)
    c.command([0.1, 0.0, -1.0, 1.0, 0.0, 0.0, 0.0], t_target=0.0, now=0.0)  # below the table
    zs = [c.step(0.01 * (k + 1))[2] for k in range(30)]
    assert np.allclose(np.diff(zs[:20]), -0.01)  # 1 cm per cycle, never a jump
    assert zs[-1] == pytest.approx(0.0)          # stops at the workspace floor


def test_a_pose_goal_takes_up_where_a_coasting_tool_already_is_in_position_only():
    """A base streaming twists went on through a late cycle: the position takes up from the tool, as joints do;
    the orientation stays the goal's, even when the tool reports its orientation as the other sign of the
    same quaternion (a per-element clamp would then make up a rotation)."""
    c = _pose_cmd(max_m=0.05, max_rad=0.05)
    turned = rotvec_to_quat([0.0, 0.0, 0.4])
    c.command([0.5, 0.0, 0.2, *turned], t_target=0.4, now=0.0)
    goal = c.step(0.1).copy()  # on time: 5 cm along x, 0.05 rad about z
    c.follow_measured([0.25, 0.01, 0.2, *(-rotvec_to_quat([0.0, 0.0, 0.2]))], now=0.3)  # 0.2 s late
    assert np.allclose(c.goal[:3], [0.25, 0.0, 0.2])  # along x as far as the tool went; y, not on the way: goal's
    assert quat_angle(c.goal[3:], goal[3:]) < 1e-9 and np.allclose(c.goal[3:], goal[3:])
    c.follow_measured([0.9, 0.0, 0.2, *goal[3:]], now=0.35)  # past where the move is now: up to there only
    assert c.goal[0] == pytest.approx(0.45, abs=1e-9)  # 0.1 m + 0.4 m * 0.35 s / 0.4 s


def test_pose_rotation_moves_along_the_slerp_arc_at_bounded_speed():
    c = _pose_cmd(max_rad=0.05)
    target = rotvec_to_quat([0.0, 0.0, 1.0])  # 1 rad about z
    c.command([0.1, 0.0, 0.2, *target], t_target=0.0, now=0.0)
    q0 = c.goal[3:].copy()
    q1 = c.step(0.01)[3:]
    assert quat_angle(q0, q1) == pytest.approx(0.05, abs=1e-6)
    for k in range(30):
        c.step(0.02 + 0.01 * k)
    assert quat_angle(c.goal[3:], target) < 1e-6
    assert np.allclose(c.goal[:3], [0.1, 0.0, 0.2])


def test_pose_watchdog_holds_a_move_whose_commands_stopped():
    c = _pose_cmd(max_m=1.0, watchdog=0.2)
    c.command([0.1, 0.0, 0.2, 1.0, 0.0, 0.0, 0.0], t_target=0.0, now=-0.05)
    c.command([0.3, 0.0, 0.2, 1.0, 0.0, 0.0, 0.0], t_target=2.0, now=0.0)
    c.step(0.1)
    held = c.step(0.3)[0]
    assert c.holding and c.step(1.5)[0] == held and held < 0.12


def test_watchdog_holds_a_silent_stream_still_stepping_towards_a_far_target():
    """Targets due now but far away (`move_joints(q)` without a time) are reached through the step
    limit over many cycles: a stream that goes silent meanwhile is held too, not finished."""
    c = _cmd(max_step=0.01, watchdog=0.3)
    c.command([0.0, 0.0], t_target=0.0, now=0.0)
    c.command([1.0, 0.0], t_target=0.05, now=0.05)
    for k in range(1, 20):
        c.step(0.05 + 0.01 * k)  # 0.19 rad by t = 0.24, still moving
    assert not c.holding
    held = c.step(0.36)[0]  # 0.31 s without a command
    assert c.holding and held < 0.25
    assert c.step(1.0)[0] == held


@pytest.mark.parametrize("node_hz", [10.0, 20.0, 30.0, 100.0])
def test_a_command_stream_faster_than_the_cycle_does_not_slow_the_motion(node_hz):
    """A 30 Hz stream of targets moving at 0.1 /s, each due one stream period ahead, into a node that
    cycles at `node_hz` and steps right after taking the latest command (the worst phase): the goal
    follows the stream, instead of restarting each move from a goal that has barely moved."""
    c = _cmd(max_step=10.0, watchdog=1.0)
    stream_dt, speed = 1 / 30, 0.1
    t_cmds = np.arange(0.0, 2.0, stream_dt)
    goal = None
    for t_step in np.arange(0.0, 2.0, 1 / node_hz):
        taken = t_cmds[t_cmds <= t_step]
        for t in taken[-3:]:  # the commands that arrived since the last cycle, oldest first
            if t > t_step - 1 / node_hz:
                c.command([speed * (t + stream_dt), 0.0], t_target=t + stream_dt, now=t_step)
        goal = c.step(t_step)
    expected = speed * 2.0
    assert goal[0] > expected - speed * (2 / node_hz + 2 * stream_dt)  # behind by about a cycle, no more


def _stream_then_stop(c, until=1.0, dt=1 / 30):
    """A control loop's stream: a target one period ahead every period, then the loop ends."""
    t = 0.0
    while t < until:
        c.command([0.1 * t, 0.0], t_target=t + 1.5 * dt, now=t)
        c.step(t + 0.001)
        t += dt
    return t


def test_home_right_after_a_stream_runs_to_its_end():
    """The bug: home(seconds=3) sent 0.2 s after a loop's last command was taken for that stream's far target
    and frozen half-way when the watchdog fired. A declared single move (`move`) runs to its end."""
    for single in (False, True):
        c = _cmd(max_step=10.0, watchdog=0.5)
        t = _stream_then_stop(c) + 0.2
        (c.move if single else c.command)([0.8, 0.5], t_target=t + 3.0, now=t)
        for k in range(1, 400):
            c.step(t + 0.01 * k)
        if single:
            assert np.allclose(c.goal, [0.8, 0.5]) and c.holding
        else:  # what a streamed command still gets: held where the watchdog found it
            assert c.goal[1] < 0.2 and c.holding


def test_a_stream_after_a_single_move_is_still_watched():
    """A single move does not turn the watchdog off: the stream that follows it is held when it goes quiet."""
    c = _cmd(max_step=10.0, watchdog=0.2)
    c.move([0.0, 0.0], t_target=0.1, now=0.0)
    c.command([0.0, 0.0], t_target=0.2, now=0.15)
    c.command([1.0, 0.0], t_target=2.0, now=0.2)
    c.step(0.3)
    held = c.step(0.5)[0]
    assert c.holding and held < 0.1 and c.step(2.5)[0] == held


def test_a_stream_that_ended_unannounced_is_a_warning_and_an_announced_end_is_quiet(caplog):
    """A stream that goes silent is a warning even when its last move is over (a pulled cable mid-run looks
    exactly like that at the node); a control loop's end is announced with hold() and logs nothing."""
    c = _cmd(max_step=10.0, watchdog=0.5)
    t = _stream_then_stop(c)
    with caplog.at_level("DEBUG", logger="rio.control"):
        for k in range(1, 100):
            c.step(t + 0.01 * k)
    assert c.holding and c.watchdog_holds == 1
    assert [r.levelname for r in caplog.records] == ["WARNING"] and "at its last target" in caplog.text
    caplog.clear()
    c = _cmd(max_step=10.0, watchdog=0.5)
    t = _stream_then_stop(c)
    c.hold(t)  # the loop's end, announced
    with caplog.at_level("DEBUG", logger="rio.control"):
        for k in range(1, 100):
            c.step(t + 0.01 * k)
    assert c.holding and c.watchdog_holds == 0 and not caplog.records
    caplog.clear()
    c = _cmd(max_step=10.0, watchdog=0.2)
    c.command([0.0, 0.0], t_target=0.0, now=-0.1)
    c.command([1.0, 0.0], t_target=2.0, now=0.0)
    with caplog.at_level("DEBUG", logger="rio.control"):
        c.step(0.1)
        c.step(0.3)
    assert [r.levelname for r in caplog.records] == ["WARNING"] and "mid-move" in caplog.text
