"""`JointCommander`: interpolation, joint limits, maximum step per cycle, stale-command watchdog."""

from __future__ import annotations

import numpy as np
from rio_so100.safety import JointCommander


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


def test_watchdog_holds_a_move_whose_commands_stopped():
    c = _cmd(max_step=10.0, watchdog=0.2)
    c.command([1.0, 0.0], t_target=2.0, now=0.0)  # a long move, then the controller goes quiet
    assert c.step(0.1)[0] == 0.05 and not c.holding
    held = c.step(0.3)[0]  # 0.3 s without a command: stop where the goal is
    assert c.holding and held == 0.05
    assert c.step(1.0)[0] == held and c.step(3.0)[0] == held
    c.command([0.0, 0.0], t_target=3.0, now=3.0)  # a fresh command takes over again
    assert not c.holding and c.step(3.01)[0] == 0.0


def test_a_finished_move_is_not_cut_short_by_the_watchdog():
    c = _cmd(max_step=10.0, watchdog=0.5)
    c.command([0.5, 0.0], t_target=0.49, now=0.0)
    for t in np.arange(0.01, 1.0, 0.01):
        c.step(t)
    assert c.holding and c.goal[0] == 0.5
