"""`cameras.uvc`: a USB webcam (UVC) through OpenCV.

Opening asks for `fourcc` (MJPG by default), width x height and `rate_hz`, with a one-frame buffer, then
reads back what the driver negotiated and says so: the log line at open and `camera_info()` give
"requested 1280x720@30 MJPG, got ...". A mode the camera did not grant is a warning and the frames are
resized to the configured size (the ring buffer's shape), or, with `strict = true`, an error.

Intrinsics: a webcam reports none. Without `fx` (and `fy`, `cx`, `cy`) in the station they are a pinhole
GUESS from `hfov_deg`, logged and reported as a guess: good for rough geometry, not for metric work.
"""

from __future__ import annotations

import logging
import sys
from typing import Any, Literal

from pydantic import Field, field_validator

from .._cv import cv2_prop
from ..errors import CameraError
from ..opencv import capture
from ..opencv.base import OpenCvCamera
from .device import resolve_device
from .negotiate import Mode, Negotiation, negotiate

log = logging.getLogger("rio_cameras.uvc")


def platform_backend(choice: str) -> str:
    """'auto' -> the native capture API of this OS."""
    if choice != "auto":
        return choice
    if sys.platform.startswith("linux"):
        return "v4l2"
    return {"darwin": "avfoundation", "win32": "msmf"}.get(sys.platform, "any")


class UvcCamera(OpenCvCamera):
    driver_name = "cameras.uvc"

    class Config(OpenCvCamera.Config):
        device: int | str = Field(0, description="camera index (0), /dev/videoN, or /dev/v4l/by-id/... "
                                  "(stable across replugging; `rio cameras list` shows them)")
        fourcc: str = Field("MJPG", pattern=r"^([ -~]{4})?$", description="pixel format to request: MJPG "
                            "(compressed: HD at 30 fps over USB 2), YUYV (uncompressed), or '' for the "
                            "driver's default")
        strict: bool = Field(False, description="fail when the camera does not grant the requested width, "
                             "height, rate or format (default: warn and resize)")
        backend: Literal["auto", "v4l2", "avfoundation", "msmf", "dshow", "any"] = Field(
            "auto", description="OpenCV capture API; auto: V4L2 on Linux, AVFoundation on macOS, MSMF on Windows")
        controls: dict[str, float] = Field(default_factory=dict, description="capture properties set after "
                                           "the mode, by OpenCV name without CAP_PROP_, e.g. {autofocus = 0, "
                                           "focus = 20, auto_exposure = 1, exposure = 150}")

        @field_validator("controls")
        @classmethod
        def _known_controls(cls, v: dict[str, float]) -> dict[str, float]:
            for name in v:
                cv2_prop(name)
            return v

    def setup(self) -> None:
        super().setup()
        self._where = f"device {self.config.device}"
        self.negotiation: Negotiation | None = None
        self._reported = ""

    def where(self) -> str:
        return self._where

    def details(self) -> dict[str, Any]:
        n = self.negotiation
        if n is None:
            return super().details()
        return {**super().details(), "requested": str(n.requested), "negotiated": str(n.got),
                "differences": n.differences(), "controls": {k: {"requested": a, "read_back": b}
                                                             for k, (a, b) in n.controls.items()}}

    def connect(self) -> capture.CaptureSource:
        c = self.config
        target, self._where = resolve_device(c.device)
        backend = platform_backend(c.backend)
        if not capture.backend_built(backend):
            raise CameraError(f"{self.label}: this OpenCV build has no {backend} capture backend")
        cap = capture.open_video_capture(target, capture.backend_id(backend))
        if not cap.isOpened():
            cap.release()
            why = ("no camera at that index" if isinstance(target, int) else
                   "it is busy (another program has it open: `fuser -v " + str(target) + "`) or is not a capture "
                   "node (a UVC camera also creates a metadata node: use its -video-index0 by-id path)")
            raise CameraError(f"{self.label}: OpenCV's {backend} backend could not open it: {why}")
        try:
            n = negotiate(cap, Mode(self.width, self.height, self.rate_hz, c.fourcc), c.controls)
        except Exception:
            cap.release()
            raise
        self.negotiation = n
        report = n.report()
        if n.differences():
            if c.strict:
                cap.release()
                raise CameraError(f"{self.label}: the camera did not grant the requested mode (strict = true): "
                                  f"{report}. List its modes with `v4l2-ctl -d {target} --list-formats-ext`")
            if report != self._reported:
                stretch = (n.got.width * self.height != n.got.height * self.width and n.got.height > 0)
                log.warning("%s: %s; frames are resized to %dx%d%s", self.label, report, self.width, self.height,
                            " (the aspect ratio differs: the picture is stretched)" if stretch else "")
        elif report != self._reported:
            log.info("%s: %s", self.label, report)
        if not self._reported:
            log.info("%s: intrinsics: %s", self.label, self.k_source)
        self._reported = report
        return capture.CaptureSource(cap)
