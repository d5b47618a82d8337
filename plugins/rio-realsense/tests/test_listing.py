"""`rio cameras list` for RealSense: nothing connected is an empty list, and a camera is described with
its driver, serial, model, firmware and modes from its sensors' stream profiles."""

from __future__ import annotations

import pytest
from rio_realsense.doctor import LIBUSB

from rio.plugins.cameras import CameraDevice, list_cameras
from rio.testing import skip_tests_without

skip_tests_without(LIBUSB)  # first: without libusb, importing pyrealsense2 raises ImportError (not a skip)
rs = pytest.importorskip("pyrealsense2")

from rio_realsense.listing import list_devices  # noqa: E402
from rio_realsense.sources.software import SoftwareSource  # noqa: E402


class StubContext:
    """A stub of `rs.context` whose `query_devices()` returns the given devices (here real software
    devices: their sensors and stream profiles are the SDK's own)."""

    def __init__(self, *devices):
        self.devices = list(devices)

    def query_devices(self):
        return self.devices


def test_no_camera_is_an_empty_list():
    if len(rs.context().query_devices()):
        pytest.skip("a RealSense camera is connected to this machine")
    assert list_devices() == []
    devices, problems = list_cameras()
    assert not [p for p in problems if "realsense" in p], problems
    assert not [d for d in devices if d.driver.startswith("realsense.")]


def test_a_camera_with_its_modes():
    d435 = SoftwareSource("123456789012", "d400", 640, 480, 30, True, (848, 480))
    l515 = SoftwareSource("f0000001", "l500", 960, 540, 30, True, (1024, 768))
    d435.open()
    l515.open()
    try:
        l515.device().update_info(rs.camera_info.usb_type_descriptor, "2.1")  # plugged into a USB 2 port
        found = list_devices(StubContext(d435.device(), l515.device()))
    finally:
        d435.close()
        l515.close()
    assert found == [
        CameraDevice("realsense.d400", "123456789012", "Intel RealSense D435", "serial", "0.0.0.0 (software)",
                     ("848x480@30 z16", "640x480@30 rgb8"), "USB 3.2"),
        CameraDevice("realsense.l515", "f0000001", "Intel RealSense L515", "serial", "0.0.0.0 (software)",
                     ("1024x768@30 z16", "960x540@30 rgb8"), "USB 2.1: use a USB 3 port and cable"),
    ]
    assert found[0].station_line() == 'driver = "realsense.d400"\nserial = "123456789012"'
