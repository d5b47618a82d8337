"""Planar odometry: a base's pose `[x, y, theta]` (m, m, rad; in the frame where it started, or was last
reset) from its body twist over time.

Each interval is integrated exactly for a constant twist over it (the body moves along a circular arc
while it turns), not with a first-order Euler step, so driving in a circle closes on itself however
coarse the samples: odometry error is then only what the wheels report, never the integration's.
"""

from __future__ import annotations

import math

import numpy as np


def advance(pose, twist, dt: float) -> np.ndarray:
    """`pose` moved by the body twist `[vx, vy, wz]` held for `dt` seconds (exact arc)."""
    x, y, th = (float(v) for v in np.asarray(pose, dtype=np.float64).reshape(3))
    vx, vy, wz = (float(v) for v in np.asarray(twist, dtype=np.float64).reshape(3))
    dth = wz * dt
    if abs(dth) < 1e-9:  # straight: the limits of sin(x)/x and (1 - cos x)/x
        s, c = dt, 0.5 * dth * dt
    else:
        s, c = math.sin(dth) / wz, (1.0 - math.cos(dth)) / wz
    dx, dy = s * vx - c * vy, c * vx + s * vy  # in the body frame at the interval's start
    ct, st = math.cos(th), math.sin(th)
    return np.array([x + ct * dx - st * dy, y + st * dx + ct * dy, math.atan2(math.sin(th + dth), math.cos(th + dth))])


class PlanarOdometry:
    """Integrates samples of a body twist stamped with their times (each twist held since the previous
    stamp would be a guess; the mean of the two ends is used, which is exact for a twist that changes
    linearly between samples). NaN twists are skipped (nothing measured: the pose stays)."""

    def __init__(self, pose=(0.0, 0.0, 0.0)):
        self.reset(pose)

    def reset(self, pose=(0.0, 0.0, 0.0)) -> None:
        self.pose = np.asarray(pose, dtype=np.float64).reshape(3).copy()
        self._t: float | None = None
        self._twist = np.zeros(3)

    def update(self, twist, t: float) -> np.ndarray:
        tw = np.asarray(twist, dtype=np.float64).reshape(3)
        if not np.isfinite(tw).all():
            return self.pose.copy()
        if self._t is not None and t > self._t:
            self.pose = advance(self.pose, 0.5 * (self._twist + tw), t - self._t)
        if self._t is None or t >= self._t:
            self._t, self._twist = float(t), tw.copy()
        return self.pose.copy()
