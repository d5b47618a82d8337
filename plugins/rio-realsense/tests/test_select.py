"""Which camera a driver opens, and the errors when it cannot choose, without cameras.

`StubContext` is a stub of the SDK's `rs.context`: its `query_devices()` returns stand-ins answering
`get_info` / `supports` / `query_sensors` like connected cameras. (pyrealsense2's software devices would
be the real thing, but `software_device.add_to(context)` does not make them appear in
`query_devices()` in 2.59, so the SDK's own enumeration cannot be fed without hardware.)"""

from __future__ import annotations

import pytest
from rio_realsense.doctor import LIBUSB

from rio.testing import skip_tests_without

skip_tests_without(LIBUSB)  # first: without libusb, importing pyrealsense2 raises ImportError (not a skip)
rs = pytest.importorskip("pyrealsense2")

from rio_realsense.errors import RealSenseError  # noqa: E402
from rio_realsense.sources.device import DeviceSource  # noqa: E402
from rio_realsense.sources.modes import Mode, offered, pick_depth  # noqa: E402
from rio_realsense.sources.select import select_device  # noqa: E402


class StubProfile:
    def __init__(self, stream, fmt, w, h, fps):
        self._s, self._f, self.w, self.h, self._fps = stream, fmt, w, h, fps

    def stream_type(self):
        return self._s

    def format(self):
        return self._f

    def fps(self):
        return self._fps

    def is_video_stream_profile(self):
        return True

    def as_video_stream_profile(self):
        return self

    def width(self):
        return self.w

    def height(self):
        return self.h


class StubSensor:
    def __init__(self, profiles):
        self.profiles = profiles

    def get_stream_profiles(self):
        return self.profiles


D435_MODES = [StubProfile(rs.stream.color, rs.format.rgb8, w, h, f) for w, h in ((640, 480), (1280, 720))
              for f in (15, 30)] + [StubProfile(rs.stream.depth, rs.format.z16, w, h, f)
                                    for w, h in ((640, 480), (848, 480), (1280, 720)) for f in (15, 30, 90)]


class StubDevice:
    def __init__(self, serial, name="Intel RealSense D435", line="D400", profiles=D435_MODES):
        self.info = {rs.camera_info.serial_number: serial, rs.camera_info.name: name,
                     rs.camera_info.product_line: line}
        self.sensors = [StubSensor(profiles)]

    def supports(self, what):
        return what in self.info

    def get_info(self, what):
        return self.info[what]

    def query_sensors(self):
        return self.sensors


class StubContext:
    """A stub of `rs.context`: only `query_devices()`."""

    def __init__(self, *devices):
        self.devices = list(devices)

    def query_devices(self):
        return self.devices


def test_by_serial_or_the_only_one():
    a, b = StubDevice("111"), StubDevice("222", "Intel RealSense L515", "L500")
    assert select_device([a, b], "111", "d400").device is a
    assert select_device([a, b], "", "d400").device is a  # the only D400
    assert select_device([a, b], "", "l500").device is b


def test_unknown_serial_names_every_connected_one():
    devices = [StubDevice("111"), StubDevice("222", "Intel RealSense D405")]
    with pytest.raises(RealSenseError, match=r"RealSense 999: not connected \(connected: 111 \(Intel RealSense "
                                             r"D435\), 222 \(Intel RealSense D405\)\)") as e:
        select_device(devices, "999", "d400")
    assert e.value.serial == "999"


def test_several_cameras_and_no_serial():
    with pytest.raises(RealSenseError, match=r"2 D400 cameras connected \(111 .*, 222 .*\): set `serial`"):
        select_device([StubDevice("111"), StubDevice("222")], "", "d400")


def test_none_connected():
    with pytest.raises(RealSenseError, match=r"no D400 camera connected \(connected: none\).*source = \"software\""):
        select_device([], "", "d400")


def test_wrong_product_line_names_the_driver_to_use():
    with pytest.raises(RealSenseError, match=r'is a Intel RealSense L515 \(L500 product line\).*realsense.l515'):
        select_device([StubDevice("333", "Intel RealSense L515", "L500")], "333", "d400")


def test_the_device_source_reports_the_same_errors_before_touching_usb():
    ctx = StubContext(StubDevice("111"), StubDevice("222"))
    for serial, match in (("", "2 D400 cameras connected"), ("999", "999: not connected")):
        with pytest.raises(RealSenseError, match=match):
            DeviceSource(serial, "d400", 640, 480, 30, True, context=ctx).open()


def test_a_mode_the_camera_lacks_is_named_with_what_it_offers():
    ctx = StubContext(StubDevice("111"))
    with pytest.raises(RealSenseError, match=r"111: Intel RealSense D435 has no colour mode 640x480@60 rgb8; "
                                             r"it offers 640x480@15/30, 1280x720@15/30"):
        DeviceSource("111", "d400", 640, 480, 60, False, context=ctx).open()
    with pytest.raises(RealSenseError, match=r"no depth mode 424x240@30 z16; it offers 640x480@15/30/90"):
        DeviceSource("111", "d400", 640, 480, 30, True, (424, 240), context=ctx).open()


def test_depth_mode_for_a_colour_mode():
    modes = [Mode("depth", "z16", 30, w, h) for w, h in ((1024, 768), (640, 480), (320, 240))]
    assert pick_depth(modes, 640, 480, 30) == Mode("depth", "z16", 30, 640, 480)  # the same size
    assert pick_depth(modes, 960, 540, 30) == Mode("depth", "z16", 30, 1024, 768)  # L515: closest width
    assert pick_depth(modes, 640, 480, 60) is None
    assert pick_depth(modes, 640, 480, 30, want=(320, 240)) == Mode("depth", "z16", 30, 320, 240)
    assert offered(modes, "depth", "z16") == "320x240@30, 640x480@30, 1024x768@30"
    assert str(Mode("color", "rgb8", 30, 640, 480)) == "640x480@30 rgb8"
