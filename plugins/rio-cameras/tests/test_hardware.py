"""On a real webcam, through the real OpenCV V4L2 (or AVFoundation / MSMF) backend. Skipped by default
(marker `hardware`) and unless a device is named:

    RIO_UVC_DEVICE=/dev/v4l/by-id/usb-...-video-index0 pytest plugins/rio-cameras -m hardware
    # optional: RIO_UVC_MODE=1280x720@30 (default 640x480@30)

It prints what the camera negotiated and checks frames arrive at the configured size, timestamped.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from rio import clock
from rio.testing import lifecycle, wait_until

pytestmark = pytest.mark.hardware


def test_a_real_webcam_delivers_frames():
    from rio_cameras.uvc.driver import UvcCamera

    device = os.environ.get("RIO_UVC_DEVICE")
    if not device:
        pytest.skip("set RIO_UVC_DEVICE to a webcam (index, /dev/videoN or /dev/v4l/by-id/...)")
    size, _, fps = os.environ.get("RIO_UVC_MODE", "640x480@30").partition("@")
    w, h = (int(x) for x in size.split("x"))
    with lifecycle(UvcCamera(device=device, width=w, height=h, rate_hz=float(fps or 30))) as cam:
        seen: list = []
        assert wait_until(lambda: seen.append(cam.read_state()) or seen[-1] is not None, timeout=10)
        info = cam.camera_info()
    print(info)
    s = seen[-1]
    assert s["rgb"].shape == (h, w, 3) and s["rgb"].dtype == np.uint8 and s["rgb"].std() > 0
    assert s["timestamp"] <= clock.now() and info["connected"] and info["error"] is None
