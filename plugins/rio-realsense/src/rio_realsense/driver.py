"""`realsense.d400` / `realsense.l515`: Intel RealSense colour (+ aligned depth) cameras in RIO's camera
contract (`rio.interfaces.CameraNode`).

One driver for the D400 family (D405, D415, D435(i), D455) and, through the spec's preset
`product_line = "l500"`, the L515. It publishes the kind's keys, `rgb` (H, W, 3) uint8 and `intrinsics`
(the colour stream's, 3x3), with `depth = true` also `depth` (H, W) uint16 aligned to colour and
`depth_scale` (m per unit, read from the depth sensor), plus

- `distortion_model`, `distortion`: the colour stream's lens distortion as the SDK reports it (model and
  5 coefficients: `rio.interfaces.camera.distortion_fields`), recorded beside the intrinsics;
- `frame_number`: the camera's frame counter (restarts when the camera is replugged);
- `t_frame`: when the camera took the frame, on the station clock (`rio_realsense.timebase`); it is
  also the sample's `timestamp`, so an observation's camera time is the picture's time, not the time
  the loop happened to publish it;
- `frame_age`: seconds from `t_frame` to the publish (how old the picture was when it went out).

Frames are grabbed in core's grab thread (`rio.interfaces.Grabber`, through `stream.py`) from a frame source
(`sources/`): the camera's `rs.pipeline` (`source = "device"`) or a software camera
(`source = "software"`, no hardware). The SDK is imported only in `open()`.
"""

from __future__ import annotations

import logging
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from rio import clock
from rio.interfaces import CameraNode
from rio.interfaces.grabber import Grabber
from rio.runtime.node import remote

from .errors import RealSenseError
from .stream import RealSenseStream

log = logging.getLogger("rio_realsense")

class RealSenseCamera(CameraNode):
    """Publishes the newest frameset at `rate_hz` (the camera's frame rate); one not grabbed in time is
    not published."""

    class Config(CameraNode.Config):
        serial: str = Field("", description="serial number of the camera (`rio cameras list`); empty: the only "
                            "connected camera of this product line")
        source: Literal["device", "software"] = Field(
            "device", description="'device': a connected camera; 'software': a software RealSense showing a "
            "test scene (no hardware)")
        product_line: Literal["d400", "l500"] = Field(
            "d400", description="camera family: d400 (D405/D415/D435/D455) or l500 (L515); fixed by the driver name")
        depth_width: int = Field(0, ge=0, le=4096, description="depth stream width before alignment (0: same as "
                                 "colour if offered, else the closest mode)")
        depth_height: int = Field(0, ge=0, le=4096, description="depth stream height before alignment (0: see "
                                  "depth_width)")
        exposure: Literal["auto"] | float = Field(
            "auto", description="colour exposure: 'auto', or microseconds (e.g. 10000)")
        white_balance: Literal["auto"] | float = Field(
            "auto", description="colour white balance: 'auto', or kelvin (2800..6500)")
        hardware_sync: Literal["none", "master", "slave"] = Field(
            "none", description="inter-camera sync over the sync cable (D415/D435/D455): one master, the "
            "others slave")
        emitter: bool = Field(True, description="IR projector on (better depth on plain surfaces); off when "
                              "another camera's pattern interferes")
        open_timeout_s: float = Field(10.0, gt=0, description="how long opening waits for the first frame (s)")
        frame_timeout_s: float = Field(1.0, gt=0, description="no frame for this long: the camera is lost (s)")
        reconnect_s: float = Field(1.0, gt=0, le=60, description="seconds between reconnect attempts")

        @model_validator(mode="after")
        def _check(self) -> Any:
            if self.rate_hz != int(self.rate_hz):
                raise ValueError(f"rate_hz = {self.rate_hz}: RealSense frame rates are whole numbers "
                                 "(6, 15, 30, 60, 90)")
            if (self.depth_width == 0) != (self.depth_height == 0):
                raise ValueError("set both depth_width and depth_height, or neither")
            if not isinstance(self.exposure, str) and not self.exposure > 0:
                raise ValueError(f"exposure = {self.exposure}: 'auto' or a positive number of microseconds")
            if not isinstance(self.white_balance, str) and not 1000 <= self.white_balance <= 12000:
                raise ValueError(f"white_balance = {self.white_balance}: 'auto' or a colour temperature in kelvin")
            if self.frame_timeout_s < 2.0 / self.rate_hz:
                raise ValueError(f"frame_timeout_s = {self.frame_timeout_s} is shorter than two frames at "
                                 f"{self.rate_hz:g} Hz")
            return self

    def setup(self) -> None:
        super().setup()
        self.example_data.update(frame_number=np.int64(0), t_frame=0.0, frame_age=0.0, timestamp=0.0)
        self.declare_distortion()  # the colour stream's, from the SDK's intrinsics
        self.grabber: Grabber | None = None
        self.stream: RealSenseStream | None = None
        self.serial = ""
        self.model = ""
        self.firmware = ""
        self.depth_scale = 0.0
        self.settings: dict[str, Any] = {}

    # -- lifecycle --------------------------------------------------------------------------------------
    def open(self) -> None:
        c = self.config
        self.stream = None
        self.grabber = Grabber(f"RealSense {c.serial or c.product_line}", self._connect, reopen_s=c.reconnect_s,
                               log=log)
        self.grabber.start(c.open_timeout_s)
        log.info("RealSense %s (%s, firmware %s) on node '%s': %dx%d@%g%s, %s", self.serial, self.model,
                 self.firmware, self.name, self.width, self.height, self.rate_hz,
                 f" + depth (scale {self.depth_scale:g} m)" if self.has_depth else "", self.settings)

    def _source(self) -> Any:
        c = self.config
        size = (c.depth_width, c.depth_height) if c.depth_width else None
        args = (c.serial, c.product_line, self.width, self.height, int(c.rate_hz), self.has_depth, size)
        if c.source == "software":
            from .sources.software import SoftwareSource

            return SoftwareSource(*args)
        from .sources.device import DeviceSource

        return DeviceSource(*args)

    def _connect(self) -> RealSenseStream:
        """Open the source, write the config's settings, read what the driver publishes about it (the
        grab thread calls this again after every loss)."""
        import pyrealsense2 as rs

        from .frames import FrameProcessor
        from .options import apply_options

        source = self._source()
        source.open()
        try:
            dev = source.device()
            self.model = _info(dev, rs.camera_info.name)
            self.firmware = _info(dev, rs.camera_info.firmware_version)
            self.settings = apply_options(dev, self.config, source.serial)
            if self.has_depth:
                self.depth_scale = float(dev.first_depth_sensor().get_depth_scale())
                if not 0.0 < self.depth_scale <= 0.1:
                    raise RealSenseError(source.serial, f"depth sensor reports depth scale {self.depth_scale}")
            self.serial = source.serial
            if self.grabber is not None:  # with no serial configured, the camera chosen: logs name it
                self.grabber.label = f"RealSense {source.serial}"
            before = self.stream.incomplete if self.stream is not None else 0  # counted since open()
            self.stream = RealSenseStream(source, FrameProcessor(source.serial, self.width, self.height,
                                                                 self.has_depth),
                                          frame_timeout_s=self.config.frame_timeout_s,
                                          open_timeout_s=self.config.open_timeout_s)
            self.stream.incomplete = before
            return self.stream
        except BaseException:
            source.close()
            raise

    # -- publishing -------------------------------------------------------------------------------------
    def read_state(self) -> dict[str, Any] | None:
        assert self.grabber is not None, "read_state() before open()"
        got = self.grabber.take()
        if got is None:
            return None
        frame = got[0]
        out: dict[str, Any] = {"rgb": frame.rgb, "intrinsics": frame.intrinsics, "frame_number": np.int64(frame.number),
                               "t_frame": frame.t_frame, "timestamp": frame.t_frame,
                               "frame_age": clock.now() - frame.t_frame, **frame.distortion}
        if self.has_depth:
            out["depth"] = frame.depth
            out["depth_scale"] = self.depth_scale
        return out

    @remote
    def camera_info(self) -> dict[str, Any]:
        """What this camera is: serial, model, firmware, published mode, depth scale, the settings written,
        and the grab thread's health (connected, frames, lost / reconnect counts, last error)."""
        status = self.grabber.status() if self.grabber is not None else {"connected": False}
        if self.stream is not None:
            status.update(incomplete_framesets=self.stream.incomplete, clock_offset_s=self.stream.clock_offset)
        return {"serial": self.serial or self.config.serial, "model": self.model,
                "firmware": self.firmware, "source": self.config.source,
                "mode": f"{self.width}x{self.height}@{self.rate_hz:g}", "depth": self.has_depth,
                "depth_scale": self.depth_scale, "settings": self.settings, **status}


def _info(dev: Any, what: Any) -> str:
    return str(dev.get_info(what)) if dev.supports(what) else ""
