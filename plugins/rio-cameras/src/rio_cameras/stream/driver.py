"""`cameras.stream`: any source OpenCV can read, as a camera.

- RTSP / HTTP MJPEG / other network URLs through OpenCV's FFMPEG backend, with open and read timeouts
  (`timeout_s`) so a dead stream is noticed and reopened instead of hanging the grab thread.
- GStreamer pipelines (`... ! appsink`), when this OpenCV was built with GStreamer (the PyPI wheels are
  not: a clear error says so).
- Video files and image sequences: a camera stand-in for demos and tests, played at `rate_hz` and
  looped (`loop = true`) by seeking back to the first frame.
- `url = "test:pattern"`: a moving synthetic picture made in-process (`rio_cameras.opencv.pattern`) that
  goes through the same capture path after the capture object; no device, file or codec involved.

Frames of another size than width x height are resized to it (the size is logged at open). Intrinsics as
for webcams: the station's `fx, fy, cx, cy`, or a field-of-view GUESS, reported as such.
"""

from __future__ import annotations

import logging
from typing import Any, Literal

from pydantic import Field

from ..errors import CameraError
from ..opencv import capture
from ..opencv.base import OpenCvCamera
from ..opencv.pattern import PatternCapture
from .url import classify, file_exists, redact

log = logging.getLogger("rio_cameras.stream")

GSTREAMER_MISSING = ("this OpenCV build has no GStreamer support (cv2.getBuildInformation() shows 'GStreamer: NO'; "
                     "the opencv-python wheels from PyPI are built without it). Use an OpenCV built with "
                     "-DWITH_GSTREAMER=ON (e.g. Debian/Ubuntu's python3-opencv in a venv made with "
                     "--system-site-packages), or give the stream's URL to the FFMPEG backend instead")


class StreamCamera(OpenCvCamera):
    driver_name = "cameras.stream"

    class Config(OpenCvCamera.Config):
        url: str = Field(..., min_length=1, description="rtsp://..., http://.../mjpg, a GStreamer pipeline ending "
                         "in appsink, a video file or image pattern (img_%04d.png), or 'test:pattern'")
        backend: Literal["auto", "ffmpeg", "gstreamer", "images", "mjpeg", "any"] = Field(
            "auto", description="OpenCV capture API; auto: GStreamer for pipelines, OpenCV's image reader for "
            "printf patterns, FFMPEG otherwise")
        loop: bool = Field(True, description="video files: start over at the end (false: stop publishing)")
        timeout_s: float = Field(10.0, gt=0, description="network streams: open and read timeout (s)")

    def setup(self) -> None:
        super().setup()
        self.kind = classify(self.config.url)
        self.delivered = ""

    def where(self) -> str:
        return redact(self.config.url)

    def details(self) -> dict[str, Any]:
        return {**super().details(), "source": self.kind, "delivered": self.delivered}

    def connect(self) -> capture.CaptureSource:
        c, kind = self.config, self.kind
        if kind == "pattern":
            cap: Any = PatternCapture(self.width, self.height, self.rate_hz)
            self.delivered = f"{self.width}x{self.height} synthetic"
            return capture.CaptureSource(cap, paced_hz=self.rate_hz)
        if kind == "file" and not file_exists(c.url):
            raise CameraError(f"{self.label}: no such file")
        backend = c.backend
        if backend == "auto":
            backend = "gstreamer" if kind == "gstreamer" else "images" if "%" in c.url else "ffmpeg"
        if backend == "gstreamer" and not capture.backend_built("gstreamer"):
            raise CameraError(f"{self.label}: {GSTREAMER_MISSING}")
        params: list[int] = []
        if kind == "network" and backend in ("ffmpeg", "any"):
            import cv2

            ms = int(c.timeout_s * 1000)
            params = [cv2.CAP_PROP_OPEN_TIMEOUT_MSEC, ms, cv2.CAP_PROP_READ_TIMEOUT_MSEC, ms]
        cap = capture.open_video_capture(c.url, capture.backend_id(backend), params)
        if not cap.isOpened():
            cap.release()
            raise CameraError(f"{self.label}: OpenCV's {backend} backend could not open it"
                              + (f" within {c.timeout_s:g} s (wrong URL or credentials, host unreachable, or "
                                 "the stream is busy)" if kind == "network" else ""))
        import cv2

        w, h = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
        fps = float(cap.get(cv2.CAP_PROP_FPS))
        delivered = f"{w}x{h}" + (f"@{fps:g}" if fps > 0 else "") + f" via {cap.getBackendName()}"
        if delivered != self.delivered:
            resized = (w, h) != (self.width, self.height) and w > 0
            log.info("%s: delivers %s%s; intrinsics: %s", self.label, delivered,
                     f", resized to {self.width}x{self.height}" if resized else "", self.k_source)
        self.delivered = delivered
        finite = kind == "file"
        return capture.CaptureSource(cap, paced_hz=self.rate_hz if finite else None, loop=c.loop, finite=finite,
                                     max_failed_reads=1 if kind == "network" else 3)
