"""`OpenCvCamera`: the base of `cameras.uvc` and `cameras.stream` (one grab path, two ways to open).

Colour only (OpenCV captures carry no depth), and intrinsics (with the lens distortion, if calibrated) from
the station config or a field-of-view guess (`rio_cameras.intrinsics`): an OpenCV capture knows nothing about
its lens.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field, model_validator

from rio.interfaces.camera import distortion_fields

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
        if c.distortion_model != "none":  # a calibrated lens: published with every frame
            self.declare_distortion()
            self.distortion = distortion_fields(c.distortion_model, c.distortion or None, camera=self.name)

    def default_intrinsics(self) -> np.ndarray | None:
        return self.k

    def details(self) -> dict[str, Any]:
        return {"intrinsics": self.k_source}
