"""`cameras.zed`: a Stereolabs ZED through pyzed (installed by the ZED SDK; see README).

Opens the camera at `resolution` (a ZED sensor mode; AUTO lets the SDK pick) and `rate_hz`, with depth
computed by the SDK (`depth_mode`, on the GPU) when `depth = true`. Each grab retrieves the LEFT view
(BGRA -> RGB) and, with depth, the DEPTH measure in millimetres (float; NaN/inf where the SDK has no
reading) as uint16 mm with 0 for no reading. Intrinsics are the SDK's rectified left-camera calibration
at the sensor mode, scaled with the picture when it is resized to width x height.

pyzed is imported only in `connect()`; `ZedSource` holds all SDK calls, kept thin so a fake `pyzed.sl`
module can stand in for it in tests.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio import clock

from ..camera import ThreadedCamera
from ..errors import CameraError, SourceLost
from ..frames import Frame, metric_to_u16
from ..sdk import ZED_HINT, require


def enum_value(enum: Any, name: str, what: str) -> Any:
    """`sl.RESOLUTION.HD720` from "HD720", or a CameraError listing what this SDK version offers."""
    if hasattr(enum, name):
        return getattr(enum, name)
    offered = sorted(n for n in dir(enum) if n.isupper() and not n.startswith("_"))
    raise CameraError(f"this ZED SDK has no {what} {name!r}; it offers {', '.join(offered)}")


class ZedSource:
    def __init__(self, serial: int, resolution: str, fps: float, depth_mode: str | None):
        sl = self.sl = require("pyzed.sl", "cameras.zed", ZED_HINT)
        init = sl.InitParameters()
        init.camera_resolution = enum_value(sl.RESOLUTION, resolution, "resolution")
        init.camera_fps = int(round(fps))
        init.depth_mode = enum_value(sl.DEPTH_MODE, depth_mode, "depth_mode") if depth_mode else sl.DEPTH_MODE.NONE
        init.coordinate_units = sl.UNIT.MILLIMETER
        if serial:
            init.set_from_serial_number(int(serial))
        self.cam = sl.Camera()
        err = self.cam.open(init)
        if err != sl.ERROR_CODE.SUCCESS:
            raise CameraError(f"the ZED SDK could not open the camera: {err} (is it plugged into a USB 3 port, "
                              "and does the SDK's ZED_Explorer see it?)")
        left = self.cam.get_camera_information().camera_configuration.calibration_parameters.left_cam
        self.k = np.array([[left.fx, 0.0, left.cx], [0.0, left.fy, left.cy], [0.0, 0.0, 1.0]])
        self.with_depth = bool(depth_mode)
        self.runtime = sl.RuntimeParameters()
        self.image, self.depth_mat = sl.Mat(), sl.Mat()

    def grab(self) -> Frame | None:
        import cv2

        sl = self.sl
        err = self.cam.grab(self.runtime)
        if err != sl.ERROR_CODE.SUCCESS:
            if err == getattr(sl.ERROR_CODE, "CAMERA_NOT_DETECTED", object()):
                raise SourceLost(f"the ZED SDK says {err}")
            return None  # a failed grab: counted by the grab thread
        t = clock.now()
        self.cam.retrieve_image(self.image, sl.VIEW.LEFT)
        rgb = cv2.cvtColor(np.asarray(self.image.get_data()), cv2.COLOR_BGRA2RGB)
        depth = None
        if self.with_depth:
            self.cam.retrieve_measure(self.depth_mat, sl.MEASURE.DEPTH)
            depth = metric_to_u16(np.asarray(self.depth_mat.get_data()), unit_m=0.001)
        return Frame(rgb=rgb, t=t, depth=depth, depth_scale=0.001, intrinsics=self.k)

    def close(self) -> None:
        self.cam.close()


class ZedCamera(ThreadedCamera):
    driver_name = "cameras.zed"

    class Config(ThreadedCamera.Config):
        serial: int = Field(0, ge=0, description="serial number (`rio cameras list`); 0: the first ZED found")
        resolution: str = Field("AUTO", description="ZED sensor mode: AUTO, HD2K, HD1080, HD1200, HD720, SVGA, "
                                "VGA (which exist depends on the model); frames are resized to width x height")
        depth_mode: str = Field("NEURAL", description="the SDK's depth mode when depth = true (NEURAL, "
                                "NEURAL_PLUS, NEURAL_LIGHT, ULTRA, QUALITY, PERFORMANCE: by SDK version)")

    def where(self) -> str:
        return f"ZED {self.config.serial or '(the first found)'}"

    def details(self) -> dict[str, Any]:
        return {"intrinsics": "ZED SDK calibration (rectified left camera)",
                "depth": f"{self.config.depth_mode}, uint16 mm" if self.has_depth else "off"}

    def connect(self) -> ZedSource:
        c = self.config
        return ZedSource(c.serial, c.resolution, self.rate_hz, c.depth_mode if self.has_depth else None)
