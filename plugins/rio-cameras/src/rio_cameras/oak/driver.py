"""`cameras.oak`: a Luxonis OAK camera through the depthai v3 API (`pip install 'rio-cameras[oak]'`).

The colour camera (socket CAM_A) is asked for width x height at `rate_hz` as interleaved BGR; with
`depth = true` a StereoDepth node built from the two mono cameras is aligned to CAM_A at the same size
and paired with colour by a Sync node, so each frame's depth matches its colour pixel for pixel. Depth
is the device's uint16 millimetres (`depth_scale` 0.001). Intrinsics are the device's factory calibration
for CAM_A at the frame's size (`readCalibration().getCameraIntrinsics`), not a guess.

depthai is imported only in `connect()`; everything SDK-specific is in `OakSource`, kept thin so a fake
depthai module can stand in for it in tests.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from rio import clock

from ..camera import ThreadedCamera
from ..errors import SourceLost
from ..frames import Frame
from ..sdk import OAK_HINT, require


class OakSource:
    """An opened OAK: its device, started pipeline and output queue."""

    def __init__(self, device_id: str, width: int, height: int, fps: float, depth: bool):
        dai = self.dai = require("depthai", "cameras.oak", OAK_HINT)
        self.depth = depth
        self.device = dai.Device(dai.DeviceInfo(device_id)) if device_id else dai.Device()
        try:
            self.pipeline = dai.Pipeline(self.device)
            cam = self.pipeline.create(dai.node.Camera).build(dai.CameraBoardSocket.CAM_A)
            rgb = cam.requestOutput((width, height), dai.ImgFrame.Type.BGR888i, fps=float(fps))
            if depth:
                stereo = self.pipeline.create(dai.node.StereoDepth).build(autoCreateCameras=True)
                stereo.setDepthAlign(dai.CameraBoardSocket.CAM_A)
                stereo.setOutputSize(width, height)
                sync = self.pipeline.create(dai.node.Sync)
                rgb.link(sync.inputs["rgb"])
                stereo.depth.link(sync.inputs["depth"])
                self.queue = sync.out.createOutputQueue(maxSize=1, blocking=False)
            else:
                self.queue = rgb.createOutputQueue(maxSize=1, blocking=False)
            self.calibration = self.device.readCalibration()
            self._k: dict[tuple[int, int], np.ndarray] = {}
            self.pipeline.start()
        except Exception:
            self.device.close()
            raise

    def intrinsics(self, width: int, height: int) -> np.ndarray:
        if (width, height) not in self._k:
            k = self.calibration.getCameraIntrinsics(self.dai.CameraBoardSocket.CAM_A, width, height)
            self._k[(width, height)] = np.asarray(k, dtype=np.float64).reshape(3, 3)
        return self._k[(width, height)]

    def grab(self) -> Frame | None:
        import cv2

        msg = self.queue.get()  # blocks for the next frame; raises (or returns None) once the device is gone
        t = clock.now()
        if msg is None:
            raise SourceLost("depthai closed the output queue (device disconnected?)")
        colour = msg["rgb"] if self.depth else msg
        bgr = colour.getCvFrame()
        rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
        h, w = rgb.shape[:2]
        depth = np.asarray(msg["depth"].getFrame(), dtype=np.uint16) if self.depth else None
        return Frame(rgb=rgb, t=t, depth=depth, depth_scale=0.001, intrinsics=self.intrinsics(w, h))

    def close(self) -> None:
        try:
            self.pipeline.stop()
        finally:
            self.device.close()


class OakCamera(ThreadedCamera):
    driver_name = "cameras.oak"

    class Config(ThreadedCamera.Config):
        device_id: str = Field("", description="the device id (`rio cameras list`) or a PoE model's IP address; "
                               "empty: the first OAK found")

    def where(self) -> str:
        return f"OAK {self.config.device_id or '(the first found)'}"

    def details(self) -> dict[str, Any]:
        return {"intrinsics": "factory calibration of CAM_A (depthai)",
                "depth": "StereoDepth aligned to CAM_A, uint16 mm" if self.has_depth else "off"}

    def connect(self) -> OakSource:
        return OakSource(self.config.device_id, self.width, self.height, self.rate_hz, self.has_depth)
