"""`sim.wrench`: a sim arm's wrist force/torque sensor (`rio_sim.wrist_ft`) behind the standard wrench
kind, so a sim station records a wrench exactly as a station with a real F/T cell (`ati.netft`) does.

It reads the values the world publishes on its bus after each batch of physics steps, and publishes one
sample per batch (stamped with the time the world wrote it), in the `<arm>/ft` site's frame. Tare it to
take the gripper's weight out (`tare_on_open = true`, or `tare()`)."""

from __future__ import annotations

from typing import Any

from pydantic import Field

from rio.interfaces import WrenchNode

from .attached import WorldAttachment
from .wrist_ft import site_name, wrist_ft_indices


class SimWrench(WrenchNode):
    class Config(WrenchNode.Config):
        defaults = {"rate_hz": 250.0}
        arm: str = Field("arm", description="whose wrist: the scene's arm name (arm, left, right)")
        world: str = Field("sim", description="the sim.world this sensor lives in")

    def setup(self) -> None:
        super().setup()
        if "frame" not in self.config.model_fields_set:
            self.frame = site_name(self.config.arm)
        self.sim = WorldAttachment(self.config.world)
        self._t_seen = -1.0

    def open(self) -> None:
        self.sim.attach()
        self.idx = wrist_ft_indices(self.sim.model, self.config.arm)

    def close(self) -> None:
        self.sim.detach()

    def read_wrench(self) -> dict[str, Any] | None:
        s = self.sim.state()
        if s["wall_time"] == self._t_seen:
            return None  # the world has not stepped since the last sample
        self._t_seen = s["wall_time"]
        w = s["sensordata"][self.idx]
        return {"force": w[:3].copy(), "torque": w[3:].copy(), "timestamp": s["wall_time"]}
