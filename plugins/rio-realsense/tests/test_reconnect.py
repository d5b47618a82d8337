"""A camera that goes away (the software camera unplugged: no more frames, and it cannot be opened)
leaves the node running, publishing nothing, with an error naming the serial in the log;
when it comes back the node reconnects, says so, and frames resume. Served by the runtime on the
thread middleware, as in a station."""

from __future__ import annotations

import logging
import uuid

import pytest
from rio_realsense.doctor import LIBUSB

from rio import ServerManager, connect, serve
from rio.testing import lifecycle, skip_tests_without, wait_until

skip_tests_without(LIBUSB)  # first: without libusb, importing pyrealsense2 raises ImportError (not a skip)
pytest.importorskip("pyrealsense2")

from rio_realsense.driver import RealSenseCamera  # noqa: E402
from rio_realsense.errors import RealSenseError  # noqa: E402
from rio_realsense.sources import software  # noqa: E402


def test_unplug_and_replug_while_served(serial, caplog):
    caplog.set_level(logging.INFO, logger="rio_realsense")
    fields = {"source": "software", "serial": serial, "width": 64, "height": 48, "depth": True,
              "reconnect_s": 0.2}
    station = f"rs-{uuid.uuid4().hex[:8]}"
    with ServerManager("thread", [serve(RealSenseCamera, name="wrist_camera", **fields)], station=station), \
            connect(RealSenseCamera, "thread", name="wrist_camera", station=station, **fields) as cam:
        assert wait_until(lambda: cam.camera_info()["frames"] > 3, timeout=20)
        before = cam.camera_info()  # (a loaded machine may already have stalled the camera once)
        software.unplug(serial)
        try:
            assert wait_until(lambda: not cam.camera_info()["connected"], timeout=20)
            lost = [r for r in caplog.records if r.levelno == logging.ERROR]
            assert lost and f"RealSense {serial}: no frame for" in lost[0].getMessage()
            # alive and answering, publishing nothing new
            info = cam.camera_info()
            assert info["lost"] > before["lost"] and "unplugged" in info["error"]
            t_gone = float(cam.get_state()["timestamp"])
            assert wait_until(lambda: "not connected" in (cam.camera_info()["error"] or ""))  # retrying
            assert float(cam.get_state()["timestamp"]) == t_gone
        finally:
            software.replug(serial)
        assert wait_until(lambda: float(cam.get_state()["timestamp"]) > t_gone, timeout=20)
        info = cam.camera_info()
        assert info["connected"] and info["reopened"] > before["reopened"] and info["error"] is None
        assert any(f"RealSense {serial}: reopened" in r.getMessage() for r in caplog.records)


def test_unplugged_at_start_is_an_error_naming_the_serial(serial):
    software.unplug(serial)
    try:
        with pytest.raises(RealSenseError, match=f"RealSense {serial}: not connected"):
            with lifecycle(RealSenseCamera(source="software", serial=serial)):
                pass
    finally:
        software.replug(serial)
