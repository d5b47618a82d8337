"""`cameras.record3d` against a fake `record3d` module (a fake of the SDK object; the real protocol is not
exercised: there is no iPhone, usbmuxd or Record3D app here). The fake is a Record3DStream whose frames
arrive from its own thread through `on_new_frame`, as the library's do, with portrait RGB, lower-resolution
float depth in metres and the app's intrinsics for the RGB frame."""

from __future__ import annotations

import contextlib
import importlib.machinery
import sys
import threading
import types

import numpy as np
import pytest
from rio_cameras.errors import CameraError
from rio_cameras.record3d.driver import Record3dCamera
from rio_cameras.record3d.lister import list_record3d_devices

from rio.conformance.drivers import CameraConformance
from rio.testing import lifecycle, wait_until

RGB_W, RGB_H = 72, 96  # portrait, as the app streams
DEPTH_W, DEPTH_H = 24, 32


class Phone:
    """The fake's hardware: one iPhone (LiDAR unless `truedepth`), connected or not."""

    udid = "00008110-000A1B2C3D4E5F6A"

    def __init__(self, truedepth: bool = False):
        self.plugged, self.truedepth = True, truedepth
        self.streams: list = []

    def module(self) -> types.ModuleType:
        phone = self

        class Record3DStream:
            def __init__(self):
                self.on_new_frame = self.on_stream_stopped = None
                self._stop = threading.Event()

            @staticmethod
            def get_connected_devices():
                return [types.SimpleNamespace(udid=phone.udid, product_id=0x12A8)] if phone.plugged else []

            def connect(self, info):
                phone.streams.append(self)
                threading.Thread(target=self._run, daemon=True).start()
                return True

            def _run(self):
                while not self._stop.wait(1 / 60):
                    if not phone.plugged:
                        self.on_stream_stopped()
                        return
                    self.on_new_frame()

            def disconnect(self):
                self._stop.set()

            def get_rgb_frame(self):
                rgb = np.zeros((RGB_H, RGB_W, 3), np.uint8)
                rgb[:, : RGB_W // 2] = (255, 0, 0)  # left half red, already RGB
                return rgb

            def get_depth_frame(self):
                d = np.full((DEPTH_H, DEPTH_W), 0.75, np.float32)
                d[:, : DEPTH_W // 2] = 1.25
                return d

            def get_intrinsic_mat(self):
                return types.SimpleNamespace(fx=60.0, fy=60.0, tx=30.0, ty=47.5)

            def get_device_type(self):
                return 0 if phone.truedepth else 1

        r3d = types.ModuleType("record3d")
        r3d.__spec__ = importlib.machinery.ModuleSpec("record3d", None)
        r3d.Record3DStream = Record3DStream
        return r3d


@contextlib.contextmanager
def fake_record3d(phone: Phone):
    saved = sys.modules.get("record3d")
    sys.modules["record3d"] = phone.module()
    try:
        yield phone
    finally:
        if saved is None:
            sys.modules.pop("record3d", None)
        else:
            sys.modules["record3d"] = saved


@pytest.fixture
def phone():
    with fake_record3d(Phone()) as p:
        yield p


def next_sample(node, timeout: float = 10.0) -> dict:
    seen: list = []
    assert wait_until(lambda: seen.append(node.read_state()) or seen[-1] is not None, timeout=timeout)
    return seen[-1]


class TestRecord3dConformance(CameraConformance):
    """The camera kit with depth on cameras.record3d over the fake library (a fake of the SDK object; the
    real protocol is not exercised)."""

    driver = "cameras.record3d"
    config = {"width": 36, "height": 48}
    bad_config = {"device": "no-such-udid"}

    @contextlib.contextmanager
    def emulator(self):
        with fake_record3d(Phone()):
            yield None


def test_lidar_frames_map_to_the_contract(phone):
    """A fake of the SDK object; the real protocol is not exercised."""
    with lifecycle(Record3dCamera(width=36, height=48, device=phone.udid)) as node:
        s = next_sample(node)
    rgb, depth = s["rgb"], s["depth"]
    assert rgb.shape == (48, 36, 3) and tuple(rgb[10, 2]) == (255, 0, 0) and tuple(rgb[10, 30]) == (0, 0, 0)
    assert depth.shape == (48, 36) and depth.dtype == np.uint16 and s["depth_scale"] == 0.001
    assert depth[10, 2] == 1250 and depth[10, 30] == 750  # metres -> mm, resized with the picture
    np.testing.assert_allclose(s["intrinsics"], [[30, 0, 14.75], [0, 30, 23.5], [0, 0, 1]])  # RGB K, halved


def test_truedepth_frames_are_unmirrored():
    """A fake of the SDK object; the real protocol is not exercised."""
    with fake_record3d(Phone(truedepth=True)), lifecycle(Record3dCamera(width=72, height=96)) as node:
        s = next_sample(node)
    assert tuple(s["rgb"][10, 70]) == (255, 0, 0) and s["depth"][10, 70] == 1250  # red is now on the right
    assert s["intrinsics"][0, 2] == pytest.approx(RGB_W - 1 - 30.0)


def test_a_stopped_stream_is_named_and_reopened(phone):
    """A fake of the SDK object; the real protocol is not exercised."""
    with lifecycle(Record3dCamera(width=36, height=48, reopen_s=0.1)) as node:
        next_sample(node)
        phone.plugged = False
        assert wait_until(lambda: "the stream stopped" in (node.camera_info()["error"] or ""), timeout=10)
        assert wait_until(lambda: "no iPhone/iPad found" in (node.camera_info()["error"] or ""), timeout=10)
        phone.plugged = True
        assert wait_until(lambda: node.camera_info()["reopened"] == 1, timeout=10)
        next_sample(node)


def test_no_device_and_missing_library_are_named(phone, monkeypatch):
    phone.plugged = False
    with pytest.raises(CameraError, match="no iPhone/iPad found over USB.*USB Streaming mode"):
        with lifecycle(Record3dCamera()):
            pass
    monkeypatch.setitem(sys.modules, "record3d", None)
    with pytest.raises(ImportError, match=r"pip install 'rio-cameras\[record3d\]'"):
        with lifecycle(Record3dCamera()):
            pass
    assert list_record3d_devices() == []


def test_lister(phone):
    """A fake of the SDK object; the real protocol is not exercised."""
    [dev] = list_record3d_devices()
    assert (dev.driver, dev.id, dev.select_field) == ("cameras.record3d", phone.udid, "device")
    assert "0x12a8" in dev.model
