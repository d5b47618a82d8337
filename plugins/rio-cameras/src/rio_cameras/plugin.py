"""rio-cameras' plugin module (entry point group `rio`): camera driver specs, the packaged station, the
camera listers behind `rio cameras list`, and what `rio doctor` checks. Specs and import paths only:
nothing here imports OpenCV or a camera SDK."""

from __future__ import annotations

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

from .sdk import ZED_INSTALL

_P = "rio_cameras"


@hookimpl
def rio_drivers() -> list[Spec]:
    return [
        Spec("cameras.uvc", "camera", f"{_P}.uvc.driver:UvcCamera",
             "USB (UVC) webcam through OpenCV/V4L2: MJPG, negotiated mode read back, reopens when replugged"),
        Spec("cameras.stream", "camera", f"{_P}.stream.driver:StreamCamera",
             "RTSP / HTTP MJPEG / GStreamer / video file (looped) through OpenCV, or url = 'test:pattern'"),
        Spec("cameras.oak", "camera", f"{_P}.oak.driver:OakCamera",
             "Luxonis OAK (depthai v3): colour with aligned stereo depth, factory intrinsics"),
        Spec("cameras.zed", "camera", f"{_P}.zed.driver:ZedCamera",
             "Stereolabs ZED (pyzed from the ZED SDK): left colour with SDK depth"),
        Spec("cameras.record3d", "camera", f"{_P}.record3d.driver:Record3dCamera",
             "iPhone/iPad RGB-D (LiDAR or TrueDepth) from the Record3D app over USB"),
    ]


@hookimpl
def rio_stations() -> list[Spec]:
    return [Spec("cameras-fake", "station", f"{_P}:stations/cameras-fake.toml",
                 "a fake arm with a cameras.stream camera showing a moving test pattern, scripted teleop "
                 "(no hardware)",
                 formerly=("cameras-virtual",))]


@hookimpl
def rio_camera_listers() -> list[str]:
    return [f"{_P}.uvc.lister:list_uvc_cameras", f"{_P}.oak.lister:list_oak_cameras",
            f"{_P}.zed.lister:list_zed_cameras", f"{_P}.record3d.lister:list_record3d_devices"]


@hookimpl
def rio_requirements() -> list[Requirement]:
    return [
        Requirement("cv2", "pip install opencv-python-headless", "cameras.uvc and cameras.stream (OpenCV capture)"),
        Requirement(None, "sudo usermod -aG video $USER", "opening /dev/video* (webcams)",
                    check=f"{_P}.doctor:video_device_problem"),
        Requirement("depthai", "pip install 'rio-cameras[oak]'", "cameras.oak (Luxonis OAK)"),
        Requirement("record3d", "pip install 'rio-cameras[record3d]'", "cameras.record3d (iPhone over USB)"),
        Requirement("pyzed", ZED_INSTALL, "cameras.zed (Stereolabs ZED)"),
    ]
