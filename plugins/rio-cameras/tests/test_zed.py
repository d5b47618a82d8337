"""`cameras.zed` against a fake `pyzed.sl` module (a fake of the SDK object; the real protocol is not
exercised: the ZED SDK needs an NVIDIA GPU and the camera). The fake answers the calls the driver makes
(InitParameters, Camera.open / grab / retrieve_image / retrieve_measure / get_camera_information, Mat) and
records the init parameters, so the tests check the driver's mapping to rgb / depth / depth_scale /
intrinsics and its error handling."""

from __future__ import annotations

import contextlib
import importlib.machinery
import sys
import time
import types

import numpy as np
import pytest
from rio_cameras.errors import CameraError
from rio_cameras.zed.driver import ZedCamera
from rio_cameras.zed.lister import list_zed_cameras

from rio.conformance.drivers import CameraConformance
from rio.testing import lifecycle, wait_until

W, H = 96, 54  # the fake sensor mode (frames are resized to the configured size)


class Zed:
    """The fake's hardware: one ZED 2i, serial 31234567, plugged or not."""

    serial = 31234567

    def __init__(self):
        self.plugged = True
        self.init = None

    def module(self) -> types.ModuleType:
        zed = self

        def enum(name, *members):
            return type(name, (), {m: f"{name}.{m}" for m in members})

        ERROR_CODE = enum("ERROR_CODE", "SUCCESS", "CAMERA_NOT_DETECTED", "FAILURE")  # noqa: N806

        class InitParameters:
            def set_from_serial_number(self, serial):
                self.serial = serial

        class Mat:
            def __init__(self):
                self.data = None

            def get_data(self):
                return self.data

        class Camera:
            def open(self, init):
                zed.init = init
                if not zed.plugged or getattr(init, "serial", zed.serial) != zed.serial:
                    return ERROR_CODE.CAMERA_NOT_DETECTED
                return ERROR_CODE.SUCCESS

            def get_camera_information(self):
                left = types.SimpleNamespace(fx=80.0, fy=81.0, cx=47.5, cy=26.5)
                calib = types.SimpleNamespace(left_cam=left)
                return types.SimpleNamespace(camera_configuration=types.SimpleNamespace(calibration_parameters=calib))

            def grab(self, runtime):
                time.sleep(1 / 60)
                return ERROR_CODE.SUCCESS if zed.plugged else ERROR_CODE.CAMERA_NOT_DETECTED

            def retrieve_image(self, mat, view):
                bgra = np.zeros((H, W, 4), np.uint8)
                bgra[..., 1] = 180  # green
                bgra[..., 3] = 255
                mat.data = bgra

            def retrieve_measure(self, mat, measure):
                depth = np.full((H, W), 2000.0, np.float32)  # mm (the driver asks for UNIT.MILLIMETER)
                depth[0, 0], depth[0, 1] = np.nan, np.inf  # the SDK's "no reading"
                mat.data = depth

            def close(self):
                pass

            @staticmethod
            def get_device_list():
                return [types.SimpleNamespace(serial_number=zed.serial, camera_model="ZED2i",
                                              camera_state="AVAILABLE")] if zed.plugged else []

        sl = types.ModuleType("pyzed.sl")
        sl.ERROR_CODE = ERROR_CODE
        sl.RESOLUTION = enum("RESOLUTION", "AUTO", "HD2K", "HD1080", "HD720", "VGA")
        sl.DEPTH_MODE = enum("DEPTH_MODE", "NONE", "NEURAL", "ULTRA", "PERFORMANCE")
        sl.UNIT = enum("UNIT", "MILLIMETER", "METER")
        sl.VIEW = enum("VIEW", "LEFT", "RIGHT")
        sl.MEASURE = enum("MEASURE", "DEPTH")
        sl.InitParameters, sl.Camera, sl.Mat = InitParameters, Camera, Mat
        sl.RuntimeParameters = lambda: object()
        return sl


@contextlib.contextmanager
def fake_pyzed(zed: Zed):
    saved = {k: sys.modules.get(k) for k in ("pyzed", "pyzed.sl")}
    pkg = types.ModuleType("pyzed")
    pkg.__spec__ = importlib.machinery.ModuleSpec("pyzed", None, is_package=True)
    pkg.sl = zed.module()
    sys.modules.update({"pyzed": pkg, "pyzed.sl": pkg.sl})
    try:
        yield zed
    finally:
        for k, v in saved.items():
            if v is None:
                sys.modules.pop(k, None)
            else:
                sys.modules[k] = v


@pytest.fixture
def zed():
    with fake_pyzed(Zed()) as z:
        yield z


def next_sample(node, timeout: float = 10.0) -> dict:
    seen: list = []
    assert wait_until(lambda: seen.append(node.read_state()) or seen[-1] is not None, timeout=timeout)
    return seen[-1]


class TestZedConformance(CameraConformance):
    """The camera kit with depth on cameras.zed over the fake pyzed (a fake of the SDK object; the real
    protocol is not exercised)."""

    driver = "cameras.zed"
    config = {"width": 48, "height": 27, "depth": True}
    bad_config = {"serial": 1}

    @contextlib.contextmanager
    def emulator(self):
        with fake_pyzed(Zed()):
            yield None


def test_left_view_and_depth_map_to_the_contract(zed):
    """A fake of the SDK object; the real protocol is not exercised."""
    with lifecycle(ZedCamera(width=48, height=27, depth=True, resolution="HD720", serial=zed.serial)) as node:
        s = next_sample(node)
    init = zed.init
    assert (init.camera_resolution, init.depth_mode, init.coordinate_units) == \
        ("RESOLUTION.HD720", "DEPTH_MODE.NEURAL", "UNIT.MILLIMETER")
    assert init.camera_fps == 30 and init.serial == zed.serial
    assert tuple(s["rgb"][5, 5]) == (0, 180, 0) and s["rgb"].shape == (27, 48, 3)
    d = s["depth"]
    assert d.dtype == np.uint16 and d.shape == (27, 48) and float(d[10, 10]) * s["depth_scale"] == pytest.approx(2.0)
    assert d[0, 0] == 0  # NaN / inf are "no reading", not a distance
    # the calibration at the 96x54 sensor mode, scaled to the published 48x27
    np.testing.assert_allclose(s["intrinsics"], [[40, 0, 23.5], [0, 40.5, 13], [0, 0, 1]])


def test_without_depth_the_sdk_computes_none(zed):
    """A fake of the SDK object; the real protocol is not exercised."""
    with lifecycle(ZedCamera(width=48, height=27)) as node:
        s = next_sample(node)
    assert zed.init.depth_mode == "DEPTH_MODE.NONE" and "depth" not in s


def test_unknown_modes_and_open_failures_are_named(zed):
    """A fake of the SDK object; the real protocol is not exercised."""
    with pytest.raises(CameraError, match="no resolution 'HD9K'; it offers AUTO, HD1080"):
        with lifecycle(ZedCamera(resolution="HD9K")):
            pass
    zed.plugged = False
    with pytest.raises(CameraError, match="could not open the camera: ERROR_CODE.CAMERA_NOT_DETECTED"):
        with lifecycle(ZedCamera()):
            pass


def test_a_lost_camera_is_reopened(zed):
    """A fake of the SDK object; the real protocol is not exercised."""
    with lifecycle(ZedCamera(width=48, height=27, reopen_s=0.1)) as node:
        next_sample(node)
        zed.plugged = False
        assert wait_until(lambda: "CAMERA_NOT_DETECTED" in (node.camera_info()["error"] or ""), timeout=10)
        zed.plugged = True
        assert wait_until(lambda: node.camera_info()["reopened"] == 1, timeout=10)
        next_sample(node)


def test_missing_pyzed_says_how_to_get_the_zed_sdk(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyzed", None)
    monkeypatch.setitem(sys.modules, "pyzed.sl", None)
    with pytest.raises(ImportError, match="pyzed is not on PyPI: it comes with the Stereolabs ZED SDK.*get_python_api"):
        with lifecycle(ZedCamera()):
            pass
    assert list_zed_cameras() == []


def test_lister(zed):
    """A fake of the SDK object; the real protocol is not exercised."""
    [dev] = list_zed_cameras()
    assert (dev.driver, dev.id, dev.model, dev.select_field) == ("cameras.zed", str(zed.serial), "ZED2i", "serial")
    assert ZedCamera.Config.model_validate({"serial": dev.id}).serial == zed.serial  # the listed line works
