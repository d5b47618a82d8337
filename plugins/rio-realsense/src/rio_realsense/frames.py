"""From an SDK frameset to the arrays the node publishes: the one place where frames are processed,
whichever source they came from (a camera's pipeline or the software camera's syncer).

Per frameset: depth aligned to colour with `rs.align` (so depth pixel (v, u) is the distance along the
colour camera's pixel (v, u)), copies of the pixel data (the SDK recycles its buffers), the colour
stream's intrinsics as a 3x3 matrix with its lens distortion (model and coefficients, as the SDK reports
them), and the frame's camera timestamp mapped onto the station clock.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rio.interfaces.camera import distortion_fields

from .errors import RealSenseError
from .timebase import FrameClock


@dataclass
class Frame:
    """One processed frameset. `t_frame`: the frame's camera timestamp on the station clock;
    `t_arrival`: `rio.clock.now()` when the frameset was taken from the source."""

    rgb: np.ndarray
    depth: np.ndarray | None
    number: int
    t_frame: float
    t_arrival: float
    intrinsics: np.ndarray
    #: the colour stream's lens distortion: `distortion_model` and `distortion` sample fields
    distortion: dict[str, Any]

    @property
    def t(self) -> float:
        """The capture time (what `rio.interfaces.Grabber` reports a frame's age from)."""
        return self.t_frame


def intrinsics_matrix(intr: Any) -> np.ndarray:
    """The 3x3 pinhole matrix of an `rs.intrinsics` (fx, fy, ppx, ppy in pixels)."""
    return np.array([[intr.fx, 0.0, intr.ppx], [0.0, intr.fy, intr.ppy], [0.0, 0.0, 1.0]])


def distortion_of(intr: Any, serial: str) -> dict[str, Any]:
    """The distortion sample fields of an `rs.intrinsics` (its model, named as `rs.distortion` names it,
    and its 5 coefficients)."""
    return distortion_fields(intr.model.name, list(intr.coeffs), camera=f"RealSense {serial}")


class FrameProcessor:
    """Processes the framesets of one connection (a new one after each reconnect: the camera's clock
    and profiles may have changed)."""

    def __init__(self, serial: str, width: int, height: int, depth: bool, clock_window_s: float = 5.0):
        import pyrealsense2 as rs

        self.serial, self.width, self.height, self.depth = serial, width, height, depth
        self._align = rs.align(rs.stream.color) if depth else None
        self.clock = FrameClock(clock_window_s)
        self._k: np.ndarray | None = None
        self._distortion: dict[str, Any] = {}

    def complete(self, frames: Any) -> bool:
        """Whether a frameset has every stream the node publishes (a syncer may hand over colour alone
        while it waits for depth)."""
        if not frames.get_color_frame():
            return False
        return not self.depth or bool(frames.get_depth_frame())

    def process(self, frames: Any, arrival: float) -> Frame:
        if self._align is not None:
            frames = self._align.process(frames)
        color = frames.get_color_frame()
        rgb = np.array(color.get_data(), dtype=np.uint8, copy=True)
        if rgb.shape != (self.height, self.width, 3):
            raise RealSenseError(self.serial, f"colour frame is {rgb.shape}, expected ({self.height}, {self.width}, 3)")
        depth = None
        if self._align is not None:
            depth = np.array(frames.get_depth_frame().get_data(), dtype=np.uint16, copy=True)
        if self._k is None:
            intr = color.profile.as_video_stream_profile().get_intrinsics()
            self._k, self._distortion = intrinsics_matrix(intr), distortion_of(intr, self.serial)
        t_frame = self.clock.map(color.get_timestamp(), arrival, color.get_frame_timestamp_domain())
        return Frame(rgb, depth, int(color.get_frame_number()), t_frame, arrival, self._k, self._distortion)
