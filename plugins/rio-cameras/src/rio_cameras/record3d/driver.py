"""`cameras.record3d`: RGB-D from an iPhone/iPad (LiDAR or the front TrueDepth camera) running the Record3D
app in USB Streaming mode, through the `record3d` package (`pip install 'rio-cameras[record3d]'`).

The library decodes in its own thread and calls `on_new_frame`; the source waits for that call, then
copies the current RGB (already RGB order) and depth (float32 metres, at the sensor's lower resolution).
Depth becomes uint16 mm and is resized with the colour to width x height (nearest-neighbour). Intrinsics
are the app's, for the RGB frame, scaled with it. Front (TrueDepth) frames are mirrored back to a true
camera view, as Record3D's own demo does. The app streams portrait frames (3:4): set width / height to
that aspect (the defaults are 480 x 640) or the picture is stretched.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
from pydantic import Field

from rio import clock

from ..camera import ThreadedCamera
from ..errors import CameraError, SourceLost
from ..frames import Frame, metric_to_u16
from ..sdk import RECORD3D_HINT, require

TRUEDEPTH = 0  # get_device_type(): 0 TrueDepth (front), 1 LiDAR (back)
NO_DEVICE = ("no iPhone/iPad found over USB: connect it with a cable, unlock it and trust this computer, open "
             "Record3D, enable Settings > USB Streaming mode and press the record button")


class Record3dSource:
    def __init__(self, device: str, wait_s: float = 1.0):
        r3d = require("record3d", "cameras.record3d", RECORD3D_HINT)
        devices = list(r3d.Record3DStream.get_connected_devices())
        if not devices:
            raise CameraError(NO_DEVICE)
        self.info = pick(devices, device)
        self.new, self.stopped, self.wait_s = threading.Event(), threading.Event(), wait_s
        self.stream = r3d.Record3DStream()
        self.stream.on_new_frame = self.new.set
        self.stream.on_stream_stopped = self.stopped.set
        if not self.stream.connect(self.info):
            raise CameraError(f"could not connect to {self.info.udid}: is Record3D open in USB Streaming mode "
                              "and no other program streaming from it?")

    def grab(self) -> Frame | None:
        if self.stopped.is_set():
            raise SourceLost("the stream stopped (the app closed or paused, the phone locked, or the cable "
                             "was unplugged)")
        if not self.new.wait(self.wait_s):
            return None  # no frame this second: counted by the grab thread
        self.new.clear()
        t = clock.now()
        s = self.stream
        rgb = np.array(s.get_rgb_frame(), dtype=np.uint8)
        depth = metric_to_u16(np.asarray(s.get_depth_frame()), unit_m=1.0)
        c = s.get_intrinsic_mat()
        k = np.array([[c.fx, 0.0, c.tx], [0.0, c.fy, c.ty], [0.0, 0.0, 1.0]])
        if s.get_device_type() == TRUEDEPTH:  # the front camera's frames arrive mirrored
            rgb, depth = rgb[:, ::-1].copy(), depth[:, ::-1].copy()
            k[0, 2] = rgb.shape[1] - 1 - k[0, 2]
        return Frame(rgb=rgb, t=t, depth=depth, depth_scale=0.001, intrinsics=k)

    def close(self) -> None:
        self.stream.disconnect()


def pick(devices: list[Any], device: str) -> Any:
    """The device whose UDID is `device`, or the one at that index; empty: the first."""
    if not device:
        return devices[0]
    for d in devices:
        if d.udid == device:
            return d
    if device.isdigit() and int(device) < len(devices):
        return devices[int(device)]
    raise CameraError(f"no connected device {device!r}; connected: {', '.join(d.udid for d in devices)}")


class Record3dCamera(ThreadedCamera):
    driver_name = "cameras.record3d"

    class Config(ThreadedCamera.Config):
        device: str = Field("", description="the iPhone/iPad's UDID (`rio cameras list`) or index; empty: the first")
        width: int = Field(480, ge=1, le=8192, description="image width (pixels); the app streams portrait 3:4")
        height: int = Field(640, ge=1, le=8192, description="image height (pixels)")
        depth: bool = Field(True, description="publish the LiDAR / TrueDepth depth (uint16 mm)")

    def where(self) -> str:
        return f"Record3D {self.config.device or '(the first iOS device)'}"

    def details(self) -> dict[str, Any]:
        return {"intrinsics": "Record3D app (RGB camera)", "depth": "uint16 mm" if self.has_depth else "off"}

    def connect(self) -> Record3dSource:
        return Record3dSource(self.config.device)
