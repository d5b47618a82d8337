"""A software RealSense: an `rs.software_device` with a depth and a colour sensor, fed by an emulator
thread at the configured rate and synced by an `rs.syncer`.

The frames are genuine SDK frames (profiles with intrinsics, depth-to-colour extrinsics, a depth-units
option, frame numbers and global-time timestamps), so the driver's alignment, intrinsics, depth-scale
and timestamp code runs exactly as on a camera. It is how the tests exercise the driver, and how a user
tries a station without a camera (`source = "software"`). The picture is `rio_realsense.scene`.

The sensors also register the options a D400 has (auto exposure, exposure, white balance, emitter,
inter-camera sync, global time), so setting them goes through the SDK's option calls; they change
nothing in the picture.

Unplugging is simulated per serial (`unplug()` / `replug()`): an unplugged camera stops delivering
frames and cannot be opened, which is what the driver sees when a USB cable is pulled.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Any

from .. import scene
from ..errors import RealSenseError

_unplugged: set[str] = set()
_lock = threading.Lock()


def unplug(serial: str) -> None:
    """Pull the software camera `serial`'s cable: no more frames, and opening it fails until `replug()`."""
    with _lock:
        _unplugged.add(serial)


def replug(serial: str) -> None:
    with _lock:
        _unplugged.discard(serial)


def plugged(serial: str) -> bool:
    with _lock:
        return serial not in _unplugged


@dataclass(frozen=True)
class SoftwareModel:
    """What a software camera imitates: name and product line as the SDK reports them, fields of view
    (degrees, horizontal), colour's offset from the depth origin (m, to the right) and depth units."""

    name: str
    product_line: str
    color_hfov: float
    depth_hfov: float
    baseline_m: float
    depth_units: float
    emitter: bool  # has an IR projector the driver can switch (D400)
    sync: bool  # has the inter-camera sync option (D400)
    #: the colour stream's lens distortion as its SDK reports it (rs.distortion name, 5 coefficients); the
    #: scene is rendered as a pinhole camera, so the emulated models report zeros (a D435's colour does)
    color_distortion: tuple[str, tuple[float, ...]] = ("inverse_brown_conrady", (0.0,) * 5)


MODELS = {
    "d400": SoftwareModel("Intel RealSense D435", "D400", 69.0, 87.0, 0.015, 0.001, True, True),
    "l500": SoftwareModel("Intel RealSense L515", "L500", 70.0, 70.0, 0.01, 0.00025, False, False,
                          ("brown_conrady", (0.0,) * 5)),
}
FIRMWARE = "0.0.0.0 (software)"
DEFAULT_SERIAL = "software"
#: The camera clock's reading (ms) when the emulator starts: far from the station clock on purpose.
CAMERA_CLOCK_BASE_MS = 1_700_000_000_000.0


class SoftwareSource:
    def __init__(self, serial: str, product_line: str, width: int, height: int, fps: int, depth: bool,
                 depth_size: tuple[int, int] | None = None):
        self.serial = serial or DEFAULT_SERIAL
        self.model = MODELS[product_line]
        self.fps, self.depth = int(fps), depth
        self.color_cam = scene.Pinhole.from_hfov(width, height, self.model.color_hfov)
        dw, dh = depth_size or (width, height)
        self.depth_cam = scene.Pinhole.from_hfov(dw, dh, self.model.depth_hfov)
        self._dev: Any = None
        self._sensors: list[Any] = []
        self._syncer: Any = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.injected = 0

    # -- FrameSource ------------------------------------------------------------------------------------
    def open(self) -> None:
        import pyrealsense2 as rs

        if not plugged(self.serial):
            raise RealSenseError(self.serial, "not connected (the software camera is unplugged)")
        m = self.model
        dev = rs.software_device()
        for key, value in ((rs.camera_info.name, m.name), (rs.camera_info.serial_number, self.serial),
                           (rs.camera_info.firmware_version, FIRMWARE), (rs.camera_info.product_line, m.product_line),
                           (rs.camera_info.usb_type_descriptor, "3.2")):
            dev.register_info(key, value)
        depth_sensor = dev.add_sensor("Stereo Module" if m.product_line == "D400" else "L500 Depth Sensor")
        color_sensor = dev.add_sensor("RGB Camera")
        self._depth_profile = depth_sensor.add_video_stream(
            _stream(rs, rs.stream.depth, 1, self.depth_cam, self.fps, rs.format.z16, 2))
        self._color_profile = color_sensor.add_video_stream(
            _stream(rs, rs.stream.color, 2, self.color_cam, self.fps, rs.format.rgb8, 3, m.color_distortion))
        to_color = rs.extrinsics()
        to_color.rotation = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        to_color.translation = [-m.baseline_m, 0.0, 0.0]  # colour sits baseline_m to the right
        self._depth_profile.register_extrinsics_to(self._color_profile, to_color)
        _add_options(rs, m, depth_sensor, color_sensor)
        self._syncer = rs.syncer()
        self._sensors = [color_sensor] + ([depth_sensor] if self.depth else [])
        color_sensor.open(self._color_profile)
        if self.depth:
            depth_sensor.open(self._depth_profile)
        for s in self._sensors:
            s.start(self._syncer)
        self._dev, self._depth_sensor, self._color_sensor = dev, depth_sensor, color_sensor
        self._stop.clear()
        self._thread = threading.Thread(target=self._emulate, name=f"rio-realsense-software-{self.serial}",
                                        daemon=True)
        self._thread.start()

    def device(self) -> Any:
        return self._dev

    def wait(self, timeout_s: float) -> Any:
        ok, frames = self._syncer.try_wait_for_frames(max(1, int(timeout_s * 1000)))
        return frames if ok else None

    def poll(self) -> Any:
        frames = self._syncer.poll_for_frames()
        return frames if frames else None

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        for s in self._sensors:
            for step in (s.stop, s.close):
                try:
                    step()
                except RuntimeError:  # not started / already closed
                    pass
        self._sensors, self._dev, self._syncer = [], None, None

    # -- the emulator -----------------------------------------------------------------------------------
    def _emulate(self) -> None:
        import pyrealsense2 as rs

        period = 1.0 / self.fps
        t0 = time.monotonic()
        t_next = t0
        n = 0
        while not self._stop.wait(max(0.0, t_next - time.monotonic())):
            t_next += period
            if time.monotonic() > t_next:  # fell behind (a loaded machine): skip, as a camera drops frames
                t_next = time.monotonic() + period
            if not plugged(self.serial):
                continue
            t_s = n / self.fps
            stamp = CAMERA_CLOCK_BASE_MS + (time.monotonic() - t0) * 1000.0
            if self.depth:
                z = scene.depth_m(self.depth_cam, t_s)
                pixels = (z / self.model.depth_units).round().astype("uint16")
                self._depth_sensor.on_video_frame(
                    _frame(rs, pixels, 2, stamp, n, self._depth_profile, depth_units=self.model.depth_units))
            rgb = scene.color(self.color_cam, t_s, cam_x=self.model.baseline_m)
            self._color_sensor.on_video_frame(_frame(rs, rgb, 3, stamp, n, self._color_profile))
            n += 1
            self.injected = n


def _stream(rs: Any, kind: Any, uid: int, cam: scene.Pinhole, fps: int, fmt: Any, bpp: int,
            distortion: tuple[str, tuple[float, ...]] = ("none", (0.0,) * 5)) -> Any:
    k = rs.intrinsics()
    k.width, k.height, k.fx, k.fy, k.ppx, k.ppy = cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy
    k.model, k.coeffs = getattr(rs.distortion, distortion[0]), list(distortion[1])
    s = rs.video_stream()
    s.type, s.index, s.uid, s.width, s.height, s.fps, s.bpp, s.fmt = kind, 0, uid, cam.width, cam.height, fps, bpp, fmt
    s.intrinsics = k
    return s


def _frame(rs: Any, pixels: Any, bpp: int, stamp_ms: float, number: int, profile: Any,
           depth_units: float | None = None) -> Any:
    f = rs.software_video_frame()
    f.pixels = pixels  # copied by the SDK
    f.bpp, f.stride = bpp, pixels.shape[1] * bpp
    f.timestamp, f.domain, f.frame_number = stamp_ms, rs.timestamp_domain.global_time, number
    f.profile = profile.as_video_stream_profile()
    if depth_units is not None:
        f.depth_units = depth_units
    return f


def _range(rs: Any, lo: float, hi: float, step: float, default: float) -> Any:
    r = rs.option_range()  # set by name: the positional order is easy to get wrong
    r.min, r.max, r.step, r.default = lo, hi, step, default
    return r


def _add_options(rs: Any, m: SoftwareModel, depth_sensor: Any, color_sensor: Any) -> None:
    """The options a camera of this model has, with its ranges and defaults (RGB exposure in 100 us
    units, as the D400's RGB sensor counts it)."""
    o = rs.option
    depth_sensor.add_read_only_option(o.depth_units, m.depth_units)
    color = [(o.enable_auto_exposure, 0, 1, 1, 1), (o.exposure, 1, 10000, 1, 156),
             (o.enable_auto_white_balance, 0, 1, 1, 1), (o.white_balance, 2800, 6500, 10, 4600),
             (o.global_time_enabled, 0, 1, 1, 1)]
    depth = [(o.global_time_enabled, 0, 1, 1, 1)]
    if m.product_line == "D400":
        depth += [(o.enable_auto_exposure, 0, 1, 1, 1), (o.exposure, 1, 165000, 1, 8500)]
    if m.emitter:
        depth.append((o.emitter_enabled, 0, 1, 1, 1))
    if m.sync:
        depth.append((o.inter_cam_sync_mode, 0, 260, 1, 0))
    for sensor, options in ((color_sensor, color), (depth_sensor, depth)):
        for opt, lo, hi, step, default in options:
            sensor.add_option(opt, _range(rs, lo, hi, step, default), True)
