"""ZED cameras for `rio cameras list`, through pyzed when the ZED SDK is installed (else none)."""

from __future__ import annotations

import importlib.util

from rio.plugins.cameras import CameraDevice


def list_zed_cameras() -> list[CameraDevice]:
    if importlib.util.find_spec("pyzed") is None:
        return []
    import pyzed.sl as sl

    return [CameraDevice(driver="cameras.zed", id=str(d.serial_number), select_field="serial",
                         model=str(d.camera_model), note=str(getattr(d, "camera_state", "")))
            for d in sl.Camera.get_device_list()]
