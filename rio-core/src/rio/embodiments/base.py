"""The Embodiment: a robot morphology assembled from station roles.

It turns the clients of its roles into one observation (`observe()`, an `Observation` subclass) and
splits one flat action vector back into per-component commands (`apply()`). Which embodiment a
station gets is decided by `required_roles` (see `rio.embodiments.infer`), so a plugin adds a new
morphology (a mobile manipulator: `{"arm", "base"}`) by registering a subclass, with no core edit.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from rio import config as _config
from rio.config import Configurable
from rio.schema import Observation


class Embodiment(Configurable):
    name: ClassVar[str] = ""
    #: Roles that must all be present for this embodiment to apply; the most specific match wins.
    required_roles: ClassVar[frozenset[str]] = frozenset()
    #: Roles it uses when present.
    optional_roles: ClassVar[frozenset[str]] = frozenset()
    class Config(_config.Config):
        """Fields of the station's `[embodiment]` table."""

    def __init__(self, clients: dict[str, Any], config: Any = None, /, **fields: Any):
        self.clients = dict(clients)
        #: Sample timestamp of each role at the last `observe()`.
        self.timestamps: dict[str, float] = {}
        #: The sample of each role read by the last `observe()` (the control loop watches their `enabled`,
        #: `fault_code` and `connected` without reading them again: `rio.loop.health`).
        self.samples: dict[str, dict[str, Any]] = {}
        for role, client in self.clients.items():  # `env.robot.arm.get_state()`, as in the paper
            setattr(self, role, client)
        super().__init__(config, **fields)

    @classmethod
    def roles(cls) -> frozenset[str]:
        return cls.required_roles | cls.optional_roles

    # -- to implement -------------------------------------------------------------------------------
    def action_parts(self) -> list[tuple[str, int]]:
        """The flat action vector, in order: (label, size) per part."""
        raise NotImplementedError

    def observe(self) -> Observation:
        raise NotImplementedError

    def apply(self, parts: dict[str, np.ndarray], t_cmd_target: float) -> None:
        """Send each part of an action (keyed by its `action_parts` label)."""
        raise NotImplementedError

    def reset(self) -> None:
        """Called by `Env.reset()`; the default holds the current state."""

    # -- shared -------------------------------------------------------------------------------------
    @property
    def action_dim(self) -> int:
        return sum(n for _, n in self.action_parts())

    def describe_action(self) -> str:
        return ", ".join(f"{label} ({n})" for label, n in self.action_parts())

    def split_action(self, action: Any) -> dict[str, np.ndarray]:
        """Flat action -> {label: part}; a wrong size or a non-finite value is a ValueError."""
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape != (self.action_dim,):
            raise ValueError(f"{self.name}: action has {a.size} values, expected {self.action_dim}: "
                             f"{self.describe_action()}")
        if not np.isfinite(a).all():
            raise ValueError(f"{self.name}: action contains NaN or inf")
        parts, i = {}, 0
        for label, n in self.action_parts():
            parts[label] = a[i:i + n]
            i += n
        return parts

    def build_action(self, **parts: Any) -> np.ndarray:
        """The flat action from named parts (the paper's `build_action(arm_target, gripper_cmd=...)`)."""
        out = []
        for label, n in self.action_parts():
            if label not in parts:
                raise ValueError(f"{self.name}: build_action needs '{label}' ({n}); parts: {self.describe_action()}")
            out.append(np.asarray(parts[label], dtype=np.float64).reshape(-1))
        return np.concatenate(out) if out else np.zeros(0)

    def _state(self, role: str) -> dict[str, Any]:
        state = self.clients[role].get_state()
        self.timestamps[role] = float(state.get("timestamp", np.nan))
        self.samples[role] = state
        return state


EmbodimentConfig = Embodiment.Config
