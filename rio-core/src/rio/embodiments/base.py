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
from rio.errors import NoCredits
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
        #: Commands not sent per role because its node was behind on a network link (`send`).
        self.behind: dict[str, int] = {}
        for role, client in self.clients.items():  # `env.robot.arm.get_state()`, as in the paper
            setattr(self, role, client)
        super().__init__(config, **fields)

    def send(self, role: str, command: str, *args: Any) -> None:
        """Call `command(*args)` on `role`'s client. A node behind on a network link (every request credit
        in flight: `NoCredits`, nothing was sent) skips this command and it is counted in `behind`: the next
        cycle's command supersedes it, and a control loop never waits on the network."""
        try:
            getattr(self.clients[role], command)(*args)
        except NoCredits:
            self.behind[role] = self.behind.get(role, 0) + 1

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

    # -- names (recorded with every episode, carried to every export's `names`) ----------------------
    def action_names(self) -> list[str]:
        """One name per element of the flat action, in order. Subclasses name them from their drivers
        (`joint_names()`: `shoulder_pan`, ..., `gripper`); this default numbers them (`joint_pos.0`)."""
        return [f"{label}.{i}" if n > 1 else label for label, n in self.action_parts() for i in range(n)]

    def named_or_numbered(self, names: list[str]) -> list[str]:
        """`names` when they are one distinct name per action element, else the numbered default (two
        drivers that name a joint alike must not give one column two meanings)."""
        if len(names) == self.action_dim and len(set(names)) == len(names):
            return list(names)
        return Embodiment.action_names(self)

    def observation_names(self) -> dict[str, list[str]]:
        """{observation field: one name per element} for the fields whose elements the drivers name
        (`proprio` is laid out as the action)."""
        return {"proprio": self.action_names()}

    def joint_names(self, role: str, n: int) -> list[str] | None:
        """The joint names the driver of `role` reports, None if it reports none or not `n` of them (a
        client without `joint_names()`, a test double): the caller then numbers the elements."""
        fn = getattr(self.clients.get(role), "joint_names", None)
        if fn is None:
            return None
        try:
            names = [str(x) for x in fn()]
        except Exception:  # a driver that cannot say: numbered names, never a failed recording
            return None
        return names if len(names) == n and len(set(names)) == n else None

    def _state(self, role: str) -> dict[str, Any]:
        state = self.clients[role].get_state()
        self.timestamps[role] = float(state.get("timestamp", np.nan))
        return state


EmbodimentConfig = Embodiment.Config
