"""The safety between a mobile base's commands and its wheels: one body twist per driver cycle.

A base is commanded by velocity, not position, so its safety differs from the arm's `JointCommander` in
what it bounds, and in what "hold" means:

- velocity limits: a commanded twist `[vx, vy, wz]` (m/s, m/s, rad/s, body frame) is scaled down to at
  most `max_linear_speed` (the norm of vx, vy: the direction of travel is kept) and `max_angular_speed`;
- acceleration limits: the twist written moves at most `max_linear_accel / rate_hz` (linear part, as a
  vector) and `max_angular_accel / rate_hz` per cycle, so a step command (a key press, a policy glitch)
  becomes a ramp the wheels can follow without slipping or tipping the arm;
- interpolation: a twist to be reached at `t_cmd_target` is approached along a line from where the goal
  is when it arrives (within the acceleration limit);
- stale-command watchdog: every command is good for `watchdog_s` only. A base keeps rolling at its last
  commanded speed, so a controller that goes silent (crashed, stalled, its link down) must not leave
  it driving: once no command has arrived for `watchdog_s`, the target becomes zero and the base ramps
  to a stop at its acceleration limit. `holding` says that no fresh command is being followed (a
  stopping or stopped base).

`hold()` (what `disable()`, `hold()` and the watchdog do) means "stop": the target becomes zero now.
Time is passed in explicitly, which keeps it testable. Its interface is the one `CommandedNode` drives
(`reset`, `command`, `hold`, `step`, `holding`, `owner`, `watchdog_holds`).
"""

from __future__ import annotations

import logging

import numpy as np

from rio.control.interpolators import LinearInterpolator

log = logging.getLogger("rio.control")

ZERO_TWIST = np.zeros(3)


def limit_planar(twist, max_linear: float, max_angular: float) -> np.ndarray:
    """`[vx, vy, wz]` scaled down to at most `max_linear` (norm of vx, vy; direction kept) and
    `max_angular` (|wz|). Also what the acceleration limit applies to a change of twist."""
    tw = np.asarray(twist, dtype=np.float64).reshape(3).copy()
    n = float(np.hypot(tw[0], tw[1]))
    if n > max_linear:
        tw[:2] *= max_linear / n if max_linear > 0 else 0.0
    tw[2] = float(np.clip(tw[2], -max_angular, max_angular))
    return tw


class TwistCommander:
    """Body twist targets -> one safe twist per cycle (see the module docstring)."""

    def __init__(self, max_linear_speed: float, max_angular_speed: float, max_linear_accel: float,
                 max_angular_accel: float, rate_hz: float, watchdog_s: float, start=None):
        self.max_linear_speed, self.max_angular_speed = float(max_linear_speed), float(max_angular_speed)
        #: the largest change of the twist written per cycle: (linear m/s, angular rad/s)
        self.max_step = (float(max_linear_accel) / float(rate_hz), float(max_angular_accel) / float(rate_hz))
        self.watchdog_s = float(watchdog_s)
        #: Times a stream of commands went silent and the watchdog stopped the base.
        self.watchdog_holds = 0
        #: Who this commander drives, for the log ("node 'base'").
        self.owner = "a twist commander"
        self._interp: LinearInterpolator  # set by reset() (a hold) and by every command
        self.reset(ZERO_TWIST if start is None else start, 0.0)

    def _clip(self, twist) -> np.ndarray:
        tw = np.asarray(twist, dtype=np.float64).reshape(-1)
        if tw.shape != (3,):
            raise ValueError(f"a body twist has 3 values [vx, vy, wz], got {tw.size}")
        return limit_planar(tw, self.max_linear_speed, self.max_angular_speed)

    def reset(self, value, t: float) -> np.ndarray:
        """Start from the twist the base has now (`value`, measured; NaN counts as standing still) and stop
        from there: nothing is commanded until the next command."""
        v = np.asarray(value, dtype=np.float64).reshape(-1)
        self.goal = self._clip(np.where(np.isfinite(v), v, 0.0))
        self._t_cmd = -np.inf
        self.hold(t)
        return self.goal.copy()

    def command(self, target, t_target: float, now: float) -> None:
        """Head for the twist `target` (clipped to the speed limits), reaching it at `t_target`, from where
        the move under way is now (not from the goal, which the acceleration limit may hold back: a stream of
        commands faster than the cycle would otherwise restart each ramp from a goal that has barely moved);
        it is good for `watchdog_s`."""
        self._interp = LinearInterpolator(self._interp.sample(now), now)
        self._interp.set_target(self._clip(target), max(float(t_target), now), now)
        self._t_cmd = now
        self.holding = False

    def hold(self, now: float) -> None:
        """Stop: the target is zero from now on (reached within the acceleration limit)."""
        self._interp = LinearInterpolator(self.goal, now)
        self._interp.set_target(ZERO_TWIST, now, now)
        self.holding = True

    @property
    def target(self) -> np.ndarray:
        """The twist the current command ends at (zero while holding)."""
        return self._interp.goal

    def step(self, now: float) -> np.ndarray:
        """The twist for this cycle."""
        if not self.holding and now - self._t_cmd > self.watchdog_s:
            self.watchdog_holds += 1
            log.warning("%s: no command for %.2f s: stopping the base (the control loop ended or its link is "
                        "down)", self.owner, self.watchdog_s)
            self.hold(now)
        delta = limit_planar(self._interp.sample(now) - self.goal, *self.max_step)
        self.goal = self._clip(self.goal + delta)
        return self.goal.copy()
