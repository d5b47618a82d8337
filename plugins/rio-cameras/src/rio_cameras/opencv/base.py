"""`OpenCvCamera`: the base of `cameras.uvc` and `cameras.stream` (one grab path, two ways to open).

Colour only (OpenCV captures carry no depth), and intrinsics from the station config or a field-of-view
guess (`rio_cameras.intrinsics`): an OpenCV capture knows nothing about its lens.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field, model_validator

from ..camera import ThreadedCamera
from ..intrinsics import IntrinsicsConfig, pinhole


class OpenCvCamera(ThreadedCamera):
    class Config(ThreadedCamera.Config, IntrinsicsConfig):
        depth: bool = Field(False, description="always false: OpenCV captures are colour only")

        @model_validator(mode="after")
        def _colour_only(self) -> Any:
            if self.depth:
                raise ValueError("depth = true: the OpenCV drivers (cameras.uvc, cameras.stream) publish colour "
                                 "only; use cameras.oak, cameras.zed, cameras.record3d or realsense.* for depth")
            return self

    def setup(self) -> None:
        super().setup()
        c = self.config
        self.k, self.k_source = pinhole(self.width, self.height, c.fx, c.fy, c.cx, c.cy, c.hfov_deg)

    def default_intrinsics(self) -> np.ndarray | None:
        return self.k

    def details(self) -> dict[str, Any]:
        return {"intrinsics": self.k_source}
