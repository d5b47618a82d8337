"""OAK cameras for `rio cameras list`, through depthai when it is installed (without it: none, not an
error: the plugin's other cameras still list)."""

from __future__ import annotations

import importlib.util

from rio.plugins.cameras import CameraDevice


def list_oak_cameras() -> list[CameraDevice]:
    if importlib.util.find_spec("depthai") is None:
        return []
    import depthai as dai

    out = []
    for info in dai.Device.getAllAvailableDevices():
        device_id = info.getDeviceId() if hasattr(info, "getDeviceId") else info.getMxId()
        platform = getattr(getattr(info, "platform", None), "name", "")
        state = getattr(getattr(info, "state", None), "name", "")
        out.append(CameraDevice(driver="cameras.oak", id=str(device_id), select_field="device_id",
                                model=f"Luxonis OAK{f' ({platform})' if platform else ''}",
                                note=" ".join(x for x in (f"at {info.name}" if info.name else "", state) if x)))
    return out
