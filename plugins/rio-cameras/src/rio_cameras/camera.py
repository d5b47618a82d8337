"""`ThreadedCamera`: the camera node every driver of this plugin is, over a device opened in `connect()`.

A driver writes only `connect()` (open the device, return a `rio.interfaces.grabber.Source`), `where()` (the device as
messages name it) and, if it has any, `details()` (what it negotiated). This class owns the rest: the grab
thread (`self.grabber`, a part the camera kind publishes from as frames land and stops on closing) with its
reopen-once-a-second, the first-frame wait, resizing to the configured size, and the published sample: the
kind's `rgb` / `intrinsics` (/ `depth` / `depth_scale`) plus

- `timestamp`: `rio.clock.now()` when the frame was taken off the device (not when it was published);
- `frame_age`: seconds between that grab and the publish (how stale the newest frame was);
- `frame_index`: frames grabbed since the node opened (a jump of more than 1 is a frame the loop skipped).
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.interfaces import CameraNode
from rio.interfaces.grabber import Grabber, Source
from rio.runtime.node import remote

from .errors import CameraError
from .fit import fit_frame
from .frames import Frame

log = logging.getLogger("rio_cameras")


class ThreadedCamera(CameraNode):
    class Config(CameraNode.Config):
        open_timeout_s: float = Field(10.0, gt=0, description="how long opening waits for the first frame (s)")
        reopen_s: float = Field(1.0, gt=0, le=60, description="seconds between reopen attempts after the "
                                "camera is lost (unplugged, stream dropped)")

    #: The registered name, for messages.
    driver_name = "camera"

    def setup(self) -> None:
        super().setup()
        self.example_data.update(timestamp=0.0, frame_age=0.0, frame_index=np.int64(0))
        self.grabber: Grabber | None = None
        #: the lens distortion fields of a driver that declared them (`declare_distortion`), else none
        self.distortion: dict[str, Any] = {}

    # -- what a driver writes ------------------------------------------------------------------------------
    def connect(self) -> Source:
        """Open the device; raise `CameraError` (or the SDK's error) naming it when it cannot be opened."""
        raise NotImplementedError

    def where(self) -> str:
        """The device as messages name it: '/dev/video0', 'rtsp://host/stream', 'OAK 1844301011B546C700'."""
        return "?"

    def details(self) -> dict[str, Any]:
        """Driver-specific facts for `camera_info()` (requested vs negotiated mode, intrinsics source)."""
        return {}

    def default_intrinsics(self) -> np.ndarray | None:
        """K for frames whose source gives none (the OpenCV drivers: from config or the FOV guess)."""
        return None

    # -- the node --------------------------------------------------------------------------------------------
    @property
    def label(self) -> str:
        return f"{self.driver_name} '{self.name}' ({self.where()})"

    def open(self) -> None:
        c = self.config
        self.grabber = Grabber(self.label, self.connect, process=self._prepare, reopen_s=c.reopen_s, log=log)
        self.grabber.start(c.open_timeout_s)

    def _prepare(self, frame: Frame) -> Frame:
        """In the grab thread: the frame at the configured size with intrinsics, ready to publish."""
        out = fit_frame(frame, self.width, self.height)
        if out.intrinsics is None:
            out.intrinsics = self.default_intrinsics()
        if out.intrinsics is None:
            raise CameraError(f"{self.label}: the driver gave no intrinsics")
        if self.has_depth and out.depth is None:
            raise CameraError(f"{self.label}: depth = true but the device delivered a frame without depth")
        return out

    def read_state(self) -> dict[str, Any] | None:
        assert self.grabber is not None, "read_state() before open()"
        got = self.grabber.take()
        if got is None:
            return None
        frame, index = got
        out: dict[str, Any] = {"rgb": frame.rgb, "intrinsics": frame.intrinsics, "timestamp": frame.t,
                               "frame_age": clock.now() - frame.t, "frame_index": np.int64(index), **self.distortion}
        if self.has_depth:
            out["depth"] = frame.depth
            out["depth_scale"] = float(frame.depth_scale)
        return out

    @remote
    def camera_info(self) -> dict[str, Any]:
        """What this camera is doing: the device, the published size, the driver's negotiation report and
        the grab thread's health (connected, error, frames, lost / reopened counts)."""
        status = self.grabber.status() if self.grabber is not None else {"connected": False}
        return {"driver": self.driver_name, "device": self.where(), "published": f"{self.width}x{self.height}",
                "rate_hz": self.rate_hz, **self.details(), **status}
