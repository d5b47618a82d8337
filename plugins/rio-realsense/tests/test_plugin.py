"""The plugin as a user meets it: registered drivers with their presets, the camera lister and doctor
requirements, config checked when a station loads, no pyrealsense2 imported until a camera opens, the
doctor's udev check, and the packaged station's observation carrying the software camera's frames."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from pydantic import ValidationError
from rio_realsense.doctor import LIBUSB, libusb_problem, udev_problem
from rio_realsense.driver import RealSenseCamera

from rio.plugins import Registry
from rio.station.load import load_station
from rio.testing import skip_tests_without


def test_drivers_station_lister_and_requirements_are_registered():
    reg = Registry()
    assert not [p for p in reg.problems if "realsense" in str(p.plugin)], reg.problems
    drivers = {s.name: s for s in reg.specs("rio_drivers") if s.plugin == "rio-realsense"}
    assert {n: s.preset for n, s in drivers.items()} == {"realsense.d400": {"product_line": "d400"},
                                                         "realsense.l515": {"product_line": "l500"}}
    assert all(s.kind == "camera" and s.load() is RealSenseCamera for s in drivers.values())
    assert [s.name for s in reg.specs("rio_stations") if s.plugin == "rio-realsense"] == ["realsense-fake"]
    assert ("rio-realsense", "rio_realsense.listing:list_devices") in list(reg.camera_listers())
    from rio_realsense.plugin import rio_requirements

    reqs = rio_requirements()
    assert [r.module for r in reqs] == ["pyrealsense2", None, None]
    assert reqs[0].install == "pip install pyrealsense2"
    assert "99-realsense-libusb.rules" in reqs[2].install


def test_listing_and_configuring_import_no_sdk():
    code = ("import sys; from rio.plugins import Registry; r = Registry(); "
            "[s.config_model() for s in r.specs('rio_drivers')]; "
            "import rio_realsense.driver, rio_realsense.plugin; "
            "rio_realsense.driver.RealSenseCamera(serial='1', depth=True); "
            "print('pyrealsense2' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.stdout.strip() == "False", out.stderr


def test_config_is_checked():
    with pytest.raises(ValidationError, match="whole numbers"):
        RealSenseCamera(rate_hz=29.97)
    with pytest.raises(ValidationError, match="set both depth_width and depth_height"):
        RealSenseCamera(depth_width=640)
    with pytest.raises(ValidationError, match="kelvin"):
        RealSenseCamera(white_balance=100)
    with pytest.raises(ValidationError, match="hardware_sync"):
        RealSenseCamera(hardware_sync="leader")
    with pytest.raises(ValidationError, match="shorter than two frames"):
        RealSenseCamera(rate_hz=6, frame_timeout_s=0.2)
    with pytest.raises(ValueError, match="fixes it to 'l500'"):
        Registry().find("rio_drivers", "realsense.l515", "driver").validate({"product_line": "d400"})
    c = RealSenseCamera(exposure=8000, white_balance=4500).config
    assert (c.exposure, c.white_balance, c.source, c.serial) == (8000.0, 4500.0, "device", "")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="udev and libusb are Linux checks")
def test_doctor_says_when_udev_rules_are_missing(tmp_path):
    assert udev_problem(euid=0) is None  # root opens cameras without rules
    empty = tmp_path / "sys"
    empty.mkdir()
    problem = udev_problem(rules_dirs=(str(tmp_path),), sys_usb=str(empty), euid=1000)
    assert problem is not None and "99-realsense-libusb.rules" in problem
    (tmp_path / "99-realsense-libusb.rules").write_text("# Intel's rules\n")
    assert udev_problem(rules_dirs=(str(tmp_path),), sys_usb=str(empty), euid=1000) is None
    assert libusb_problem() in (None, "libusb-1.0 is not installed (pyrealsense2 needs it): "
                                      "sudo apt install libusb-1.0-0")


def test_the_packaged_station_shows_the_software_camera():
    skip_tests_without(LIBUSB)
    pytest.importorskip("pyrealsense2")
    from rio import ServerManager
    from rio.station import make_station
    from rio.testing import wait_until

    st = load_station("realsense-fake")
    cam = st.components["wrist_camera"]
    assert cam.driver == "realsense.d400" and cam.config.source == "software" and cam.config.depth
    servers, clients, env = make_station("realsense-fake")
    with ServerManager(servers), env:
        first = env.reset().observation.cameras["wrist"]
        assert first.rgb.shape == (240, 320, 3) and first.rgb.dtype == np.uint8
        assert first.depth.shape == (240, 320)
        d = first.depth  # metres: the plate and the wall
        assert np.all(np.isclose(d, 0.8, atol=0.002) | np.isclose(d, 1.0, atol=0.002))
        np.testing.assert_allclose(first.meta["intrinsics"][2], [0, 0, 1])
        t0 = first.meta["timestamp"]
        assert wait_until(lambda: env.get_state().observation.cameras["wrist"].meta["timestamp"] > t0, timeout=10)
