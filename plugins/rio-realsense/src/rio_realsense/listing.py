"""`rio cameras list` for RealSense: every connected camera with the driver that opens it, its serial
(the station field `serial`), model, firmware and the modes each of its sensors offers, plus a note on
its USB link (a camera on USB 2 offers far fewer modes, the most common surprise).

No camera connected is an empty list, not an error. Imports pyrealsense2 (only `rio cameras list`
calls this)."""

from __future__ import annotations

from typing import Any

from rio.plugins.cameras import CameraDevice


def list_devices(context: Any = None) -> list[CameraDevice]:
    """The connected RealSense cameras as `CameraDevice`s. `context`: an `rs.context` (default: a new one)."""
    import pyrealsense2 as rs

    from .sources.select import DRIVERS, describe

    ctx = context if context is not None else rs.context()
    out = []
    for found in describe(ctx.query_devices()):
        notes: list[str] = []
        modes = _modes(found.device, notes)
        link = _info(found.device, rs.camera_info.usb_type_descriptor)
        if link:
            notes.append(f"USB {link}" + (": use a USB 3 port and cable" if link.startswith("2") else ""))
        driver = DRIVERS.get(found.product_line)
        if driver is None:
            driver = DRIVERS["D400"]
            notes.append(f"{found.product_line} product line: not tested with {driver}")
        out.append(CameraDevice(driver=driver, id=found.serial, model=found.name, select_field="serial",
                                firmware=_info(found.device, rs.camera_info.firmware_version), modes=modes,
                                note="; ".join(notes)))
    return out


def _info(dev: Any, what: Any) -> str:
    try:
        return str(dev.get_info(what)) if dev.supports(what) else ""
    except RuntimeError:  # unplugged while being listed
        return ""


def _modes(dev: Any, notes: list[str]) -> tuple[str, ...]:
    from .sources.modes import sensor_modes

    modes: dict[str, None] = {}
    try:
        for sensor in dev.query_sensors():
            for m in sensor_modes(sensor):
                modes.setdefault(str(m), None)
    except RuntimeError as e:  # unplugged while being listed
        notes.append(f"could not read its modes: {e}")
    return tuple(modes)
