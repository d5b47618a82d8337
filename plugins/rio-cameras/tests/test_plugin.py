"""The plugin as a user meets it: its drivers, station, camera listers and doctor requirements are
registered; listing them imports neither OpenCV nor a camera SDK; `rio doctor`'s check of /dev/video*."""

from __future__ import annotations

import os
import subprocess
import sys

from rio_cameras.doctor import video_device_problem

from rio.plugins import Registry
from rio.plugins.requirements import evaluate

DRIVERS = {"cameras.uvc": "UvcCamera", "cameras.stream": "StreamCamera", "cameras.oak": "OakCamera",
           "cameras.zed": "ZedCamera", "cameras.record3d": "Record3dCamera"}


def test_drivers_station_listers_and_requirements_are_registered():
    reg = Registry()
    assert not [p for p in reg.problems if "camera" in str(p.plugin)], reg.problems
    drivers = {s.name: s for s in reg.specs("rio_drivers") if s.plugin == "rio-cameras"}
    assert {n: s.load().__name__ for n, s in drivers.items()} == DRIVERS
    assert {s.kind for s in drivers.values()} == {"camera"}
    assert [s.name for s in reg.specs("rio_stations") if s.plugin == "rio-cameras"] == ["cameras-fake"]
    listers = [path for dist, path in reg.camera_listers() if dist == "rio-cameras"]
    assert [p.split(":")[1] for p in listers] == ["list_uvc_cameras", "list_oak_cameras", "list_zed_cameras",
                                                  "list_record3d_devices"]
    reqs = reg.requirements()["rio-cameras"]
    assert [r.module for r in reqs] == ["cv2", None, "depthai", "record3d", "pyzed"]
    install = {r.module: r.install for r in reqs}
    assert install["depthai"] == "pip install 'rio-cameras[oak]'" and "ZED SDK" in install["pyzed"]
    statuses = [evaluate(r) for r in reqs]  # rio doctor's evaluation, on this machine
    assert statuses[0].present and statuses[1].checked


def test_listing_imports_no_opencv_or_sdk():
    code = ("import sys; from rio.plugins import Registry; r = Registry(); "
            "[s.config_model() for s in r.specs('rio_drivers')]; "
            "print(sorted(m for m in ('cv2', 'depthai', 'pyzed', 'record3d') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.stdout.strip() == "[]", (out.stdout, out.stderr)


def test_doctor_names_video_devices_this_user_cannot_open(tmp_path, monkeypatch):
    assert video_device_problem(str(tmp_path)) is None  # no camera plugged in: fine
    (tmp_path / "video0").write_text("")
    assert video_device_problem(str(tmp_path)) is None
    real_access = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: False if str(p).endswith("video0") else real_access(p, mode))
    problem = video_device_problem(str(tmp_path))
    assert problem is not None and f"{tmp_path / 'video0'}" in problem and "sudo usermod -aG" in problem
