"""Replay: plays back a recorded episode's actions as if a policy had produced them, time-aligned.

The episode's clock starts at the first observation after a reset: a chunk action meant for `s`
seconds after it is the recorded command for `s` seconds into the episode (interpolated between
recorded steps on their own timestamps, so irregular steps replay correctly), and the deploy loop's
latency compensation reproduces the recorded command stream whatever the inference latency.
Useful to check a station end to end, and to compare a deployment with its demonstration.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio.policy import Policy, PolicyConfig, PolicyMetadata, PolicyNode
from rio.schema import Observation

from .episode import read_actions


class ReplayPolicy(Policy):
    name = "replay.episode"
    class Config(PolicyConfig):
        episode: str = Field(description="an episode directory, a dataset directory (with index), or an .npz")
        index: int = Field(0, ge=0, description="episode index within a dataset directory")
        rate_hz: float | None = Field(None, gt=0, description="action rate (default: from the recorded times)")
        chunk: int = Field(50, ge=1, description="actions per chunk")

    def setup(self) -> None:
        self.actions = np.zeros((0, 0))
        self.dt = 0.0
        self.t0: float | None = None
        self._t_obs = 0.0

    def load(self, layout: Any) -> None:
        super().load(layout)
        self.actions, times, fps = read_actions(self.config.episode, self.config.index)
        rate = self.config.rate_hz or fps
        if not rate:
            raise ValueError(f"episode {self.config.episode} has no times; set rate_hz")
        self.dt = 1.0 / rate
        #: when each recorded command was to be reached, seconds from the episode's first observation
        self.targets = times if times is not None else (np.arange(len(self.actions)) + 1) * self.dt

    def metadata(self) -> PolicyMetadata:
        return PolicyMetadata(self.name, self.layout.action_dim, min(self.config.chunk, self.config.max_horizon),
                              self.dt, extra={"steps": int(len(self.actions))})

    def reset(self) -> None:
        self.t0 = None

    def prepare(self, obs: Observation, instruction: str | None) -> float:
        return self._t_obs

    def __call__(self, obs: Observation, instruction: str | None, t_obs: float, seq: int = 0,
                 t_recv: float | None = None):
        self._t_obs = t_obs
        if self.t0 is None:
            self.t0 = t_obs
        return super().__call__(obs, instruction, t_obs, seq, t_recv)

    def infer(self, t_obs: float) -> np.ndarray:
        meta = self._meta()
        s = t_obs - self.t0 + (np.arange(meta.horizon) + meta.offset) * meta.dt
        return np.stack([np.interp(s, self.targets, col) for col in self.actions.T], axis=1)


ReplayConfig = ReplayPolicy.Config


class ReplayNode(PolicyNode):
    policy_class = ReplayPolicy
