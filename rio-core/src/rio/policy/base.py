"""The policy interface: what a policy plugin implements so any station can run it.

A policy adapter answers three questions and nothing else (the RIO paper's "lightweight interface"):

- how to load it (`load`, heavy: weights, a GPU, a connection to a remote server),
- how to turn the standard `rio.schema.Observation` into its own inputs (`prepare`),
- how to run inference (`infer`), returning an action chunk `[H, D]`.

Everything else (hosting it in its own process, carrying observations in and chunks out through the
middleware, aligning chunks to the time their observation was taken, blending and interpolating them
to the control rate) is done once, by `rio.policy.node` and `rio.policy.schedule`, for every policy.

A chunk is tagged with the timestamp of the observation it was computed from: action `i` is the target
for time `t_obs + (i + offset) * dt`. With `offset = 1` (the default) the first action is the command
for one action period after the observation, which is how a recorded step pairs an observation with
the action sent right after it (`Env.step` targets one period ahead).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any, ClassVar

import numpy as np
from pydantic import Field

from rio import clock
from rio.config import Config, Configurable
from rio.errors import RioError
from rio.schema import Observation


class PolicyError(RioError, ValueError):
    """A policy's output the station cannot take (NaN or inf, the wrong width or shape): an error the user
    acts on (the model, its `action_indices`), said in one line naming the policy, not a traceback."""


@dataclass
class PolicyMetadata:
    """What a loaded policy tells the deploy loop. `action_dim` is the station's action size (after
    `action_indices`), `dt` the time between consecutive actions of a chunk."""

    name: str
    action_dim: int
    horizon: int
    dt: float
    offset: float = 1.0
    action_space: str = "joint_pos"
    cameras: list[str] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def rate_hz(self) -> float:
        return 1.0 / self.dt

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PolicyMetadata:
        return cls(**d)


@dataclass
class ActionChunk:
    """`actions[i]` is the target for `t_obs + (i + offset) * dt` (all `rio.clock.now()` seconds)."""

    actions: np.ndarray
    t_obs: float
    dt: float
    offset: float = 1.0
    seq: int = 0
    #: Inside the policy process: request received, inference started and finished.
    t_recv: float = float("nan")
    t_start: float = float("nan")
    t_end: float = float("nan")

    @property
    def horizon(self) -> int:
        return int(self.actions.shape[0])

    def times(self) -> np.ndarray:
        return self.t_obs + (np.arange(self.horizon) + self.offset) * self.dt

    @property
    def forward_s(self) -> float:
        return self.t_end - self.t_start


class Policy(Configurable):
    """Base class of policy adapters: `Policy(config)` or `Policy(**fields)` (validated into `self.config`).
    Construction must stay cheap (clients build the object too, to learn its config); heavy work belongs
    in `load`."""

    class Config(Config):
        """Fields every policy accepts (a station's `[components.policy]` table, or `--policy NAME,k=v`).
        Adapters subclass it with their own fields."""

        max_horizon: int = Field(128, ge=1, le=4096,
                                 description="slots reserved for one chunk; longer chunks are cut to it")
        horizon: int | None = Field(None, ge=1, description="use only the first N actions of each chunk")
        action_indices: list[int] | None = Field(
            None, description="columns of the model's output that form the station's action, in order")
    name: ClassVar[str] = "policy"

    def __init__(self, config: Any = None, /, **fields: Any):
        super().__init__(config, **fields)
        self.layout: Any = None  # rio.policy.obs_layout.ObsLayout, set by load()

    # -- to implement -------------------------------------------------------------------------------
    def load(self, layout: Any) -> None:
        """Load weights / connect. `layout` (an `ObsLayout`) describes the station's observation: its
        cameras and their shapes, the state fields and the action size."""
        self.layout = layout

    def metadata(self) -> PolicyMetadata:
        raise NotImplementedError(f"{type(self).__name__} must define metadata()")

    def prepare(self, obs: Observation, instruction: str | None) -> Any:
        """Standard observation -> this policy's inputs. The default passes the observation through."""
        return obs

    def infer(self, inputs: Any) -> np.ndarray:
        """Inputs -> raw action chunk `[H, D_model]` (or `[D_model]` for a single action)."""
        raise NotImplementedError(f"{type(self).__name__} must define infer()")

    def reset(self) -> None:
        """Start of an episode: forget any internal state (history, queues)."""

    def close(self) -> None:
        """Release what `load` acquired."""

    # -- shared -------------------------------------------------------------------------------------
    def postprocess(self, raw: Any) -> np.ndarray:
        """Raw model output -> `[H, action_dim]` float64: pick `action_indices`, cut to `horizon` and
        `max_horizon`; a wrong width or a NaN is an error naming the policy."""
        a = np.asarray(raw, dtype=np.float64)
        if a.ndim == 1:
            a = a[None, :]
        if a.ndim != 2:
            raise PolicyError(f"policy '{self.name}' returned actions of shape {a.shape}; expected [H, D]")
        if self.config.action_indices is not None:
            a = a[:, self.config.action_indices]
        a = a[: min(self.config.horizon or a.shape[0], self.config.max_horizon)]
        want = self.layout.action_dim if self.layout is not None else a.shape[1]
        if a.shape[1] != want:
            raise PolicyError(f"policy '{self.name}' returned {a.shape[1]} action values per step, the station "
                             f"takes {want} (set action_indices to pick them)")
        if not np.isfinite(a).all():
            bad = np.argwhere(~np.isfinite(a))[0]
            raise PolicyError(f"policy '{self.name}' returned a NaN or inf action (step {bad[0]}, value {bad[1]} "
                              "of its chunk)")
        return a

    def __call__(self, obs: Observation, instruction: str | None, t_obs: float, seq: int = 0,
                 t_recv: float | None = None) -> ActionChunk:
        """Prepare, infer and postprocess one observation into a timestamped chunk."""
        meta = self._meta()
        t_start = clock.now()
        actions = self.postprocess(self.infer(self.prepare(obs, instruction)))
        t_end = clock.now()
        return ActionChunk(actions, float(t_obs), meta.dt, meta.offset, int(seq),
                           t_start if t_recv is None else t_recv, t_start, t_end)

    def _meta(self) -> PolicyMetadata:
        meta = getattr(self, "_cached_meta", None)
        if meta is None:
            meta = self._cached_meta = self.metadata()
        return meta


PolicyConfig = Policy.Config
