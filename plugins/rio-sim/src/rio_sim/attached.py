"""What every node that lives in a sim world shares: attaching to the world bus on `open()`, the
compiled scene (same indices as the world), and a clear error when the world is gone."""

from __future__ import annotations

from .bus import WorldBus

ATTACH_TIMEOUT_S = 60.0


class Attached:
    """Mixin for sim nodes: `self.bus`, `self.model` (the world's scene) after `attach_world()`."""

    world: str
    bus: WorldBus | None = None
    model = None

    def attach_world(self) -> None:
        from .scenes import build_model

        self.bus = WorldBus.attach(self.world, timeout=ATTACH_TIMEOUT_S)
        self.model = build_model(self.bus.scene)
        if (self.model.nq, self.model.nv, self.model.nu) != (self.bus.nq, self.bus.nv, self.bus.nu):
            raise RuntimeError(f"scene '{self.bus.scene}' compiled here differs from the world's "
                               "(different rio-sim versions in one station?)")

    def world_state(self) -> dict:
        self.bus.check_alive()
        return self.bus.read_state(self._buf)

    def detach_world(self) -> None:
        if self.bus is not None:
            self.bus.close()
            self.bus = None

    @property
    def _buf(self) -> dict:
        buf = self.__dict__.get("_state_buf")
        if buf is None:
            import numpy as np

            buf = self.__dict__["_state_buf"] = {"qpos": np.empty(self.bus.nq), "qvel": np.empty(self.bus.nv),
                                                 "ctrl": np.empty(self.bus.nu)}
        return buf
