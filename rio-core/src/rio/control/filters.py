"""Smoothing for commands and measurements: a first-order low-pass and the One Euro filter.

Teleop devices are noisy (hand tremor, sensor jitter) or steppy (a keyboard is all-or-nothing);
policies emit chunks that jump where they meet. A first-order low-pass removes jitter at a fixed
lag; the One Euro filter (Casiez, Roussel, Vogel, CHI 2012) adapts its cutoff to the signal's speed,
so a still hand is steady and a fast motion is not lagged. Both are linear with unit gain at rest,
so an integrated twist still reaches the distance it was meant to once the input stops.

Filters take the sample time (`rio.clock.now()` seconds) with each value, so an irregular loop is
filtered correctly, and work on scalars or arrays of any fixed shape. `PoseFilter` smooths 7-vector
poses (position component-wise, orientation by slerp with the same smoothing factor).
"""

from __future__ import annotations

import math

import numpy as np

from rio.control.rotations import quat_slerp
from rio.control.se3 import as_pose


def _alpha(cutoff_hz: float, dt: float) -> float:
    """Smoothing factor of a first-order low-pass with `cutoff_hz` sampled after `dt` seconds."""
    if dt <= 0:
        return 1.0
    tau = 1.0 / (2.0 * math.pi * cutoff_hz)
    return 1.0 / (1.0 + tau / dt)


class LowPassFilter:
    """y += a * (x - y) with a from the cutoff and the actual time step."""

    def __init__(self, cutoff_hz: float):
        if not cutoff_hz > 0:
            raise ValueError(f"cutoff_hz must be > 0, got {cutoff_hz}")
        self.cutoff_hz = float(cutoff_hz)
        self.value: np.ndarray | None = None
        self.t: float | None = None

    def reset(self, value=None, t: float | None = None) -> None:
        self.value = None if value is None else np.array(value, dtype=np.float64)
        self.t = t

    def __call__(self, x, t: float) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        if self.value is None or self.t is None:
            self.value, self.t = x.copy(), float(t)
            return self.value.copy()
        a = _alpha(self.cutoff_hz, float(t) - self.t)
        self.value = self.value + a * (x - self.value)
        self.t = float(t)
        return self.value.copy()

    def over(self, x, h: float) -> np.ndarray:
        """Filter a rate (a twist) that is then integrated over the span `h`, taking `h` itself as the
        time step: this filter's update is then exactly tau * (y_n - y_0) = sum h * (x - y), so once the
        input rests the filtered rate has integrated to the same displacement as the input, however
        irregular the spans. Filtered on the loop's tick times instead, a late cycle's long span is
        multiplied by a lagging value and the difference stays: CI's scripted squares ended up to 9 mm
        open on a loaded machine. A span of 0 changes nothing.

        A filter that has seen nothing starts from rest (zero), for the same identity to hold from the
        first span: started at its first input instead, it integrates `tau * x_0` more than the input
        when a run begins mid-motion (a device's first samples arriving after a stall: 0.5 mm)."""
        x = np.asarray(x, dtype=np.float64)
        if self.value is None or self.t is None:
            self.value, self.t = np.zeros_like(x), 0.0
        if h <= 0:
            return self.value.copy()
        return self(x, self.t + float(h))


class OneEuroFilter:
    """Speed-adaptive low-pass: cutoff = min_cutoff + beta * |filtered derivative|.

    `min_cutoff` (Hz) sets the smoothing when still; `beta` how fast the cutoff rises with speed;
    `d_cutoff` (Hz) filters the derivative estimate itself. For arrays the speed is the norm of the
    derivative, so all components share one cutoff (a 3-D position is smoothed as one point).
    """

    def __init__(self, min_cutoff: float = 1.0, beta: float = 0.0, d_cutoff: float = 1.0):
        if not (min_cutoff > 0 and d_cutoff > 0 and beta >= 0):
            raise ValueError("OneEuroFilter needs min_cutoff > 0, d_cutoff > 0, beta >= 0")
        self.min_cutoff, self.beta, self.d_cutoff = float(min_cutoff), float(beta), float(d_cutoff)
        self.value: np.ndarray | None = None
        self.deriv: np.ndarray | None = None
        self.t: float | None = None

    def reset(self) -> None:
        self.value = self.deriv = self.t = None

    def __call__(self, x, t: float) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        if self.value is None or self.t is None:
            self.value, self.deriv, self.t = x.copy(), np.zeros_like(x), float(t)
            return self.value.copy()
        dt = float(t) - self.t
        if dt <= 0:
            return self.value.copy()
        d = (x - self.value) / dt
        self.deriv = self.deriv + _alpha(self.d_cutoff, dt) * (d - self.deriv)
        cutoff = self.min_cutoff + self.beta * float(np.linalg.norm(self.deriv))
        self.value = self.value + _alpha(cutoff, dt) * (x - self.value)
        self.t = float(t)
        return self.value.copy()


class PoseFilter:
    """Low-pass (or One Euro, on the position's speed) for 7-vector poses."""

    def __init__(self, min_cutoff: float = 5.0, beta: float = 0.0):
        self.pos = OneEuroFilter(min_cutoff, beta)
        self.quat: np.ndarray | None = None

    def reset(self) -> None:
        self.pos.reset()
        self.quat = None

    def __call__(self, pose, t: float) -> np.ndarray:
        p = as_pose(pose)
        t_prev = self.pos.t
        prev = None if self.pos.value is None else self.pos.value.copy()
        pos = self.pos(p[:3], t)
        if self.quat is None or t_prev is None or prev is None:
            self.quat = p[3:].copy()
        else:
            # the smoothing factor the position filter just used, applied to the orientation
            moved = p[:3] - prev
            step = pos - prev
            k = float(np.dot(step, moved) / np.dot(moved, moved)) if np.dot(moved, moved) > 1e-18 else \
                _alpha(self.pos.min_cutoff, float(t) - t_prev)
            self.quat = quat_slerp(self.quat, p[3:], min(max(k, 0.0), 1.0))
        return np.concatenate([pos, self.quat])
