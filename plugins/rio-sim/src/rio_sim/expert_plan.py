"""What the scripted expert does, as a function of the world's state: one pick-and-place state machine per
arm of the scene's pick-and-place pairs, closed on the measured tool pose and the objects' true poses.

Each control step an arm's machine reads its tool (position, and the angle of the fingers' closing axis
about the vertical), its finger opening, its cube and its pad, and returns a tool velocity (world frame:
m/s, and rad/s about the vertical) and a gripper command (0 closed .. 1 open):

    approach  above the cube, turning the fingers square to its faces (a cube is the same every 90 deg, so
              the turn is at most 45 deg)
    descend   around the cube
    grasp     close, until the fingers stop; fingers that closed on nothing: open, approach again
    lift      straight up; a cube left on the table: open, approach again
    carry     the cube (not the tool) over the pad's center
    lower     until the cube is just above the table
    release   open
    retreat   straight up; a cube that did not end on its pad: approach it again
    done

Velocities are proportional to the remaining error (`GAIN`, a first-order approach that slows into each
goal), capped at `SPEED` (`SLOW` near the table). A twist teleop integrates them into the tool target, so
the target keeps moving until the measured tool is at the goal: whatever the arm's tracking lag or sag, it
arrives (the proportional law on the measured pose acts as an integral one on the target).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .scenes import CUBE

#: m/s of tool speed per m of error, rad/s per rad
GAIN, TURN_GAIN = 3.0, 3.0
#: speed caps (m/s, rad/s); SLOW near the table, where a late stop would push the cube
SPEED, SLOW, TURN = 0.12, 0.05, 0.8
#: the tool's height above the table while moving over it, and its offset above the cube's center when grasping
HOVER_Z, GRASP_DZ = 0.075, 0.003
#: how close is "there" (m, rad)
REACHED_M, REACHED_FINE_M, REACHED_RAD = 0.006, 0.004, 0.05
#: a gripper whose opening changed less than this (m) over `SETTLE_S` has stopped
SETTLE_M, SETTLE_S = 0.0005, 0.25
#: attempts at one cube before the arm stops trying
MAX_ATTEMPTS = 4

PHASES = ("approach", "descend", "grasp", "lift", "carry", "lower", "release", "retreat", "done")


def wrap(a: float, period: float = 2 * math.pi) -> float:
    """`a` wrapped into [-period/2, period/2)."""
    return (a + period / 2) % period - period / 2


def quat_yaw(q) -> float:
    """The rotation about the vertical of a [w, x, y, z] quaternion (its heading)."""
    w, x, y, z = (float(v) for v in q)
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


@dataclass
class View:
    """What one arm's machine reads each step (world frame)."""

    t: float               # simulated time (s)
    tool: np.ndarray       # tool position (3)
    tool_yaw: float        # angle of the fingers' closing axis about the vertical (rad)
    width: float           # finger opening (m)
    cube: np.ndarray       # cube pose (7: xyz, wxyz)
    pad: np.ndarray        # pad pose (7)
    placed: bool           # the cube rests on its pad, released (rio_sim.success)


@dataclass
class ArmPlan:
    """One arm's pick and place (see the module docstring)."""

    rest_z: float = CUBE / 2
    phase: str = "approach"
    attempts: int = 1
    t_phase: float | None = None
    yaw_goal: float | None = None
    widths: list[tuple[float, float]] = field(default_factory=list)
    gripper: float = 1.0

    @property
    def done(self) -> bool:
        return self.phase == "done"

    def _go(self, phase: str, t: float) -> None:
        self.phase, self.t_phase, self.widths = phase, t, []

    def _again(self, t: float) -> None:
        """Open and approach the cube again, or give up after MAX_ATTEMPTS."""
        self.attempts += 1
        self.gripper, self.yaw_goal = 1.0, None
        self._go("approach" if self.attempts <= MAX_ATTEMPTS else "done", t)

    def _settled(self, v: View) -> bool:
        self.widths.append((v.t, v.width))
        old = [w for t, w in self.widths if t <= v.t - SETTLE_S]
        return bool(old) and abs(old[-1] - v.width) < SETTLE_M

    def step(self, v: View) -> tuple[np.ndarray, float]:
        """(twist: 6, world frame; gripper 0..1) for this step."""
        if self.t_phase is None:
            self.t_phase = v.t
        goal, yaw_goal, cap = v.tool.copy(), None, SPEED
        grasp_z = v.cube[2] + GRASP_DZ
        p = self.phase
        if p == "approach":
            self.gripper = 1.0
            if self.yaw_goal is None:  # square to the cube's faces: the nearest of its four headings
                self.yaw_goal = v.tool_yaw + wrap(quat_yaw(v.cube[3:]) - v.tool_yaw, math.pi / 2)
            goal = np.array([v.cube[0], v.cube[1], HOVER_Z])
            yaw_goal = self.yaw_goal
            if _near(v.tool, goal, REACHED_M) and abs(wrap(self.yaw_goal - v.tool_yaw)) < REACHED_RAD:
                self._go("descend", v.t)
        elif p == "descend":
            goal, yaw_goal, cap = np.array([v.cube[0], v.cube[1], grasp_z]), self.yaw_goal, SLOW
            if _near(v.tool, goal, REACHED_FINE_M):
                self._go("grasp", v.t)
        elif p == "grasp":
            self.gripper, goal, yaw_goal, cap = 0.0, np.array([v.cube[0], v.cube[1], grasp_z]), self.yaw_goal, SLOW
            if self._settled(v):
                if v.width < 0.6 * CUBE:  # closed on nothing
                    self._again(v.t)
                else:
                    self._go("lift", v.t)
        elif p == "lift":
            goal = np.array([v.tool[0], v.tool[1], HOVER_Z])
            if v.tool[2] > grasp_z + 0.03 and v.cube[2] < self.rest_z + 0.01:  # it stayed on the table
                self._again(v.t)
            elif _near(v.tool, goal, REACHED_M):
                self._go("carry", v.t)
        elif p == "carry":
            hold = v.tool[:2] - v.cube[:2]  # where the cube sits in the fingers: carry the cube, not the tool
            goal = np.array([v.pad[0] + hold[0], v.pad[1] + hold[1], HOVER_Z])
            if v.cube[2] < self.rest_z + 0.01:  # dropped on the way
                self._again(v.t)
            elif _near(v.tool, goal, REACHED_M):
                self._go("lower", v.t)
        elif p == "lower":
            hold = v.tool[:2] - v.cube[:2]
            lift = v.cube[2] - self.rest_z  # how far the cube is above resting on the table
            goal, cap = np.array([v.pad[0] + hold[0], v.pad[1] + hold[1], v.tool[2] - lift + 0.003]), SLOW
            if lift < 0.005:
                self._go("release", v.t)
        elif p == "release":
            self.gripper = 1.0
            if self._settled(v) and v.width > 0.8 * (CUBE + 0.01):
                self._go("retreat", v.t)
        elif p == "retreat":
            goal = np.array([v.tool[0], v.tool[1], HOVER_Z])
            if _near(v.tool, goal, REACHED_M):
                if v.placed:
                    self._go("done", v.t)
                else:
                    self._again(v.t)
        twist = np.zeros(6)
        err = goal - v.tool
        speed = GAIN * err
        n = float(np.linalg.norm(speed))
        twist[:3] = speed * (cap / n) if n > cap else speed
        if yaw_goal is not None:
            twist[5] = float(np.clip(TURN_GAIN * wrap(yaw_goal - v.tool_yaw), -TURN, TURN))
        if self.phase == "done":
            twist[:] = 0.0
        return twist, self.gripper


def _near(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    return float(np.linalg.norm(a - b)) < tol
