"""A `cv2.VideoCapture` as a grab-thread source (`rio.interfaces.grabber.Source`).

Everything after the capture is the same for a webcam, an RTSP stream, a video file and the test pattern:
read, stamp with `rio.clock.now()`, convert OpenCV's BGR to the contract's RGB. Video files and the pattern
produce frames as fast as they are asked, so they are paced to the camera's `rate_hz` here; live sources
pace themselves (a read blocks until the device has the next frame).

`open_video_capture` is the one place a capture is constructed, so tests can stand a fake in for it.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from rio import clock
from rio.interfaces.grabber import SourceFinished

from ..frames import Frame

#: Station spelling -> OpenCV's constant name.
BACKENDS = {"any": "CAP_ANY", "v4l2": "CAP_V4L2", "ffmpeg": "CAP_FFMPEG", "gstreamer": "CAP_GSTREAMER",
            "avfoundation": "CAP_AVFOUNDATION", "msmf": "CAP_MSMF", "dshow": "CAP_DSHOW", "images": "CAP_IMAGES",
            "mjpeg": "CAP_OPENCV_MJPEG"}


def open_video_capture(target: int | str, api: int, params: Sequence[int] = ()) -> Any:
    """`cv2.VideoCapture(target, api[, params])`."""
    import cv2

    return cv2.VideoCapture(target, api, list(params)) if params else cv2.VideoCapture(target, api)


def backend_id(name: str) -> int:
    import cv2

    return int(getattr(cv2, BACKENDS[name]))


def backend_built(name: str) -> bool:
    """Whether this OpenCV build has the backend (`cv2.getBuildInformation()`, 'Video I/O'). The PyPI wheels
    have FFMPEG and V4L2 but not GStreamer."""
    import cv2

    return name == "any" or bool(cv2.videoio_registry.hasBackend(backend_id(name)))


def fourcc_text(value: float) -> str:
    """CAP_PROP_FOURCC's float as its four letters ('MJPG', 'YUYV'); '' when the backend reports none."""
    code = int(value) & 0xFFFFFFFF
    text = code.to_bytes(4, "little").decode("ascii", "replace").strip("\x00 ")
    return text if code and text.isprintable() else ""


def to_rgb(img: np.ndarray) -> np.ndarray:
    """OpenCV's BGR (or grey, or BGRA) image as RGB uint8."""
    import cv2

    if img.dtype != np.uint8:  # 16-bit video: keep the high byte
        img = (img >> 8).astype(np.uint8) if img.dtype == np.uint16 else img.astype(np.uint8)
    if img.ndim == 2 or img.shape[2] == 1:
        return cv2.cvtColor(img, cv2.COLOR_GRAY2RGB)
    if img.shape[2] == 4:
        return cv2.cvtColor(img, cv2.COLOR_BGRA2RGB)
    return cv2.cvtColor(img, cv2.COLOR_BGR2RGB)


class CaptureSource:
    """Reads an opened capture. `paced_hz`: deliver at most this many frames per second (files, pattern).
    `loop`: at the end of a finite source seek back to its first frame (a video file standing in for a camera);
    without it the end is `SourceFinished`. `max_failed_reads`: failed reads in a row that mean the source
    is lost (1 for network streams, whose read has already waited out its timeout)."""

    def __init__(self, cap: Any, *, paced_hz: float | None = None, loop: bool = False, finite: bool = False,
                 max_failed_reads: int = 3):
        self.cap, self.max_failed_reads = cap, max_failed_reads
        self.period = None if not paced_hz else 1.0 / float(paced_hz)
        self.loop, self.finite = loop, finite
        self._due = clock.now()
        self.loops = 0

    def grab(self) -> Frame | None:
        if self.period is not None:
            wait = self._due - clock.now()
            if wait > 0:
                time.sleep(wait)
            self._due = max(self._due + self.period, clock.now() - self.period)
        ok, img = self.cap.read()
        if not ok or img is None:
            if not self.finite:
                return None  # a failed read of a live source: the grab thread counts them
            if not self.loop:
                raise SourceFinished("end of the video (loop = false)")
            if not self._rewind():
                return None  # cannot seek: counted; when the source is lost, reopening starts it over
            ok, img = self.cap.read()
            if not ok or img is None:
                return None
        return Frame(rgb=to_rgb(img), t=clock.now())

    def _rewind(self) -> bool:
        import cv2

        self.loops += 1
        return bool(self.cap.set(cv2.CAP_PROP_POS_FRAMES, 0))

    def close(self) -> None:
        self.cap.release()
