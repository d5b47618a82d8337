"""The joints as the controller moves them, one control tick at a time.

The controller keeps a *setpoint* `q_cmd` and the joints follow it:

- servo mode (1): each servo command replaces `servo_target`; the setpoint walks toward it at most
  at the arm's largest joint speed (the controller's rate limit), so a far target is approached,
  never jumped to. The walk is timed by when each target arrived (`servo(q, t)`), not by the control
  ticks: a tick after the emulator's thread was descheduled used to walk the whole stall toward a
  target that came at its end, moving faster than the limit allows (a loaded CI machine saw it);
- position mode (0): motion commands queue up as segments (joint moves with a trapezoidal speed
  profile at the commanded speed and acceleration, pauses, markers for "tell me when the queue gets
  here"); the head segment drives the setpoint.

What the joints then do is the backend's business: `ModelJoints` is a first-order lag (~20 ms, the
servo loop of a real joint) on the setpoint; the rio-sim backend sends the setpoint to a simulated
arm and reads its joints back. Segments report when they start and end, which the controller turns
into feedback frames.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

#: The setpoint and the joints agree within this (rad): the arm is still.
STILL = 1e-3
#: A move whose joints do not settle (a blocked simulated arm) ends this long after its setpoint did (s).
SETTLE_S = 0.5


class JointBackend(Protocol):
    def read(self) -> np.ndarray: ...

    def write(self, q_cmd: np.ndarray, t: float, dt: float) -> None: ...

    def close(self) -> None: ...


class ModelJoints:
    """Joints that follow the setpoint with a first-order lag of time constant `lag` (s)."""

    def __init__(self, q0, lag: float = 0.02):
        self.q = np.asarray(q0, dtype=float).copy()
        self.lag = float(lag)

    def read(self) -> np.ndarray:
        return self.q.copy()

    def write(self, q_cmd: np.ndarray, t: float, dt: float) -> None:
        alpha = 1.0 - math.exp(-max(dt, 0.0) / self.lag) if self.lag > 0 else 1.0
        self.q += (q_cmd - self.q) * alpha

    def set(self, q) -> None:
        self.q = np.asarray(q, dtype=float).copy()

    def close(self) -> None:
        pass


@dataclass(eq=False)
class Segment:
    """One entry of the position-mode queue. `goal` (rad, NaN = keep that joint) for a joint move;
    `duration` for a pause; neither for a marker. `start_kind`/`end_kind`: the feedback bits its start
    and end raise (0: none). `tag`: who to tell (the controller's business)."""

    goal: np.ndarray | None = None
    speed: float = 1.0
    acc: float = 10.0
    duration: float = 0.0
    start_kind: int = 0
    end_kind: int = 0
    tag: Any = None
    on_reach: Any = None  # called when the segment ends normally
    elapsed: float = field(default=0.0, init=False)
    settle: float = field(default=0.0, init=False)  # s since the setpoint arrived (moves)
    _q0: np.ndarray | None = field(default=None, init=False)
    _dq: np.ndarray | None = field(default=None, init=False)
    _plan: tuple[float, float, float, float] = field(default=(0.0, 0.0, 0.0, 0.0), init=False)

    def begin(self, q_cmd: np.ndarray) -> None:
        if self.goal is None:
            return
        goal = np.where(np.isfinite(self.goal), self.goal, q_cmd)
        self._q0, self._dq = q_cmd.copy(), goal - q_cmd
        dist = float(np.abs(self._dq).max()) if len(self._dq) else 0.0
        v, a = max(self.speed, 1e-6), max(self.acc, 1e-6)
        ta = v / a
        if a * ta * ta >= dist:  # never reaches full speed: triangular profile
            ta = math.sqrt(dist / a)
            v = a * ta
            total = 2 * ta
        else:
            total = 2 * ta + (dist - a * ta * ta) / v
        self._plan = (dist, v, a, ta)
        self.duration = total

    def sample(self) -> np.ndarray | None:
        """The setpoint `elapsed` s into a joint move (None for other segments)."""
        if self._q0 is None or self._dq is None:
            return None
        dist, v, a, ta = self._plan
        if dist <= 0.0:
            return self._q0 + self._dq
        t, total = min(self.elapsed, self.duration), self.duration
        if t < ta:
            s = 0.5 * a * t * t
        elif t < total - ta:
            s = 0.5 * a * ta * ta + v * (t - ta)
        else:
            s = dist - 0.5 * a * (total - t) ** 2
        return self._q0 + self._dq * min(max(s / dist, 0.0), 1.0)

    @property
    def done(self) -> bool:
        return self.elapsed >= self.duration


class MotionModel:
    """Setpoint generation (servo tracking, segment queue) over a `JointBackend`."""

    def __init__(self, backend: JointBackend, max_speed: float):
        self.backend = backend
        self.max_speed = float(max_speed)
        self.q = backend.read()
        self.qd = np.zeros_like(self.q)
        self.q_cmd = self.q.copy()
        self.servo_target = self.q.copy()
        self.t_walked: float | None = None  # the time the servo setpoint has walked up to
        self.queue: deque[Segment] = deque()
        self.active: Segment | None = None

    @property
    def pending(self) -> int:
        """Segments not finished (the controller's command count)."""
        return len(self.queue) + (self.active is not None)

    def servo(self, q, t: float | None = None) -> None:
        """A new servo target, arrived at `t` (monotonic s): up to then the setpoint walks toward the
        target this one replaces."""
        if t is not None:
            self._walk(t)
        self.servo_target = np.asarray(q, dtype=float).copy()

    def _walk(self, t: float) -> None:
        """The servo setpoint toward `servo_target`, at most `max_speed` for the time since it last walked."""
        if self.t_walked is not None and t > self.t_walked:
            step = self.max_speed * (t - self.t_walked)
            self.q_cmd = self.q_cmd + np.clip(self.servo_target - self.q_cmd, -step, step)
        self.t_walked = t if self.t_walked is None else max(self.t_walked, t)

    def enqueue(self, seg: Segment) -> None:
        self.queue.append(seg)

    def stop(self) -> list[Segment]:
        """Stop where the joints are: clear the queue, hold the present position. Returns the segments
        dropped (the interrupted one first)."""
        dropped = ([self.active] if self.active is not None else []) + list(self.queue)
        self.active = None
        self.queue.clear()
        self.q_cmd = self.q.copy()
        self.servo_target = self.q.copy()
        return dropped

    def moving(self, servo_mode: bool) -> bool:
        lag = float(np.abs(self.q_cmd - self.q).max()) > STILL
        if servo_mode:
            return lag or float(np.abs(self.servo_target - self.q_cmd).max()) > STILL
        return lag or self.pending > 0

    def step(self, t: float, dt: float, run: bool, servo_mode: bool) -> list[tuple[str, Segment]]:
        """Advance one tick of `dt` s; `run` False holds the setpoint (stopped, paused). Returns the
        segment events of the tick: ("start" | "end", segment)."""
        events: list[tuple[str, Segment]] = []
        if run and servo_mode:
            self._walk(t)
        else:  # held (or queue-driven): no servo walk, but the time is spent
            self.t_walked = t
        if run:
            budget = dt
            while True:
                if self.active is None:
                    if not self.queue:
                        break
                    self.active = self.queue.popleft()
                    self.active.begin(self.q_cmd)
                    events.append(("start", self.active))
                seg = self.active
                used = min(budget, max(seg.duration - seg.elapsed, 0.0))
                seg.elapsed += used
                budget -= used
                q = seg.sample()
                if q is not None:
                    self.q_cmd = q
                if not seg.done:
                    break
                if seg.goal is not None:  # a move ends when the joints are there, not the setpoint
                    seg.settle += dt
                    break
                events.append(("end", seg))
                self.active = None
        self.backend.write(self.q_cmd, t, dt)
        q_new = self.backend.read()
        if dt > 0:
            self.qd = (q_new - self.q) / dt
        self.q = q_new
        seg = self.active
        if run and seg is not None and seg.done and seg.goal is not None:
            if float(np.abs(self.q_cmd - self.q).max()) < STILL or seg.settle > SETTLE_S:
                events.append(("end", seg))
                self.active = None
        return events
