"""The G1's two Inspire hands in the bridge (`hands = "inspire"`), as Unitree's Inspire service shows them.

rio-sim has no Inspire model, and mapping its six DoF onto the Dex3-1's seven joints would be a different
hand with the wrong ranges. So the bridge emulates what a driver sees of the real pair over DDS, not its
physics: 12 position servos (no links, no contacts, nothing to grasp), each a first-order lag toward its
commanded position (time constant `tau_s`) at most `speed` of its stroke per second. Everything in the
service's normalised units (1 open, 0 closed; `rio_unitree.inspire`):

- takes `rt/inspire/cmd` (12 motors; fewer is counted malformed): each `q` clipped to [0, 1] and rounded
  to the hand's 1/1000 steps, as the service writes it to the hand's angle register; the other fields are
  ignored, as the service ignores them;
- publishes `rt/inspire/state`: each motor's q in 1/1000 steps (the register's), nothing else (the service
  fills only q).

The two hands start fully open (q = 1). `tau_s` and `speed` are plausible figures for an unloaded RH56
(a full stroke in about half a second), not measured ones.
"""

from __future__ import annotations

import numpy as np

from ..inspire import NUM_MOTORS
from ..inspire_wire import MotorCmds, MotorStates


class InspirePair:
    def __init__(self, tau_s: float = 0.04, speed: float = 2.0):
        if tau_s <= 0 or speed <= 0:
            raise ValueError(f"inspire hands: tau_s and speed must be > 0 (got {tau_s}, {speed})")
        self.tau_s, self.speed = tau_s, speed
        self.q = np.ones(NUM_MOTORS)
        self.target = np.ones(NUM_MOTORS)

    def command(self, cmd: MotorCmds) -> bool:
        """Take one command; False (ignored) when it has fewer than 12 motors or a non-finite q."""
        q = np.asarray(cmd.q[:NUM_MOTORS], np.float64)
        if len(q) < NUM_MOTORS or not np.isfinite(q).all():
            return False
        self.target = np.round(np.clip(q, 0.0, 1.0) * 1000.0) / 1000.0
        return True

    def step(self, dt: float) -> None:
        move = (self.target - self.q) * min(1.0, dt / self.tau_s)
        self.q += np.clip(move, -self.speed * dt, self.speed * dt)

    def state(self) -> MotorStates:
        st = MotorStates.zeros(NUM_MOTORS)
        st.q[:] = np.round(self.q * 1000.0) / 1000.0
        return st
