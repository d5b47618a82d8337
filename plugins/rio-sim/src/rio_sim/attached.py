"""What every node that lives in a sim world holds (as `self.sim`): its attachment to the world bus, made on
`open()`, the compiled scene (same indices as the world), the world's state, and a clear error when the
world is gone."""

from __future__ import annotations

from typing import Any

from .bus import WorldBus

ATTACH_TIMEOUT_S = 60.0


class WorldAttachment:
    """The sim world named `world`, as one node sees it: `bus` and `model` (the world's scene) once attached."""

    def __init__(self, world: str):
        self.world = world
        self.bus: WorldBus | None = None
        self.model: Any = None
        self._buf: dict[str, Any] | None = None

    def attach(self) -> None:
        from .scenes import build_model

        self.bus = WorldBus.attach(self.world, timeout=ATTACH_TIMEOUT_S)
        self.model = build_model(self.bus.scene)
        if (self.model.nq, self.model.nv, self.model.nu) != (self.bus.nq, self.bus.nv, self.bus.nu):
            raise RuntimeError(f"scene '{self.bus.scene}' compiled here differs from the world's "
                               "(different rio-sim versions in one station?)")

    def state(self) -> dict[str, Any]:
        """The world's qpos, qvel, ctrl and sensordata now (into buffers this attachment reuses)."""
        assert self.bus is not None
        self.bus.check_alive()
        if self._buf is None:
            import numpy as np

            self._buf = {"qpos": np.empty(self.bus.nq), "qvel": np.empty(self.bus.nv), "ctrl": np.empty(self.bus.nu),
                         "sensordata": np.empty(self.bus.ns)}
        return self.bus.read_state(self._buf)

    def detach(self) -> None:
        if self.bus is not None:
            self.bus.close()
            self.bus = None
