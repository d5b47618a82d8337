"""A fake camera and fake sensors: the `rio.fake_camera`, `rio.fake_sensor` and `rio.fake_wrench` drivers."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio import interfaces as ifc
from rio.runtime.node import Node, NodeConfig


class FakeCamera(ifc.CameraNode):
    """Frames whose every pixel is the frame counter (mod 256); depth is a flat 1 m."""

    class Config(ifc.CameraNode.Config):
        width: int = Field(64, ge=1, le=4096)
        height: int = Field(48, ge=1, le=4096)

    def setup(self) -> None:
        super().setup()
        self.frame = 0
        w, h = self.width, self.height
        self.k = np.array([[w, 0.0, w / 2], [0.0, w, h / 2], [0.0, 0.0, 1.0]])

    def read_state(self) -> dict[str, Any]:
        self.frame += 1
        out: dict[str, Any] = {"rgb": np.full((self.height, self.width, 3), self.frame % 256, np.uint8),
                               "intrinsics": self.k}
        if self.has_depth:
            out["depth"] = np.full((self.height, self.width), 1000, np.uint16)
            out["depth_scale"] = 0.001
        return out


class FakeSensor(Node):
    """A sensor of no standard kind (a force-torque sensor, say) publishing a constant reading."""

    class Config(NodeConfig):
        value: list[float] = Field(default_factory=lambda: [0.0] * 6, min_length=1, max_length=64,
                                   description="the reading published (e.g. a wrench: N, N m)")

    def setup(self) -> None:
        self.example_data = {"value": np.zeros(len(self.config.value))}

    def read_state(self) -> dict[str, Any]:
        return {"value": np.asarray(self.config.value, dtype=np.float64)}


class FakeWrench(ifc.WrenchNode):
    """A force/torque cell under a constant `load` (Fx, Fy, Fz N, Tx, Ty, Tz N m) with seeded noise."""

    class Config(ifc.WrenchNode.Config):
        load: list[float] = Field(default_factory=lambda: [0.0, 0.0, -4.9, 0.0, 0.0, 0.0], min_length=6,
                                  max_length=6, description="the constant wrench applied (N, N m)")
        noise: float = Field(0.01, ge=0, description="standard deviation of each reading's noise (N, N m)")

    def setup(self) -> None:
        super().setup()
        self._rng = np.random.default_rng(0)

    def read_wrench(self) -> dict[str, Any]:
        w = np.asarray(self.config.load, dtype=np.float64) + self._rng.normal(0.0, self.config.noise, 6)
        return {"force": w[:3], "torque": w[3:]}
