"""iOS devices for `rio cameras list` through the record3d package when installed (else none). Any
USB-connected iPhone/iPad is listed; streaming needs the Record3D app open in USB Streaming mode."""

from __future__ import annotations

import importlib.util

from rio.plugins.cameras import CameraDevice


def list_record3d_devices() -> list[CameraDevice]:
    if importlib.util.find_spec("record3d") is None:
        return []
    from record3d import Record3DStream

    return [CameraDevice(driver="cameras.record3d", id=str(d.udid), select_field="device",
                         model=f"iOS device (USB product id {int(d.product_id):#06x})",
                         note="needs the Record3D app in USB Streaming mode")
            for d in Record3DStream.get_connected_devices()]
