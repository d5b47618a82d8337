"""A connected camera as a frame source: an `rs.pipeline` configured for one serial's colour (and depth)
streams. The pipeline does the USB work and its own frame syncing; we only pick the modes and turn
SDK failures into `RealSenseError`s that name the camera."""

from __future__ import annotations

from typing import Any

from ..errors import RealSenseError
from .modes import Mode, device_modes, offered, pick_depth
from .select import select_device


class DeviceSource:
    def __init__(self, serial: str, product_line: str, width: int, height: int, fps: int, depth: bool,
                 depth_size: tuple[int, int] | None = None, context: Any = None):
        self.serial, self.product_line = serial, product_line
        self.width, self.height, self.fps, self.depth = width, height, fps, depth
        self.depth_size = depth_size
        self.context = context
        self._pipeline: Any = None
        self._device: Any = None
        self.modes: tuple[Mode, Mode | None] | None = None

    def open(self) -> None:
        import pyrealsense2 as rs

        ctx = self.context if self.context is not None else rs.context()
        found = select_device(ctx.query_devices(), self.serial, self.product_line)
        self.serial = found.serial
        color, depth = self._choose(device_modes(found.device), found.name)
        cfg = rs.config()
        cfg.enable_device(self.serial)
        cfg.enable_stream(rs.stream.color, color.width, color.height, rs.format.rgb8, color.fps)
        if depth is not None:
            cfg.enable_stream(rs.stream.depth, depth.width, depth.height, rs.format.z16, depth.fps)
        pipeline = rs.pipeline(ctx)
        try:
            profile = pipeline.start(cfg)
        except RuntimeError as e:
            raise RealSenseError(self.serial, f"could not start {color}" + (f" + {depth}" if depth else "")
                                 + f": {e} (in use by another program? on a USB 2 port?)") from e
        self._pipeline, self._device = pipeline, profile.get_device()
        self.modes = (color, depth)

    def _choose(self, modes: list[Mode], name: str) -> tuple[Mode, Mode | None]:
        color = Mode("color", "rgb8", self.fps, self.width, self.height)
        if color not in modes:
            raise RealSenseError(self.serial, f"{name} has no colour mode {color}; it offers "
                                 f"{offered(modes, 'color', 'rgb8')} (set width, height and rate_hz to one of them)")
        if not self.depth:
            return color, None
        depth = pick_depth(modes, self.width, self.height, self.fps, self.depth_size)
        if depth is None:
            want = f"{self.depth_size[0]}x{self.depth_size[1]}@{self.fps}" if self.depth_size else f"@{self.fps}"
            raise RealSenseError(self.serial, f"{name} has no depth mode {want} z16; it offers "
                                 f"{offered(modes, 'depth', 'z16')}")
        return color, depth

    def device(self) -> Any:
        return self._device

    def wait(self, timeout_s: float) -> Any:
        ok, frames = self._pipeline.try_wait_for_frames(max(1, int(timeout_s * 1000)))
        return frames if ok else None

    def poll(self) -> Any:
        frames = self._pipeline.poll_for_frames()
        return frames if frames else None

    def close(self) -> None:
        pipeline, self._pipeline, self._device = self._pipeline, None, None
        if pipeline is not None:
            try:
                pipeline.stop()
            except RuntimeError:  # already stopped, or the camera is gone
                pass
