"""On a real camera. Skipped by default (marker `hardware`) and unless a serial is given:

    RIO_REALSENSE_SERIAL=123456789012 pytest plugins/rio-realsense -m hardware
    # optional: RIO_REALSENSE_DRIVER=realsense.l515 (and RIO_REALSENSE_SIZE=960x540 for its colour)

Checks what the software camera cannot: the SDK's USB path, the camera's own timestamps and depth
scale, and that the lister sees the camera."""

from __future__ import annotations

import os

import numpy as np
import pytest
from rio_realsense.doctor import LIBUSB

from rio import clock
from rio.testing import lifecycle, skip_tests_without

pytestmark = pytest.mark.hardware

SERIAL = os.environ.get("RIO_REALSENSE_SERIAL", "")
DRIVER = os.environ.get("RIO_REALSENSE_DRIVER", "realsense.d400")
SIZE = tuple(int(x) for x in os.environ.get("RIO_REALSENSE_SIZE", "640x480").split("x"))


@pytest.fixture
def serial() -> str:
    if not SERIAL:
        pytest.skip("set RIO_REALSENSE_SERIAL to a connected camera's serial (`rio cameras list`)")
    skip_tests_without(LIBUSB)
    pytest.importorskip("pyrealsense2")
    return SERIAL


def camera(serial: str, **fields):
    from rio.plugins import Registry

    spec = Registry().find("rio_drivers", DRIVER, "driver")
    return spec.load()(spec.validate({"serial": serial, "width": SIZE[0], "height": SIZE[1], **fields}))


def test_the_lister_sees_it(serial):
    from rio_realsense.listing import list_devices

    found = {d.id: d for d in list_devices()}
    assert serial in found, list(found)
    dev = found[serial]
    print(dev)
    assert dev.driver == DRIVER and dev.firmware and f"{SIZE[0]}x{SIZE[1]}@30 rgb8" in dev.modes


def test_frames_with_aligned_depth(serial, collect):
    cam = camera(serial, depth=True)
    with lifecycle(cam):
        samples = collect(cam, 30, timeout=30)
        print(cam.camera_info())
    h, w = SIZE[1], SIZE[0]
    numbers = [int(s["frame_number"]) for s in samples]
    assert np.all(np.diff(numbers) > 0), numbers
    for s in samples:
        assert s["rgb"].shape == (h, w, 3) and s["depth"].shape == (h, w) and s["depth"].dtype == np.uint16
        assert 0 < s["depth_scale"] <= 0.001
        assert s["intrinsics"][0, 0] > 0 and s["t_frame"] <= clock.now() and 0 <= s["frame_age"] < 1.0
    assert np.mean(samples[-1]["depth"] > 0) > 0.2, "hardly any valid depth: is the lens covered?"
    assert samples[-1]["rgb"].std() > 1.0, "a flat colour image"


def test_manual_exposure(serial, collect):
    cam = camera(serial, exposure=10000, white_balance=4600)
    with lifecycle(cam):
        collect(cam, 5, timeout=30)
        settings = cam.camera_info()["settings"]
    assert settings["exposure"] == pytest.approx(10000, rel=0.05) and settings["white_balance"] == 4600
