"""The box an arm's tool stays in and the speed it moves at: the Cartesian half of the commander's safety.

Joint limits and a joint step bound each joint; they do not bound where the tool goes. A policy that emits a
tool position of 10^6 m, or drifts 5 m further every chunk, was followed at the step limit for as long as the
run lasted (a fake arm went 13.6 m in 5 s). So every arm's commander also holds a `Workspace`: a box in the
arm's base frame that every target is clipped into, and a largest tool travel per cycle (the Cartesian speed
limit times the cycle). Policy, replay and teleop actions all pass through it, in the commander, once.

- End-effector targets (`PoseCommander`) are clipped into the box when they arrive and move at most the tool
  step per cycle. The box is convex, so the straight path from a goal inside it to a clipped target stays
  inside; a goal outside it (the arm was there when it was enabled) is never yanked in: it is held where it
  is, and moves inwards as commanded.
- Joint targets (`JointCommander`), where the arm has a model: `ToolBound` checks the tool pose forward
  kinematics gives for the goal. A target whose tool lies outside the box is cut back along the move to where
  the tool leaves it; each cycle's goal moves the tool at most the tool step, and a goal whose tool would
  leave the box (a joint-space move curving out of it) is not taken: the arm holds at the box's edge. A move
  that leads back towards the box from outside it is always allowed.
- An arm without a model has no forward kinematics for its joint targets: only its joint limits and joint
  step bound them (docs/drivers.md).

`clipped` counts the commands the box changed; the arm publishes it, and the run's summary reports it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: Violations smaller than this (m) do not count: forward kinematics and interpolation round.
_EPS_M = 1e-6


class Workspace:
    """`lower`/`upper`: the box's corners (m, base frame); `max_step_m`: the largest tool travel per cycle."""

    def __init__(self, lower, upper, max_step_m: float = np.inf):
        self.lower = np.asarray(lower, dtype=np.float64).reshape(3)
        self.upper = np.asarray(upper, dtype=np.float64).reshape(3)
        if np.any(np.isnan(self.lower)) or np.any(np.isnan(self.upper)) or np.any(self.lower > self.upper):
            raise ValueError(f"a workspace is [[x, y, z] lower, [x, y, z] upper] with lower <= upper, got "
                             f"{self.lower.tolist()} / {self.upper.tolist()}")
        self.max_step_m = float(max_step_m)
        if not self.max_step_m > 0:
            raise ValueError(f"the tool step must be > 0 m per cycle, got {max_step_m}")

    @property
    def bounded(self) -> bool:
        return bool(np.all(np.isfinite(self.lower)) and np.all(np.isfinite(self.upper)))

    def clip(self, p) -> np.ndarray:
        return np.clip(np.asarray(p, dtype=np.float64)[:3], self.lower, self.upper)

    def outside(self, p) -> float:
        """How far `p` lies outside the box (m; 0 inside)."""
        p = np.asarray(p, dtype=np.float64)[:3]
        return float(np.linalg.norm(p - np.clip(p, self.lower, self.upper)))

    def describe(self) -> str:
        def v(x: np.ndarray) -> str:
            return "[" + ", ".join(f"{c:.3g}" for c in x) + "]"

        return f"{v(self.lower)} .. {v(self.upper)} m, at most {self.max_step_m * 1000:.3g} mm per cycle"


class ToolBound:
    """The workspace applied to joint goals through forward kinematics (`fk(q)` -> `[x, y, z, ...]`). A target
    whose tool lies within `slack_m` outside the box is taken as it is: an end-effector target clipped to the
    box's edge comes back from IK that close, and cutting it again would count it twice."""

    #: Bisection steps cutting a target back to the box (the cut is then within 2^-12 of the move).
    CUT_STEPS = 12

    def __init__(self, fk: Callable[[np.ndarray], np.ndarray], workspace: Workspace, slack_m: float = 0.002):
        self.fk, self.ws, self.slack_m = fk, workspace, float(slack_m)

    def tool(self, q: np.ndarray) -> np.ndarray:
        return np.asarray(self.fk(q), dtype=np.float64)[:3]

    def cut(self, q_from: np.ndarray, q_to: np.ndarray) -> tuple[np.ndarray, bool]:
        """`q_to`, or the point of the move from `q_from` to it where the tool reaches as far out of the box as
        it is at `q_from` (inside: the box's edge); True when it was cut."""
        ws = self.ws
        allowed = max(ws.outside(self.tool(q_from)), self.slack_m) + _EPS_M
        if ws.outside(self.tool(q_to)) <= allowed:
            return q_to, False
        lo, hi = 0.0, 1.0  # the fraction of the move: lo is allowed, hi is not
        d = q_to - q_from
        for _ in range(self.CUT_STEPS):
            mid = 0.5 * (lo + hi)
            if ws.outside(self.tool(q_from + mid * d)) <= allowed:
                lo = mid
            else:
                hi = mid
        return q_from + lo * d, True

    def step(self, q: np.ndarray, p: np.ndarray, q_new: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One cycle from goal `q` (its tool at `p`) toward `q_new`: scaled back so the tool moves at most the
        tool step, and not taken when its tool would leave the box further than it is. Returns the goal and its
        tool position."""
        ws = self.ws
        p_new = self.tool(q_new)
        for _ in range(3):  # the tool's travel is nearly linear in a small joint step: scale, check, again
            travel = float(np.linalg.norm(p_new - p))
            if travel <= ws.max_step_m * (1 + 1e-6):
                break
            q_new = q + (q_new - q) * (ws.max_step_m / travel)
            p_new = self.tool(q_new)
        if ws.outside(p_new) > max(ws.outside(p), self.slack_m) + _EPS_M:
            return q, p
        return q_new, p_new
