"""Stand-in policies for tests and benchmarks: no model, known outputs, a forward pass of a chosen
length (a sleep, which releases the GIL like a GPU call does), so measurements show the framework.

They live in an importable module because process middlewares spawn the policy node by class path:
`--policy rio.policy.testing:SleepPolicyNode,forward_s=0.086`.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from pydantic import Field

from rio.policy.base import Policy, PolicyConfig, PolicyMetadata
from rio.policy.node import PolicyNode
from rio.runtime.slot_check import checksum
from rio.schema import Camera, Observation


class _StandIn(Policy):
    class Config(PolicyConfig):
        forward_s: float = Field(0.0, ge=0, description="sleep this long in each forward pass")
        chunk: int = Field(50, ge=1, le=4096, description="actions per chunk")
        rate_hz: float = Field(50.0, gt=0, description="actions per second within a chunk")

    def metadata(self) -> PolicyMetadata:
        c = self.config
        return PolicyMetadata(self.name, self.layout.action_dim, min(c.chunk, c.max_horizon), 1.0 / c.rate_hz)

    def prepare(self, obs: Observation, instruction: str | None) -> Any:
        return obs

    def _sleep(self) -> None:
        if self.config.forward_s > 0:
            time.sleep(self.config.forward_s)


StandInConfig = _StandIn.Config


class SleepPolicy(_StandIn):
    """Holds the observed state for a whole chunk after `forward_s` (the benchmark's model)."""

    name = "testing.sleep"

    def infer(self, obs: Observation) -> np.ndarray:
        self._sleep()
        return np.repeat(np.asarray(obs.proprio, dtype=np.float64)[None, :], self.config.chunk, axis=0)


class RampPolicy(_StandIn):
    """Each chunk samples one straight line in time, `start + slope * (t - t0)`, where `start` and
    `t0` are the state and time of the first observation after a reset. Chunks computed from
    different observations therefore agree exactly where they overlap, so a correctly aligned
    command stream is that same line, whatever the latency."""

    name = "testing.ramp"
    class Config(StandInConfig):
        slope: float = Field(0.5, description="units per second, on every action dimension")

    def setup(self) -> None:
        self.t0: float | None = None
        self.start: np.ndarray | None = None
        self._t_obs = 0.0

    def reset(self) -> None:
        self.t0 = self.start = None

    def prepare(self, obs: Observation, instruction: str | None) -> Any:
        return obs

    def __call__(self, obs: Observation, instruction: str | None, t_obs: float, seq: int = 0,
                 t_recv: float | None = None):
        self._t_obs = t_obs
        if self.t0 is None:
            self.t0, self.start = t_obs, np.asarray(obs.proprio, dtype=np.float64).copy()
        return super().__call__(obs, instruction, t_obs, seq, t_recv)

    def infer(self, obs: Observation) -> np.ndarray:
        self._sleep()
        meta = self._meta()
        times = self._t_obs + (np.arange(meta.horizon) + meta.offset) * meta.dt
        assert self.start is not None and self.t0 is not None  # set by __call__, which runs infer()
        return self.start[None, :] + self.config.slope * (times - self.t0)[:, None]


RampConfig = RampPolicy.Config


class CrashPolicy(SleepPolicy):
    """A model that fails mid-run (out of GPU memory, say): the node must be reported by name."""

    name = "testing.crash"
    class Config(StandInConfig):
        crash_after: int = Field(2, ge=0, description="raise in the forward pass after this many chunks")

    def setup(self) -> None:
        self.calls = 0

    def infer(self, obs: Observation) -> np.ndarray:
        self.calls += 1
        if self.calls > self.config.crash_after:
            raise RuntimeError(f"simulated model failure after {self.config.crash_after} chunks")
        return super().infer(obs)


CrashConfig = CrashPolicy.Config


class NanPolicy(SleepPolicy):
    """A model whose output turns to NaN mid-run (a diverged network, a bad input): the node must stop, the
    robot hold, and the run say why in one line."""

    name = "testing.nan"
    class Config(StandInConfig):
        nan_after: int = Field(2, ge=0, description="return NaN actions after this many chunks")

    def setup(self) -> None:
        self.calls = 0

    def infer(self, obs: Observation) -> np.ndarray:
        self.calls += 1
        actions = super().infer(obs)
        if self.calls > self.config.nan_after:
            actions[:, 0] = np.nan
        return actions


class WildPolicy(SleepPolicy):
    """A model gone wild, on one action value (`index`; 0, an end-effector station's tool x, by default): every
    action sets it to `value`, or, with `value` None, to the observed one plus `drift` (each chunk asks for
    `drift` beyond where the arm is: a drift that never ends). The commander's workspace box and speed limit
    must keep the arm in."""

    name = "testing.wild"
    class Config(StandInConfig):
        value: float | None = Field(None, description="the first action value of every action (None: the "
                                                      "observed one plus `drift`)")
        drift: float = Field(0.0, description="with `value` None: how far beyond the observed value each chunk "
                                              "asks for")
        index: int = Field(0, ge=0, description="which action value goes wild")

    def infer(self, obs: Observation) -> np.ndarray:
        actions = super().infer(obs)
        i = self.config.index
        if self.config.value is not None:
            actions[:, i] = self.config.value
        else:
            actions[:, i] += self.config.drift
        return actions


def frame_signature(cam: Camera) -> np.ndarray:
    """A camera frame as 5 numbers: its timestamp and the 64-bit checksums of its rgb and depth arrays, each
    as two exact 32-bit halves (-1, -1 without depth). Equal signatures: the same frame, bit for bit."""
    def halves(a: np.ndarray | None) -> list[float]:
        if a is None:
            return [-1.0, -1.0]
        h = checksum(0, np.ascontiguousarray(a))
        return [float(h >> 32), float(h & 0xFFFFFFFF)]

    return np.array([float(cam.meta["timestamp"]), *halves(cam.rgb), *halves(cam.depth)])


class FrameEchoPolicy(_StandIn):
    """Answers with what it was shown: one chunk row per camera (the layout's order) starting with that
    frame's `frame_signature`, so a test in another process can check that the policy saw exactly the
    frames the observation referenced. Needs an action size of at least 5."""

    name = "testing.frame_echo"

    def metadata(self) -> PolicyMetadata:
        return PolicyMetadata(self.name, self.layout.action_dim, max(len(self.layout.cameras), 1),
                              1.0 / self.config.rate_hz)

    def infer(self, obs: Observation) -> np.ndarray:
        self._sleep()
        rows = np.zeros((max(len(obs.cameras), 1), self.layout.action_dim))
        for i, cam in enumerate(obs.cameras.values()):
            rows[i, :5] = frame_signature(cam)
        return rows


class SleepPolicyNode(PolicyNode):
    policy_class = SleepPolicy


class RampPolicyNode(PolicyNode):
    policy_class = RampPolicy


class CrashPolicyNode(PolicyNode):
    policy_class = CrashPolicy


class FrameEchoPolicyNode(PolicyNode):
    policy_class = FrameEchoPolicy


class NanPolicyNode(PolicyNode):
    policy_class = NanPolicy


class WildPolicyNode(PolicyNode):
    policy_class = WildPolicy
