"""Interpolators: turn sparse timed targets into a value at any time.

Commands reach a driver slower than it runs (a 30 Hz teleop loop, a 10 Hz policy) and each carries
the time it should be reached (`t_cmd_target`). A driver keeps one of these per controlled quantity
and samples it every tick, so the hardware sees a smooth ramp instead of a staircase.

- `LinearInterpolator`: from where the value is when a target arrives, straight to the target,
  arriving at its time (joints, gripper opening, any vector).
- `PoseInterpolator`: the same for 7-vector poses (line in position, slerp in orientation).
- `Waypoints`: piecewise-linear through several timed values (an action chunk), clamped at both ends.

Time is passed in explicitly (`rio.clock.now()` in drivers), which keeps them testable.
"""

from __future__ import annotations

import numpy as np

from rio.control.se3 import as_pose, pose_interp


class LinearInterpolator:
    """Element-wise: every element has its own start, goal and times, so one interpolator can carry
    values whose targets arrive separately (`set_target(..., where=mask)`: the sim world drives all
    actuators of a scene with one, each arm's commands arriving on their own)."""

    def __init__(self, value, t: float = 0.0):
        self.reset(value, t)

    def reset(self, value, t: float) -> None:
        """Hold `value` from time `t`."""
        self._x0 = np.array(value, dtype=np.float64)
        self._x1 = self._x0.copy()
        self._t0 = np.full(self._x0.shape, float(t))
        self._t1 = self._t0.copy()
        self._t_reset = float(t)

    @property
    def goal(self) -> np.ndarray:
        return self._x1.copy()

    @property
    def t_goal(self) -> float:
        """When the last element arrives."""
        return float(np.max(self._t1)) if self._t1.size else float(self._t_reset)

    def set_target(self, goal, t_target, t_now: float, where=None) -> None:
        """Start from the value at `t_now`; reach `goal` at `t_target` (at once if not in the future).
        With `where` (a boolean mask of the value's shape) only those elements get the new target; the
        others keep their move."""
        goal = np.array(goal, dtype=np.float64)
        if goal.shape != self._x0.shape:
            raise ValueError(f"target has shape {goal.shape}, interpolator holds {self._x0.shape}")
        start = self.sample(t_now)
        t1 = np.maximum(np.broadcast_to(np.asarray(t_target, dtype=np.float64), goal.shape), float(t_now))
        m = np.ones(goal.shape, bool) if where is None else np.broadcast_to(np.asarray(where, bool), goal.shape)
        self._x0 = np.where(m, start, self._x0)
        self._x1 = np.where(m, goal, self._x1)
        self._t0 = np.where(m, float(t_now), self._t0)
        self._t1 = np.where(m, t1, self._t1)

    def sample(self, t: float) -> np.ndarray:
        span = self._t1 - self._t0
        moving = span > 0
        a = np.where(moving, np.clip((float(t) - self._t0) / np.where(moving, span, 1.0), 0.0, 1.0), 1.0)
        return self._x0 + a * (self._x1 - self._x0)


class PoseInterpolator:
    def __init__(self, pose, t: float = 0.0):
        self._p0 = as_pose(pose)
        self._p1 = self._p0.copy()
        self._t0 = self._t1 = float(t)

    @property
    def goal(self) -> np.ndarray:
        return self._p1.copy()

    @property
    def t_goal(self) -> float:
        return self._t1

    def set_target(self, goal, t_target: float, t_now: float) -> None:
        self._p0, self._p1 = self.sample(t_now), as_pose(goal)
        self._t0, self._t1 = float(t_now), max(float(t_target), float(t_now))

    def sample(self, t: float) -> np.ndarray:
        span = self._t1 - self._t0
        a = 1.0 if span <= 0 else min(max((float(t) - self._t0) / span, 0.0), 1.0)
        return pose_interp(self._p0, self._p1, a)


class Waypoints:
    """Piecewise-linear through `(times[i], values[i])`; before the first / after the last time it
    holds the end value (never extrapolates a command)."""

    def __init__(self, times, values):
        self.times = np.asarray(times, dtype=np.float64).reshape(-1)
        self.values = np.asarray(values, dtype=np.float64)
        if self.values.shape[0] != self.times.shape[0] or self.times.size == 0:
            raise ValueError("Waypoints needs as many values as times, at least one")
        if np.any(np.diff(self.times) <= 0):
            raise ValueError("Waypoints times must be strictly increasing")

    def sample(self, t: float) -> np.ndarray:
        ts = self.times
        if t <= ts[0]:
            return self.values[0].copy()
        if t >= ts[-1]:
            return self.values[-1].copy()
        i = int(np.searchsorted(ts, t, side="right")) - 1
        a = (t - ts[i]) / (ts[i + 1] - ts[i])
        return self.values[i] + a * (self.values[i + 1] - self.values[i])
