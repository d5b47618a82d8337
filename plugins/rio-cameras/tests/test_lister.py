"""`rio cameras list` for webcams, read from a fake sysfs and /dev tree built in a temporary folder (the
lister takes its roots as arguments; this machine has no /sys/class/video4linux). The tree is laid out as
Linux lays it out for a UVC webcam: a picture node (index 0) and a metadata node (index 1) under one USB
interface, udev's by-id links, and a built-in camera without a by-id link."""

from __future__ import annotations

import sys
from pathlib import Path

from rio_cameras.opencv import capture
from rio_cameras.uvc.lister import from_probe, list_uvc_cameras

from rio.plugins.cameras import list_cameras


def node(sys_root: Path, name: str, product: str, index: str, usb_interface: Path | None = None) -> None:
    d = sys_root / "class" / "video4linux" / name
    d.mkdir(parents=True)
    (d / "name").write_text(product + "\n")
    (d / "index").write_text(index + "\n")
    if usb_interface is not None:
        (d / "device").symlink_to(usb_interface)


def fake_tree(root: Path) -> tuple[Path, Path]:
    sys_root, dev = root / "sys", root / "dev"
    usb = sys_root / "devices" / "pci0000:00" / "usb1" / "1-2"
    (usb / "1-2:1.0").mkdir(parents=True)
    (usb / "idVendor").write_text("046d\n")
    (usb / "idProduct").write_text("082d\n")
    node(sys_root, "video0", "HD Pro Webcam C920", "0", usb / "1-2:1.0")
    node(sys_root, "video1", "HD Pro Webcam C920", "1", usb / "1-2:1.0")
    node(sys_root, "video10", "Integrated Camera", "0")
    node(sys_root, "video2", "Loopback", "0")
    (dev / "v4l" / "by-id").mkdir(parents=True)
    for n in ("video0", "video1", "video2", "video10"):
        (dev / n).write_text("")
    for i in (0, 1):
        (dev / "v4l" / "by-id" / f"usb-046d_HD_Pro_Webcam_C920_A1B2C3-video-index{i}").symlink_to(f"../../video{i}")
    return sys_root, dev


def test_sysfs_tree_lists_picture_nodes_by_their_stable_path(tmp_path):
    sys_root, dev = fake_tree(tmp_path)
    found = list_uvc_cameras(str(sys_root), str(dev))
    assert [(d.id, d.model) for d in found] == [
        (str(dev / "v4l" / "by-id" / "usb-046d_HD_Pro_Webcam_C920_A1B2C3-video-index0"), "HD Pro Webcam C920"),
        (str(dev / "video2"), "Loopback"),
        (str(dev / "video10"), "Integrated Camera"),
    ]
    assert all(d.driver == "cameras.uvc" and d.select_field == "device" for d in found)
    assert found[0].note == f"{dev / 'video0'}, usb 046d:082d"
    assert found[0].station_line().endswith(f'device = "{found[0].id}"')


def test_no_video_devices_is_an_empty_list(tmp_path):
    assert list_uvc_cameras(str(tmp_path / "sys"), str(tmp_path / "dev")) == []


def test_other_systems_probe_a_few_indices(monkeypatch):
    class Cap:
        def __init__(self, index):
            self.index = index

        def isOpened(self):  # noqa: N802
            return self.index == 1

        def release(self):
            pass

    monkeypatch.setattr(capture, "open_video_capture", lambda target, api, params=(): Cap(target))
    assert [d.id for d in from_probe(3)] == ["1"]


def test_rio_cameras_list_runs_here_without_problems():
    devices, problems = list_cameras()
    assert not [p for p in problems if "rio-cameras" in p], problems
    if sys.platform.startswith("linux") and not Path("/sys/class/video4linux").exists():
        assert not [d for d in devices if d.driver == "cameras.uvc"]
