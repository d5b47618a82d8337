"""The camera contract: RGB (and optionally depth) frames at the camera's own rate.

A driver's `read_state()` returns `rgb` (H, W, 3) uint8 and `intrinsics` (3x3, pixels); with depth also
`depth` (H, W) uint16 and `depth_scale` (m per unit). Frames it could not grab are not published.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from ..errors import FrameGone
from ..node import Node, NodeConfig, client_side
from ..schema import Camera, RingCamera


class CameraNode(Node):
    class Config(NodeConfig):
        rate_hz: float = Field(30.0, gt=0, description="frames per second")
        width: int = Field(640, ge=1, le=8192, description="image width (pixels)")
        height: int = Field(480, ge=1, le=8192, description="image height (pixels)")
        depth: bool = Field(False, description="also publish metric depth")

    def setup(self) -> None:
        c = self.config
        self.width, self.height, self.has_depth = int(c.width), int(c.height), bool(c.depth)
        self.example_data: dict[str, Any] = {"rgb": np.zeros((self.height, self.width, 3), np.uint8),
                                             "intrinsics": np.eye(3)}
        if self.has_depth:
            self.example_data["depth"] = np.zeros((self.height, self.width), np.uint16)
            self.example_data["depth_scale"] = 0.001

    @client_side
    def newest_frame(self) -> Camera:
        """The newest frame as the schema's `Camera` (depth in meters), its pixels left in the ring buffer
        until first read (`rio.schema.RingCamera`): what `Env` puts in each observation."""
        ring = self.ring_buffer
        s = ring.get(copy=False)  # checked views; only the small fields are copied now
        ts = float(s["timestamp"])
        meta: dict[str, Any] = {"timestamp": ts}
        if "intrinsics" in s:
            meta["intrinsics"] = np.array(s["intrinsics"])
        name = self.name

        def load() -> Camera:
            sample = ring.find(ts)
            if sample is None:
                raise FrameGone(name, ts, ring.capacity, "read an observation's pixels within that many frames, "
                                "or copy the ones you keep")
            return Camera.from_sample(sample)

        return RingCamera(load, meta)


CameraConfig = CameraNode.Config
