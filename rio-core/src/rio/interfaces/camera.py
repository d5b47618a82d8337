"""The camera contract: RGB (and optionally depth) frames at the camera's own rate.

A driver's `read_state()` returns `rgb` (H, W, 3) uint8 and `intrinsics` (3x3, pixels); with depth also
`depth` (H, W) uint16 and `depth_scale` (m per unit). A driver that knows its lens distortion declares it
(`declare_distortion`) and also returns `distortion_model` and `distortion` (`distortion_fields`). Frames it
could not grab are not published.

A driver that grabs in a thread of its own makes a `rio.interfaces.Grabber` in `open()` as `self.grabber`:
the kind then publishes each frame as it lands (the grabber's arrival event) rather than at `rate_hz`, and
stops the grab thread before the driver's `close()`.

Across a network link frames are compressed once on the camera's side and decoded once by each reader
(`codec`, `jpeg_quality`, `depth_codec`; see docs/concepts/middlewares.md); capture timestamps travel
unchanged, and readers on the camera's machine over shm still read the original frames.
"""

from __future__ import annotations

import threading
from typing import Any, Literal

import numpy as np
from pydantic import Field

from rio.interfaces.grabber import Grabber
from rio.runtime.node import Node, NodeConfig, client_side
from rio.schema import DISTORTION_MODELS, Camera, RingCamera, camera_meta


class CameraNode(Node):
    class Config(NodeConfig):
        rate_hz: float = Field(30.0, gt=0, description="frames per second")
        width: int = Field(640, ge=1, le=8192, description="image width (pixels)")
        height: int = Field(480, ge=1, le=8192, description="image height (pixels)")
        depth: bool = Field(False, description="also publish metric depth")
        codec: Literal["auto", "raw", "jpeg", "png", "zstd"] = Field(
            "auto", description="how colour frames cross a network link (zmq, zenoh, portal): encoded once on "
            "the camera's side, decoded once by each reader; auto: raw while the node serves this machine only, "
            "jpeg once it serves others (shm and thread never encode)")
        jpeg_quality: int = Field(90, ge=1, le=100, description="JPEG quality (codec jpeg, or auto on a link)")
        depth_codec: Literal["auto", "raw", "png", "zstd"] = Field(
            "auto", description="how depth frames cross a network link, always lossless; auto: raw on "
            "loopback, zstd across machines")

    #: The grab thread, where the driver grabs in one (made in `open()`).
    grabber: Grabber | None = None

    def setup(self) -> None:
        c = self.config
        self.width, self.height, self.has_depth = int(c.width), int(c.height), bool(c.depth)
        self.example_data: dict[str, Any] = {"rgb": np.zeros((self.height, self.width, 3), np.uint8),
                                             "intrinsics": np.eye(3)}
        if self.has_depth:
            self.example_data["depth"] = np.zeros((self.height, self.width), np.uint16)
            self.example_data["depth_scale"] = 0.001

    def link_codecs(self) -> dict[str, dict[str, Any]]:
        """What a network middleware may compress, and how (`rio.middleware.protocol.codecs`)."""
        c = self.config
        return {"rgb": {"codec": c.codec, "quality": c.jpeg_quality}, "depth": {"codec": c.depth_codec}}

    def arrival_event(self) -> threading.Event | None:
        return self.grabber.arrived if self.grabber is not None else None

    def closing(self) -> None:
        if self.grabber is not None:
            self.grabber.stop()
            self.grabber = None

    @client_side
    def newest_frame(self) -> Camera:
        """The newest frame as the schema's `Camera` (depth in meters), its pixels left in the ring buffer
        until first read (`rio.schema.RingCamera`): what `Env` puts in each observation."""
        ring = self.ring_buffer
        s = ring.get(copy=False)  # checked views; only the small fields are copied now
        return RingCamera(ring, self.name, camera_meta(s))

    def declare_distortion(self) -> None:
        """For a driver that knows its lens distortion (call it in `setup`, after `super().setup()`): its
        samples then carry `distortion_model` and `distortion` (`distortion_fields` makes them). Cameras
        that do not declare it are pinhole cameras to their consumers ("none")."""
        self.example_data.update(distortion_fields("none"))


def distortion_fields(model: str, coefficients: Any = None, camera: str = "camera") -> dict[str, Any]:
    """A sample's lens distortion fields: `distortion_model` (the index of `model` in
    `rio.schema.DISTORTION_MODELS`, the ring holding numbers only) and `distortion` (5,) float64 (zeros
    when not given; fewer than 5 are padded with zeros). A bad model or coefficient names `camera`."""
    if model not in DISTORTION_MODELS:
        raise ValueError(f"{camera}: unknown distortion model '{model}'; one of {list(DISTORTION_MODELS)}")
    k = np.zeros(5) if coefficients is None else np.asarray(coefficients, np.float64).ravel()
    if k.size > 5 or not np.isfinite(k).all():
        raise ValueError(f"{camera}: distortion needs at most 5 finite coefficients, got {k.tolist()}")
    return {"distortion_model": np.uint8(DISTORTION_MODELS.index(model)),
            "distortion": np.pad(k, (0, 5 - k.size))}


CameraConfig = CameraNode.Config
