"""Both drivers pass rio-core's camera conformance kit on the software source (pyrealsense2's software
device: the driver's real SDK path from syncer to `rs.align`). The start-up case opens a camera that is
not connected: no serial matches on this machine, so `open()` fails naming the serial."""

from __future__ import annotations

import pytest
from rio_realsense.doctor import LIBUSB

from rio.conformance.drivers import CameraConformance
from rio.testing import skip_tests_without

skip_tests_without(LIBUSB)  # first: without libusb, importing pyrealsense2 raises ImportError (not a skip)
pytest.importorskip("pyrealsense2")

NOT_CONNECTED = {"source": "device", "serial": "000000000000"}


class TestD400SoftwareWithDepth(CameraConformance):
    driver = "realsense.d400"
    config = {"source": "software", "serial": "kit-d435", "width": 128, "height": 96, "depth": True}
    bad_config = NOT_CONNECTED


class TestD400SoftwareColourOnly(CameraConformance):
    driver = "realsense.d400"
    config = {"source": "software", "serial": "kit-d435-rgb", "width": 96, "height": 64}
    bad_config = NOT_CONNECTED


class TestL515Software(CameraConformance):
    driver = "realsense.l515"
    config = {"source": "software", "serial": "kit-l515", "width": 96, "height": 54, "depth": True,
              "depth_width": 128, "depth_height": 96}
    bad_config = NOT_CONNECTED
