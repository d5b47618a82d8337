"""`cameras.oak` against a fake of the depthai v3 module (a fake of the SDK object; the real protocol is
not exercised: depthai, its XLink USB transport and an OAK device cannot run here). The fake answers
exactly the calls the driver makes (Device, Pipeline, Camera.requestOutput, StereoDepth aligned to CAM_A,
Sync, output queues, readCalibration) and records them, so these tests check the driver's mapping from
SDK frames to rgb / depth / depth_scale / intrinsics, its pipeline wiring, and its lost-device handling."""

from __future__ import annotations

import contextlib
import importlib.machinery
import sys
import time
import types

import numpy as np
import pytest
from rio_cameras.oak.driver import OakCamera
from rio_cameras.oak.lister import list_oak_cameras

from rio.conformance.drivers import CameraConformance
from rio.testing import lifecycle, wait_until


class Board:
    """The fake's hardware: one OAK (id 14442C10D13EABCE00), plugged or not, and the calls it saw."""

    device_id = "14442C10D13EABCE00"

    def __init__(self):
        self.plugged = True
        self.calls: list[tuple] = []

    def module(self) -> types.ModuleType:
        board = self

        class Output:
            def __init__(self, kind, size=None):
                self.kind, self.size = kind, size

            def link(self, target):
                board.calls.append(("link", self.kind, target))

            def createOutputQueue(self, maxSize=16, blocking=True):  # noqa: N802, N803 - depthai's spelling
                board.calls.append(("queue", self.kind, maxSize, blocking))
                return Queue(self)

        class ImgFrame:
            class Type:
                BGR888i = "BGR888i"

            def __init__(self, array):
                self.array = array

            def getCvFrame(self):  # noqa: N802
                return self.array

            def getFrame(self):  # noqa: N802
                return self.array

        class Queue:
            def __init__(self, output):
                self.output = output

            def get(self):
                time.sleep(1 / 60)
                if not board.plugged:
                    raise RuntimeError("Communication exception - possible device error/misconfiguration")
                w, h = board.size
                bgr = np.zeros((h, w, 3), np.uint8)
                bgr[..., 2] = 200  # red, in BGR order
                colour = ImgFrame(bgr)
                if self.output.kind != "sync":
                    return colour
                return {"rgb": colour, "depth": ImgFrame(np.full((h, w), 1500, np.uint16))}

        class Camera:
            def build(self, socket):
                board.calls.append(("camera", socket))
                return self

            def requestOutput(self, size, type=None, fps=None):  # noqa: N802, A002
                board.calls.append(("requestOutput", tuple(size), type, fps))
                board.size = tuple(size)
                return Output("rgb", size)

        class StereoDepth:
            def __init__(self):
                self.depth = Output("depth")

            def build(self, autoCreateCameras=False):  # noqa: N803
                board.calls.append(("stereo", autoCreateCameras))
                return self

            def setDepthAlign(self, socket):  # noqa: N802
                board.calls.append(("setDepthAlign", socket))

            def setOutputSize(self, w, h):  # noqa: N802
                board.calls.append(("setOutputSize", w, h))

        class Sync:
            def __init__(self):
                self.inputs = {"rgb": "sync.rgb", "depth": "sync.depth"}
                self.out = Output("sync")

        class Calibration:
            def getCameraIntrinsics(self, socket, w, h):  # noqa: N802
                return [[float(w), 0.0, w / 2], [0.0, float(w), h / 2], [0.0, 0.0, 1.0]]

        class DeviceInfo:
            def __init__(self, device_id=""):
                self.device_id, self.name = device_id, "1.2"
                self.state = types.SimpleNamespace(name="X_LINK_UNBOOTED")

            def getDeviceId(self):  # noqa: N802
                return self.device_id

        class Device:
            def __init__(self, info=None):
                if not board.plugged or (info is not None and info.device_id != board.device_id):
                    raise RuntimeError("No available devices")
                board.calls.append(("device", None if info is None else info.device_id))

            @staticmethod
            def getAllAvailableDevices():  # noqa: N802
                return [DeviceInfo(board.device_id)] if board.plugged else []

            def readCalibration(self):  # noqa: N802
                return Calibration()

            def close(self):
                board.calls.append(("close",))

        class Pipeline:
            def __init__(self, device):
                self.device = device

            def create(self, cls):
                return cls()

            def start(self):
                board.calls.append(("start",))

            def stop(self):
                board.calls.append(("stop",))

        dai = types.ModuleType("depthai")
        dai.__spec__ = importlib.machinery.ModuleSpec("depthai", None)
        dai.Device, dai.DeviceInfo, dai.Pipeline, dai.ImgFrame = Device, DeviceInfo, Pipeline, ImgFrame
        dai.node = types.SimpleNamespace(Camera=Camera, StereoDepth=StereoDepth, Sync=Sync)
        dai.CameraBoardSocket = types.SimpleNamespace(CAM_A="CAM_A", CAM_B="CAM_B", CAM_C="CAM_C")
        return dai


@contextlib.contextmanager
def fake_depthai(board: Board):
    saved = sys.modules.get("depthai")
    sys.modules["depthai"] = board.module()
    try:
        yield board
    finally:
        if saved is None:
            sys.modules.pop("depthai", None)
        else:
            sys.modules["depthai"] = saved


@pytest.fixture
def board():
    with fake_depthai(Board()) as b:
        yield b


def next_sample(node, timeout: float = 10.0) -> dict:
    seen: list = []
    assert wait_until(lambda: seen.append(node.read_state()) or seen[-1] is not None, timeout=timeout)
    return seen[-1]


class TestOakConformance(CameraConformance):
    """The camera kit with depth on cameras.oak over the fake depthai (a fake of the SDK object; the real
    protocol is not exercised)."""

    driver = "cameras.oak"
    config = {"width": 64, "height": 48, "depth": True}
    bad_config = {"device_id": "NOT-CONNECTED"}

    @contextlib.contextmanager
    def emulator(self):
        with fake_depthai(Board()):
            yield None


def test_colour_and_aligned_depth_map_to_the_contract(board):
    """A fake of the SDK object; the real protocol is not exercised."""
    with lifecycle(OakCamera(width=64, height=48, rate_hz=30, depth=True, device_id=board.device_id)) as node:
        s = next_sample(node)
    assert tuple(s["rgb"][0, 0]) == (200, 0, 0)  # BGR from getCvFrame, published as RGB
    assert s["depth"].dtype == np.uint16 and float(s["depth"][0, 0]) * s["depth_scale"] == pytest.approx(1.5)
    np.testing.assert_allclose(s["intrinsics"], [[64, 0, 32], [0, 64, 24], [0, 0, 1]])  # calibration at 64x48
    calls = board.calls
    assert ("device", board.device_id) in calls
    assert ("requestOutput", (64, 48), "BGR888i", 30.0) in calls
    assert ("stereo", True) in calls and ("setDepthAlign", "CAM_A") in calls and ("setOutputSize", 64, 48) in calls
    assert ("link", "rgb", "sync.rgb") in calls and ("link", "depth", "sync.depth") in calls
    assert ("queue", "sync", 1, False) in calls
    assert calls[-2:] == [("stop",), ("close",)]


def test_colour_only_uses_no_stereo(board):
    """A fake of the SDK object; the real protocol is not exercised."""
    with lifecycle(OakCamera(width=32, height=24)) as node:
        s = next_sample(node)
    assert set(s) == {"rgb", "intrinsics", "timestamp", "frame_age", "frame_index"}
    assert not [c for c in board.calls if c[0] in ("stereo", "setDepthAlign")]
    assert ("queue", "rgb", 1, False) in board.calls


def test_a_lost_device_is_reopened(board):
    """A fake of the SDK object; the real protocol is not exercised."""
    with lifecycle(OakCamera(width=32, height=24, reopen_s=0.1)) as node:
        next_sample(node)
        board.plugged = False
        assert wait_until(lambda: "reopen failed" in (node.camera_info()["error"] or ""), timeout=10)
        assert "Communication exception" in node.camera_info()["error"]
        board.plugged = True
        assert wait_until(lambda: node.camera_info()["reopened"] == 1, timeout=10)
        next_sample(node)


def test_missing_depthai_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "depthai", None)
    with pytest.raises(ImportError, match=r"cameras\.oak needs .*depthai.*pip install 'rio-cameras\[oak\]'"):
        with lifecycle(OakCamera()):
            pass


def test_lister(board, monkeypatch):
    """A fake of the SDK object; the real protocol is not exercised."""
    [dev] = list_oak_cameras()
    assert (dev.driver, dev.id, dev.select_field) == ("cameras.oak", board.device_id, "device_id")
    assert "1.2" in dev.note
    board.plugged = False
    assert list_oak_cameras() == []
    monkeypatch.setitem(sys.modules, "depthai", None)  # not installed: nothing, not an error
    assert list_oak_cameras() == []
