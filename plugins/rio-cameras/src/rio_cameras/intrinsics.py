"""Intrinsics for cameras whose SDK has no calibration to give (webcams, streams, video files).

A plain webcam does not report its focal length, so there are two honest options: the user's own
calibration (`fx, fy, cx, cy` in the station file, in pixels of the published width x height), or a
pinhole *guess* from a horizontal field of view (`hfov_deg`, default 70 degrees, typical of USB webcams;
look up your camera's data sheet). A guess keeps the contract's shape and is good enough for rough
geometry; it is never presented as a calibration: `camera_info()` and the open log say which one is in use.

A calibration may also give the lens distortion (`distortion_model`, e.g. "brown_conrady" for OpenCV's
`calibrateCamera` [k1, k2, p1, p2, k3], and `distortion`): the camera then publishes it with every frame
(`rio.interfaces.camera.distortion_fields`) and recordings keep it beside the intrinsics. Unset, the camera
is a pinhole camera ("none") to its consumers.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field, model_validator

from rio.interfaces import CameraNode
from rio.interfaces.camera import distortion_fields


class IntrinsicsConfig(CameraNode.Config):
    """The intrinsics fields of the OpenCV drivers (mixed into their Config)."""

    fx: float | None = Field(None, gt=0, description="focal length x (pixels of the published image); "
                             "unset: a guess from hfov_deg")
    fy: float | None = Field(None, gt=0, description="focal length y (pixels); unset: fx")
    cx: float | None = Field(None, description="principal point x (pixels); unset: the image centre")
    cy: float | None = Field(None, description="principal point y (pixels); unset: the image centre")
    hfov_deg: float = Field(70.0, gt=1, lt=179, description="horizontal field of view for the pinhole GUESS "
                            "used when fx is unset (not a calibration)")
    distortion_model: str = Field("none", description="lens distortion model of the calibration: none, "
                                  "brown_conrady (OpenCV's k1 k2 p1 p2 k3), kannala_brandt4 (fisheye), ...")
    distortion: list[float] = Field(default_factory=list, description="its coefficients (up to 5), e.g. "
                                    "OpenCV's [k1, k2, p1, p2, k3]")

    @model_validator(mode="after")
    def _known_distortion(self) -> IntrinsicsConfig:
        distortion_fields(self.distortion_model, self.distortion or None, camera="distortion_model / distortion")
        if self.distortion_model == "none" and any(self.distortion):
            raise ValueError("distortion coefficients given with distortion_model = 'none': name their model")
        return self


def pinhole(width: int, height: int, fx: float | None = None, fy: float | None = None, cx: float | None = None,
            cy: float | None = None, hfov_deg: float = 70.0) -> tuple[np.ndarray, str]:
    """(K, where it came from). With `fx` given it is the user's calibration; without, a guess with square
    pixels and the principal point at the image centre."""
    ccx = (width - 1) / 2 if cx is None else float(cx)
    ccy = (height - 1) / 2 if cy is None else float(cy)
    if fx is not None:
        f_x, f_y = float(fx), float(fx if fy is None else fy)
        source = "calibration from the station config (fx, fy, cx, cy)"
    else:
        f_x = f_y = (width / 2) / math.tan(math.radians(hfov_deg) / 2)
        source = f"GUESS from hfov_deg = {hfov_deg:g} (set fx, fy, cx, cy from a calibration to replace it)"
    return np.array([[f_x, 0.0, ccx], [0.0, f_y, ccy], [0.0, 0.0, 1.0]]), source
