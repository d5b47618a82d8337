"""What stands between a command and the hardware, every driver cycle: the one safety layer of RIO.

A commander turns sparse timed targets (`t_cmd_target`) into one goal per driver cycle:

- interpolation: a target to be reached at `t_cmd_target` is approached from where the move under way
  was when it arrived (a line in joint space; a line plus slerp for poses), so commands sent slower than
  the driver rate give smooth motion, and commands sent faster do not slow it down;
- limits: every goal is clipped to the joint limits; every tool target to the arm's workspace box
  (`rio.control.workspace`: poses directly, joint targets through forward kinematics where the arm has a
  model), so a wild or drifting target (a policy gone wrong) ends at the box's edge and holds there;
- maximum step: a goal moves at most `max_step` per cycle (rad; m and rad for poses), and the tool at most
  the workspace's tool step (the Cartesian speed limit), so a wild target (a policy glitch, a leader arm
  far from the follower) becomes a bounded-speed motion, never a jump;
- stale-command watchdog: a stream of commands (each within `watchdog_s` of the previous one: a teleop
  loop, a policy) must keep coming. When none has arrived for `watchdog_s` while a streamed move is still
  under way (a target far ahead, then silence: a crashed or stalled controller), the goal stops where it
  is and the robot holds it until the next command. A single deliberate move (`home(seconds=3)`, a
  script's `move_joints(q, now + 2)` sent on its own) runs to its end, and a move that already ended stays at its
  target. `holding` says that no fresh command is being followed. A move its sender declares single
  (`move()`: the `home()` API) is never taken for part of a stream, even when it comes right after one:
  by timing alone, `home(seconds=3)` sent 0.2 s after a control loop's last command looks exactly like a
  stream that sent a far target and went silent, and was frozen half-way when the watchdog fired.
  A stream that ends with its move finished (a control loop that ended) is logged at debug level: the
  hold stops nothing; one that goes silent mid-move is a warning.
- force limit (`guard`, where the device has a wrench source and the station sets `force_limit`): a
  wrench crossing its limit holds the device where it measures itself to be (not at the goal, which may
  lie inside what it pushes against), as the watchdog holds: until the next command. While the wrench
  stays over the limit, a command is followed only as far as it backs the device off toward where it
  last was within the limit (an operator can pull back; pushing on goes nowhere). A wrench source that
  falls silent or dies (a separate sensor node) holds the same way: a limit nobody measures bounds
  nothing. Each crossing is logged by node name and counted (`force_holds`).

Every standard driver kind (`rio.interfaces`) owns one and feeds the hardware only what it returns.
Time is passed in explicitly, which keeps them testable. `clipped` counts the targets the workspace box cut.
"""

from __future__ import annotations

import logging

import numpy as np

from rio.control.force_limit import ForceLimit
from rio.control.interpolators import LinearInterpolator, PoseInterpolator
from rio.control.rotations import quat_angle, quat_slerp
from rio.control.se3 import as_pose
from rio.control.workspace import ToolBound, Workspace

log = logging.getLogger("rio.control")


class _Commander:
    """Interpolation and watchdog; subclasses say how a goal is limited and moved one step."""

    def __init__(self, value, watchdog_s: float, interp_cls: type):
        self.watchdog_s = float(watchdog_s)
        #: Times a stream of commands went silent and the watchdog held (mid-move or at its end).
        self.watchdog_holds = 0
        #: Targets the workspace box cut (`rio.control.workspace`).
        self.clipped = 0
        #: Who this commander drives, for the log ("node 'arm'").
        self.owner = "a commander"
        #: Force/torque limits checked by `guard()` (None: no limit).
        self.force_limit: ForceLimit | None = None
        #: Times a wrench crossed its limit and the force limit held.
        self.force_holds = 0
        #: Of those, the times its source could not be trusted (`guard`'s `fault`: silent or gone).
        self.source_holds = 0
        self._over_limit = False
        self._safe: np.ndarray | None = None  # where the device last was with its wrench within the limit
        self._interp_cls = interp_cls
        self.goal = self._held(value)
        self._interp = interp_cls(self.goal, 0.0)
        self._t_cmd = -np.inf
        self._streamed = False
        self.holding = True

    def _clip(self, value) -> np.ndarray:
        raise NotImplementedError

    def _held(self, value) -> np.ndarray:
        """What `reset(value)` holds: `value` within the limits."""
        return self._clip(value)

    def _target(self, target, now: float) -> np.ndarray:
        """Where a commanded move ends: `target` within the limits."""
        return self._clip(target)

    def _toward(self, goal: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """This cycle's goal on the way from `goal` to `desired`, within the step limits."""
        raise NotImplementedError

    def _arrived(self) -> bool:
        """The goal has reached the end of the current move (the step limit may lag the interpolation)."""
        return bool(np.allclose(self.goal, self._interp.goal, rtol=0.0, atol=1e-9))

    def reset(self, value, t: float) -> np.ndarray:
        """Hold `value` (the measured state at start-up, after enabling, after switching modes)."""
        self.goal = self._held(value)
        self._interp = self._interp_cls(self.goal, t)
        self._t_cmd = -np.inf
        self._streamed = False
        self.holding = True
        return self.goal.copy()

    def command(self, target, t_target: float, now: float) -> None:
        """Head for `target` (clipped to the limits), arriving at `t_target`, from where the move under way
        is now (not from the last cycle's goal: a stream of commands faster than the driver's cycle would
        otherwise restart each move from a goal that has barely moved, and crawl)."""
        self._interp = self._interp_cls(self._interp.sample(now), now)
        self._interp.set_target(self._target(target, now), t_target, now)
        self._streamed = now - self._t_cmd <= self.watchdog_s
        self._t_cmd = now
        self.holding = False

    def move(self, target, t_target: float, now: float) -> None:
        """One deliberate move (home, a scripted pose), run to its end whatever came just before it: the
        watchdog does not hold it, and the next command judges its stream from this one's time."""
        self.command(target, t_target, now)
        self._streamed = False

    def follow_measured(self, measured, now: float) -> None:
        """For hardware that keeps moving at its last commanded speed between cycles (a velocity-commanded
        base): where it went on, during a late cycle, along the way the goal was heading, the goal starts
        from there, clamped per element between the goal and where the move is now (never backwards,
        never past the move). Otherwise the goal, held to `max_step` in the cycle after a late one, lags
        the arm, which is pulled back to it and then sent forward again: a 100 ms stall of the Gen3
        driver added 20 % to its joint path (6 % with this). Call it before `step()`; the goal is still
        at most `max_step` from the measured position afterwards, so nothing jumps."""
        desired = self._interp.sample(now)
        m = np.asarray(measured, dtype=np.float64).reshape(self.goal.shape)
        self.goal = self._clip(np.clip(m, np.minimum(self.goal, desired), np.maximum(self.goal, desired)))

    def guard(self, wrench, measured, now: float, fault: str | None = None, expected: bool = False) -> bool:
        """Check this cycle's wrench (force N, torque N m) against `force_limit`; over it, hold at `measured`
        (where the device is: a goal pressed into a table would keep pressing) and return True. A crossing
        is logged and counted once; the hold is renewed every cycle the wrench stays over the limit, so
        commands resume only once it is back under. `fault`: why the wrench cannot be trusted this cycle (its
        source is silent or gone), in words: held as over the limit, since a limit nobody measures bounds
        nothing. `expected`: a hold that is part of starting up (the source not handed over yet), logged at
        INFO instead of WARNING."""
        why = fault or (self.force_limit.exceeded(wrench) if self.force_limit is not None else None)
        if why is None:
            self._over_limit = False
            self._safe = self._clip(measured)
            return False
        if not self._over_limit:
            self.force_holds += 1
            self.source_holds += fault is not None
            log.log(logging.INFO if expected else logging.WARNING,
                    "%s: %s: force limit, holding where it is until the next command", self.owner, why)
            self._over_limit = True
            self.reset(measured, now)
        return True

    def _distance(self, a: np.ndarray, b: np.ndarray) -> float:
        return float(np.linalg.norm(a - b))

    def _backs_off(self, goal: np.ndarray) -> bool:
        """Over the force limit: does `goal` bring the device closer to where it last was within it?"""
        if self._safe is None:
            return False
        return self._distance(goal, self._safe) < self._distance(self.goal, self._safe) - 1e-12

    def hold(self, now: float) -> None:
        """Stop where the goal is now (also what the watchdog does)."""
        self._interp = self._interp_cls(self.goal, now)
        self.holding = True

    @property
    def target(self) -> np.ndarray:
        """Where the current move ends."""
        return self._interp.goal

    def step(self, now: float) -> np.ndarray:
        """The goal for this cycle."""
        quiet = not self.holding and now - self._t_cmd > self.watchdog_s
        if quiet and self._streamed:
            self.watchdog_holds += 1  # a stream went silent (counted once: it holds from here on)
            if now >= self._interp.t_goal and self._arrived():  # it ended where it was heading
                # (a control loop that ends says so with hold(): this silence was not announced — a stalled
                # controller, a pulled cable — and at the target it looks the same as mid-stream)
                log.warning("%s: its stream of commands stopped %.2f s ago at its last target: holding there "
                            "(the controller stalled or its link is down)", self.owner, self.watchdog_s)
            else:  # mid-move: stop here
                log.warning("%s: its stream of commands stopped %.2f s ago mid-move: holding where it is (the "
                            "controller stalled or its link is down)", self.owner, self.watchdog_s)
                self.hold(now)
        goal = self._toward(self.goal, self._interp.sample(now))  # (_toward keeps each kind's limits)
        if self._over_limit and not self._backs_off(goal):
            goal = self.goal  # over the force limit: only a step back toward where it was within it
            self.holding = True
        self.goal = goal
        if quiet and now >= self._interp.t_goal and self._arrived():
            self.holding = True  # the move is over and nothing fresh is being followed
        return self.goal.copy()


class JointCommander(_Commander):
    """Joint targets (rad) -> one safe goal per cycle: clipped to `[lower, upper]`, at most `max_step`
    rad per joint per cycle, held by the watchdog. With `tool` (the arm's forward kinematics and workspace:
    `rio.control.workspace.ToolBound`), the tool of every target and goal stays in the workspace box and
    moves at most its tool step per cycle."""

    def __init__(self, lower, upper, max_step: float, watchdog_s: float, start=None, tool: ToolBound | None = None):
        self.lower = np.asarray(lower, dtype=np.float64).reshape(-1)
        self.upper = np.asarray(upper, dtype=np.float64).reshape(-1)
        if self.lower.shape != self.upper.shape or np.any(self.lower > self.upper):
            raise ValueError(f"joint limits must be two equal-length vectors with lower <= upper, got "
                             f"{self.lower.tolist()} / {self.upper.tolist()}")
        self.max_step = float(max_step)
        self.tool = tool
        start = np.zeros(self.lower.size) if start is None else start
        super().__init__(start, watchdog_s, LinearInterpolator)
        self._tool_at = tool.tool(self.goal) if tool is not None else None  # the goal's tool position

    def _clip(self, q) -> np.ndarray:
        q = np.asarray(q, dtype=np.float64).reshape(-1)
        if q.shape != self.lower.shape:
            raise ValueError(f"joint target has {q.size} values, the commander drives {self.lower.size}")
        return np.clip(q, self.lower, self.upper)

    def reset(self, value, t: float) -> np.ndarray:
        held = super().reset(value, t)
        if self.tool is not None:
            self._tool_at = self.tool.tool(self.goal)
        return held

    def _target(self, target, now: float) -> np.ndarray:
        q = self._clip(target)
        if self.tool is None:
            return q
        q, cut = self.tool.cut(self._clip(self._interp.sample(now)), q)
        self.clipped += int(cut)
        return q

    def _toward(self, goal: np.ndarray, desired: np.ndarray) -> np.ndarray:
        q = self._clip(goal + np.clip(desired - goal, -self.max_step, self.max_step))
        if self.tool is None or np.array_equal(q, goal):
            return q
        assert self._tool_at is not None  # set with the tool bound at reset
        q, self._tool_at = self.tool.step(goal, self._tool_at, q)
        return q


class PoseCommander(_Commander):
    """End-effector pose targets `[x, y, z, qw, qx, qy, qz]` -> one safe goal per cycle: position in
    the workspace box, at most `max_step_m` of travel and `max_step_rad` of rotation per cycle (the
    orientation moves along the slerp arc), held by the watchdog. A pose held by `reset` stays where it is,
    inside the box or not (it is where the arm was): only the targets it is sent are clipped, so the arm is
    never yanked into the box, and moves into it as commanded."""

    def __init__(self, workspace_lower, workspace_upper, max_step_m: float, max_step_rad: float,
                 watchdog_s: float, start=None):
        self.workspace = Workspace(workspace_lower, workspace_upper, max_step_m)
        self.lower, self.upper = self.workspace.lower, self.workspace.upper
        self.max_step_m, self.max_step_rad = float(max_step_m), float(max_step_rad)
        start = np.array([*np.clip(np.zeros(3), self.lower, self.upper), 1.0, 0.0, 0.0, 0.0]) if start is None \
            else start
        super().__init__(start, watchdog_s, PoseInterpolator)

    def _clip(self, pose) -> np.ndarray:
        p = as_pose(pose)
        p[:3] = np.clip(p[:3], self.lower, self.upper)
        return p

    def _distance(self, a: np.ndarray, b: np.ndarray) -> float:
        """Tool travel (m) plus rotation at 0.1 m per rad."""
        return float(np.linalg.norm(a[:3] - b[:3])) + 0.1 * quat_angle(a[3:], b[3:])
    def _held(self, pose) -> np.ndarray:
        return as_pose(pose)

    def _target(self, target, now: float) -> np.ndarray:
        p = self._clip(target)
        if self.workspace.outside(as_pose(target)) > 1e-9:
            self.clipped += 1
        return p

    def follow_measured(self, measured, now: float) -> None:
        """The position as `_Commander.follow_measured` (a base streaming twists keeps its last one through a
        late cycle); the orientation stays the goal's (a quaternion is not clamped element by element: q and
        -q are the same rotation)."""
        m = as_pose(measured)
        m[3:] = self.goal[3:]
        super().follow_measured(m, now)

    def _arrived(self) -> bool:
        target = self._interp.goal
        return bool(np.allclose(self.goal[:3], target[:3], rtol=0.0, atol=1e-9)
                    and quat_angle(self.goal[3:], target[3:]) <= 1e-9)

    def _toward(self, goal: np.ndarray, desired: np.ndarray) -> np.ndarray:
        out = desired.copy()
        d = desired[:3] - goal[:3]
        dist = float(np.linalg.norm(d))
        if dist > self.max_step_m:
            out[:3] = goal[:3] + d * (self.max_step_m / dist)
        angle = quat_angle(goal[3:], desired[3:])
        if angle > self.max_step_rad:
            out[3:] = quat_slerp(goal[3:], desired[3:], self.max_step_rad / angle)
        return out
