"""The gantry of a free-floating simulated G1: what holds it up until its controller stands it.

A real G1 is brought up hanging from a hoist, feet just off the ground; the controller starts, holds the
standing pose, and only then is the hoist lowered until the feet carry the robot. Without that, a free G1
in the bridge falls in the second its driver and policy take to start. (Unitree's unitree_mujoco has the
same idea, an "elastic band" on the pelvis.)

Here the hoist is a soft 6-DoF spring-damper on the pelvis (a harness holds the torso upright, not only a
point), pulling it to where it started, plus the robot's weight as a feed-forward so it hangs without
sagging. Lowering it (`release`) takes `lower_s` seconds: the anchor goes down `drop_m` while the weight
it carries and its stiffness fade smoothly to zero, so the feet take the load gradually (no drop); then
it applies nothing.

When: `release()` (the bridge's `release_gantry`, Enter at `rio unitree bridge --gantry`), or on its own
`release_after_s` seconds after the legs are first commanded stiff (an rt/lowcmd with kp > 0 on every
leg motor: the controller holds the pose), as an operator waits for the controller before lowering.
"""

from __future__ import annotations

from typing import Any

import numpy as np

HOLDING, LOWERING, RELEASED = "holding", "lowering", "released"


class Gantry:
    """Holds the free body `body` of `model` (its free joint's pose and velocity: `qpos`, `dof` addresses)."""

    def __init__(self, model: Any, data: Any, body: int, qpos: int, dof: int, release_after_s: float | None = None,
                 lower_s: float = 2.0, drop_m: float = 0.05, stiffness: float = 10000.0, damping: float = 600.0,
                 rot_stiffness: float = 1000.0, rot_damping: float = 20.0):
        if lower_s <= 0 or drop_m < 0:
            raise ValueError(f"gantry: lower_s must be > 0 and drop_m >= 0 (got {lower_s}, {drop_m})")
        if release_after_s is not None and release_after_s < 0:
            raise ValueError(f"gantry: release_after_s must be >= 0 (got {release_after_s})")
        self.model, self.data, self.body, self.qpos, self.dof = model, data, body, qpos, dof
        self.release_after_s, self.lower_s, self.drop_m = release_after_s, lower_s, drop_m
        self.k, self.c, self.k_rot, self.c_rot = stiffness, damping, rot_stiffness, rot_damping
        self.weight = float(model.body_subtreemass[body]) * float(-model.opt.gravity[2])
        self.engage()

    def engage(self) -> None:
        """Hold the body where it is now (after a reset: the start pose)."""
        self.anchor = self.data.qpos[self.qpos:self.qpos + 3].copy()
        self.anchor_quat = self.data.qpos[self.qpos + 3:self.qpos + 7].copy()
        self.t_stiff: float | None = None  # when the legs were first commanded stiff
        self.t_release: float | None = None  # when lowering began

    @property
    def state(self) -> str:
        if self.t_release is None:
            return HOLDING
        return LOWERING if self.load(float(self.data.time)) > 0.0 else RELEASED

    def release(self) -> None:
        """Start lowering now (again: nothing)."""
        if self.t_release is None:
            self.t_release = float(self.data.time)

    def legs_stiff(self) -> None:
        """The controller holds the legs (see the module docstring): starts the `release_after_s` clock."""
        if self.t_stiff is None:
            self.t_stiff = float(self.data.time)

    def load(self, t: float) -> float:
        """The share of the robot's weight (and of the gantry's stiffness) carried at sim time `t`: 1 while
        holding, easing to 0 over `lower_s` once lowering began."""
        if self.t_release is None:
            return 1.0
        u = min(max((t - self.t_release) / self.lower_s, 0.0), 1.0)
        return 1.0 - u * u * (3.0 - 2.0 * u)  # smoothstep: no jerk at either end

    def apply(self) -> None:
        """Set the pelvis' applied force and torque for the coming step (call before each `mj_step`)."""
        import mujoco

        d = self.data
        t = float(d.time)
        if self.t_release is None and self.t_stiff is not None and self.release_after_s is not None \
                and t >= self.t_stiff + self.release_after_s:
            self.t_release = t
        s = self.load(t)
        if s <= 0.0:
            d.xfrc_applied[self.body] = 0.0
            return
        pos, quat = d.qpos[self.qpos:self.qpos + 3], d.qpos[self.qpos + 3:self.qpos + 7]
        vel, ang_local = d.qvel[self.dof:self.dof + 3], d.qvel[self.dof + 3:self.dof + 6]
        anchor = self.anchor - np.array([0.0, 0.0, self.drop_m * (1.0 - s)])
        force = s * (self.k * (anchor - pos) - self.c * vel + np.array([0.0, 0.0, self.weight]))
        err = np.zeros(3)
        mujoco.mju_subQuat(err, self.anchor_quat, quat)  # body frame: the turn that brings it back upright
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, quat)
        torque = rot.reshape(3, 3) @ (s * (self.k_rot * err - self.c_rot * ang_local))
        d.xfrc_applied[self.body, :3] = force
        d.xfrc_applied[self.body, 3:] = torque
