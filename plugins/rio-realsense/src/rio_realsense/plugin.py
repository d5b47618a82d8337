"""rio-realsense's plugin module (entry point group `rio`): driver specs, the packaged station, the
camera lister behind `rio cameras list`, and what `rio doctor` checks. Specs and import paths only:
nothing here imports pyrealsense2."""

from __future__ import annotations

from rio.plugins.hookspecs import hookimpl
from rio.plugins.requirements import Requirement
from rio.plugins.specs import Spec

_P = "rio_realsense"
_DRIVER = f"{_P}.driver:RealSenseCamera"
UDEV_INSTALL = ("sudo curl -fsSL https://raw.githubusercontent.com/IntelRealSense/librealsense/master/config/"
                "99-realsense-libusb.rules -o /etc/udev/rules.d/99-realsense-libusb.rules && "
                "sudo udevadm control --reload-rules && sudo udevadm trigger")


@hookimpl
def rio_drivers() -> list[Spec]:
    return [
        Spec("realsense.d400", "camera", _DRIVER,
             "Intel RealSense D405/D415/D435/D455: colour with depth aligned to it, by serial "
             '(or source = "software")', preset={"product_line": "d400"}),
        Spec("realsense.l515", "camera", _DRIVER,
             'Intel RealSense L515 (lidar): colour with depth aligned to it, by serial (or source = "software"); '
             "needs pyrealsense2 < 2.55 (later SDKs dropped the L515)",
             preset={"product_line": "l500"}),
    ]


@hookimpl
def rio_stations() -> list[Spec]:
    return [Spec("realsense-fake", "station", f"{_P}:stations/realsense-fake.toml",
                 "a fake arm with a software RealSense D435 (colour + aligned depth), scripted teleop (no hardware)",
                 formerly=("realsense-virtual",))]


@hookimpl
def rio_camera_listers() -> list[str]:
    return [f"{_P}.listing:list_devices"]


@hookimpl
def rio_requirements() -> list[Requirement]:
    return [
        Requirement("pyrealsense2", "pip install pyrealsense2",
                    "realsense.d400 / realsense.l515 (Intel RealSense SDK 2)"),
        Requirement(None, "sudo apt install libusb-1.0-0", "USB access of pyrealsense2 (Linux)",
                    check=f"{_P}.doctor:libusb_problem"),
        Requirement(None, UDEV_INSTALL, "opening RealSense cameras without root (Linux udev rules)",
                    check=f"{_P}.doctor:udev_problem"),
    ]
