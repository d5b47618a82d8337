"""What stands between a command and the servos' goal registers, every driver cycle.

`JointCommander` turns timed joint targets into one goal per cycle:

- interpolation: a target to be reached at `t_cmd_target` is approached linearly from the goal in
  force when it arrived, so commands sent slower than the driver rate still give smooth motion;
- joint limits: every goal is clipped to the calibrated range;
- maximum step: a goal moves at most `max_step` (rad) per cycle, so a wild target (a policy glitch,
  a leader arm far from the follower) becomes a bounded-speed motion, never a jump;
- stale-command watchdog: commands must keep coming. When none has arrived for `watchdog_s` while a
  move is still under way (a target far ahead, then silence: a crashed or stalled controller), the
  goal stops where it is and the arm holds that position until the next command; `holding` says
  that no fresh command is being followed. A move that already ended simply stays at its target.
"""

from __future__ import annotations

import numpy as np


class JointCommander:
    def __init__(self, lower, upper, max_step: float, watchdog_s: float):
        self.lower = np.asarray(lower, dtype=np.float64)
        self.upper = np.asarray(upper, dtype=np.float64)
        self.max_step, self.watchdog_s = float(max_step), float(watchdog_s)
        n = self.lower.size
        self.goal = np.zeros(n)
        self._start, self._target = np.zeros(n), np.zeros(n)
        self._t0 = self._t1 = self._t_cmd = 0.0
        self.holding = True

    def clip(self, q) -> np.ndarray:
        return np.clip(np.asarray(q, dtype=np.float64), self.lower, self.upper)

    def reset(self, q_now, t: float) -> np.ndarray:
        """Hold `q_now` (the measured pose at start-up or after torque comes back)."""
        self.goal = self.clip(q_now)
        self._start, self._target = self.goal.copy(), self.goal.copy()
        self._t0 = self._t1 = self._t_cmd = t
        self.holding = True
        return self.goal.copy()

    def command(self, q, t_target: float, now: float) -> None:
        self._start, self._target = self.goal.copy(), self.clip(q)
        self._t0, self._t1, self._t_cmd = now, max(float(t_target), now), now
        self.holding = False

    def hold(self) -> None:
        """Stop where the goal is now (also what the watchdog does)."""
        self._start, self._target = self.goal.copy(), self.goal.copy()
        self._t1 = self._t0
        self.holding = True

    def step(self, now: float) -> np.ndarray:
        """The goal for this cycle."""
        stale = not self.holding and now - self._t_cmd > self.watchdog_s
        if stale and now < self._t1:
            self.hold()
        if now >= self._t1 or self._t1 <= self._t0:
            desired = self._target
        else:
            a = (now - self._t0) / (self._t1 - self._t0)
            desired = self._start + a * (self._target - self._start)
        delta = np.clip(desired - self.goal, -self.max_step, self.max_step)
        self.goal = self.clip(self.goal + delta)
        self.holding |= stale
        return self.goal.copy()
