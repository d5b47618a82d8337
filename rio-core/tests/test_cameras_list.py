"""`rio cameras list`: the camera plugins' listers are called only there; a lister that fails (its SDK
missing) is one line naming its plugin and the others still list."""

from __future__ import annotations

import sys
import types

from rio.plugins import Registry
from rio.plugins.cameras import CameraDevice, list_cameras
from rio.plugins.hookspecs import hookimpl

FOUND = CameraDevice("vendor.cam", "1234", "Cam 1", firmware="5.1", modes=("640x480@30 rgb8",))


def found() -> list[CameraDevice]:
    return [FOUND]


def broken() -> list[CameraDevice]:
    raise ImportError("the vendor SDK is not installed: pip install vendor-sdk")


def test_listers_are_called_and_a_failing_one_is_named(monkeypatch):
    here = types.ModuleType("rio_test_camera_listers")
    here.found, here.broken = found, broken  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "rio_test_camera_listers", here)
    plugin = types.ModuleType("rio_test_camera_plugin")

    @hookimpl
    def rio_camera_listers():
        return ["rio_test_camera_listers:found", "rio_test_camera_listers:broken", "not-a-path"]

    plugin.rio_camera_listers = rio_camera_listers  # type: ignore[attr-defined]
    reg = Registry(load_entry_points=False)
    assert reg.register(plugin, name="camtest", dist="rio-camtest")
    devices, problems = list_cameras(reg)
    assert devices == [FOUND]
    assert len(problems) == 1 and "rio-camtest" in problems[0] and "pip install vendor-sdk" in problems[0]
    assert any("not-a-path" in p.message for p in reg.problems)
    assert FOUND.station_line() == 'driver = "vendor.cam"\nserial = "1234"'
