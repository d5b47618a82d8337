"""The config's camera settings written to an opened camera's sensors through the SDK's option calls.

Runs on any `rs.device` (a camera, or the software camera, which registers the same options), after
every (re)connection, because a replugged camera starts from its defaults.

Units: `exposure` is in microseconds. A D400's separate RGB sensor (D415/D435/D455) counts exposure
in 100 us steps, so the value is divided by 100 there; a D405's colour comes from its depth sensor,
which counts microseconds. A value outside the sensor's range is clamped, with a warning.
"""

from __future__ import annotations

import logging
from typing import Any

from .errors import RealSenseError

log = logging.getLogger("rio_realsense")

SYNC_MODES = {"none": 0, "master": 1, "slave": 2}


def sensor_for(device: Any, stream: Any) -> Any:
    """The sensor of `device` that produces `stream` (rs.stream.color / depth), or None."""
    for sensor in device.query_sensors():
        if any(p.stream_type() == stream for p in sensor.get_stream_profiles()):
            return sensor
    return None


def _set(sensor: Any, option: Any, value: float, serial: str, what: str) -> float:
    r = sensor.get_option_range(option)
    v = min(max(float(value), r.min), r.max)
    if r.step > 0:
        v = r.min + round((v - r.min) / r.step) * r.step
    if abs(v - value) > max(r.step, 1e-9):
        log.warning("RealSense %s: %s %g is outside %g..%g; using %g", serial, what, value, r.min, r.max, v)
    sensor.set_option(option, v)
    return v


def apply_options(device: Any, config: Any, serial: str) -> dict[str, Any]:
    """Write `config`'s exposure, white balance, emitter and hardware sync (and global timestamps) to
    `device`; returns what was set, for `camera_info()`. Raises `RealSenseError` when the config asks
    for hardware sync from a camera that has none (unsynchronized frames would go unnoticed)."""
    import pyrealsense2 as rs

    o = rs.option
    done: dict[str, Any] = {}
    for sensor in device.query_sensors():
        if sensor.supports(o.global_time_enabled):
            sensor.set_option(o.global_time_enabled, 1)
            done["global_time"] = True
    color = sensor_for(device, rs.stream.color)
    if color is not None:
        done["exposure"] = _exposure(color, config.exposure, serial)
        done["white_balance"] = _white_balance(color, config.white_balance, serial)
    try:
        depth = device.first_depth_sensor()
    except RuntimeError:  # no depth sensor
        depth = None
    if depth is not None and depth.supports(o.emitter_enabled):
        depth.set_option(o.emitter_enabled, 1 if config.emitter else 0)
        done["emitter"] = bool(config.emitter)
    elif not config.emitter:
        log.warning("RealSense %s: emitter = false, but the camera has no emitter switch", serial)
    if depth is not None and depth.supports(o.inter_cam_sync_mode):
        depth.set_option(o.inter_cam_sync_mode, SYNC_MODES[config.hardware_sync])
        done["hardware_sync"] = config.hardware_sync
    elif config.hardware_sync != "none":
        raise RealSenseError(serial, f"hardware_sync = \"{config.hardware_sync}\", but this camera has no "
                             "inter-camera sync option (D415/D435/D455 have one; the L515 has none)")
    return done


def _exposure(sensor: Any, exposure: Any, serial: str) -> Any:
    import pyrealsense2 as rs

    o = rs.option
    if exposure == "auto":
        if sensor.supports(o.enable_auto_exposure):
            sensor.set_option(o.enable_auto_exposure, 1)
        return "auto"
    if not sensor.supports(o.exposure):
        raise RealSenseError(serial, "exposure is set, but the colour sensor has no exposure control")
    if sensor.supports(o.enable_auto_exposure):
        sensor.set_option(o.enable_auto_exposure, 0)
    per_unit = 1.0 if sensor.is_depth_sensor() else 100.0  # D405 colour: us; RGB sensors: 100 us
    unit = "us" if per_unit == 1.0 else "100 us units"
    return _set(sensor, o.exposure, float(exposure) / per_unit, serial, f"exposure ({unit})") * per_unit


def _white_balance(sensor: Any, white_balance: Any, serial: str) -> Any:
    import pyrealsense2 as rs

    o = rs.option
    if white_balance == "auto":
        if sensor.supports(o.enable_auto_white_balance):
            sensor.set_option(o.enable_auto_white_balance, 1)
        return "auto"
    if not sensor.supports(o.white_balance):
        raise RealSenseError(serial, "white_balance is set, but the colour sensor has no white balance control")
    if sensor.supports(o.enable_auto_white_balance):
        sensor.set_option(o.enable_auto_white_balance, 0)
    return _set(sensor, o.white_balance, float(white_balance), serial, "white balance (K)")
