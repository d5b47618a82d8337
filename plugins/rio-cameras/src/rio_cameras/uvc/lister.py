"""V4L2 cameras for `rio cameras list`, read from sysfs and /dev without opening any device (opening
would disturb a camera another program is streaming from, and needs permissions listing should not).

Linux: each `/sys/class/video4linux/videoN` with its `name` (the USB product string) and `index` (a UVC
camera creates index 0 for pictures and index 1 for metadata: only index-0 nodes are listed), selected by
its stable `/dev/v4l/by-id/...` link where udev made one, else by `/dev/videoN`. The USB vendor:product
comes from the parent USB device's `idVendor` / `idProduct`. Modes are not listed: they need the device
open (`v4l2-ctl -d DEV --list-formats-ext`).

macOS / Windows: no such tree; a short probe opens indices 0..3 with the OS's capture API.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from rio.plugins.cameras import CameraDevice

DRIVER = "cameras.uvc"


def list_uvc_cameras(sys_root: str = "/sys", dev_root: str = "/dev", probe: int = 4) -> list[CameraDevice]:
    if sys.platform.startswith("linux"):
        return from_sysfs(Path(sys_root), Path(dev_root))
    return from_probe(probe)


def _read(path: Path) -> str:
    try:
        return path.read_text().strip()
    except OSError:
        return ""


def _usb_ids(node: Path) -> str:
    """'046d:085c' from the USB device above the interface that `node/device` points at."""
    try:
        d = (node / "device").resolve()
    except OSError:
        return ""
    for up in (d, *d.parents[:3]):
        vendor, product = _read(up / "idVendor"), _read(up / "idProduct")
        if vendor and product:
            return f"{vendor}:{product}"
    return ""


def _by_id(dev_root: Path) -> dict[str, str]:
    """videoN -> its /dev/v4l/by-id link (the index-0 one when several point at it)."""
    links: dict[str, str] = {}
    folder = dev_root / "v4l" / "by-id"
    if not folder.is_dir():
        return links
    for link in sorted(folder.iterdir()):
        target = os.path.basename(os.path.realpath(link))
        if target not in links or link.name.endswith("index0"):
            links[target] = str(link)
    return links


def from_sysfs(sys_root: Path, dev_root: Path) -> list[CameraDevice]:
    classdir = sys_root / "class" / "video4linux"
    if not classdir.is_dir():
        return []
    by_id = _by_id(dev_root)
    out = []
    nodes = sorted((p for p in classdir.iterdir() if p.name.startswith("video")),
                   key=lambda p: int("".join(ch for ch in p.name if ch.isdigit()) or 0))
    for node in nodes:
        if _read(node / "index") not in ("", "0"):
            continue  # a metadata (or second) node of a camera listed already
        dev = dev_root / node.name
        usb = _usb_ids(node)
        note = ", ".join(x for x in (str(dev), f"usb {usb}" if usb else "",
                                     "" if dev.exists() else "no device node") if x)
        out.append(CameraDevice(driver=DRIVER, id=by_id.get(node.name, str(dev)), select_field="device",
                                model=_read(node / "name") or node.name, note=note))
    return out


def from_probe(count: int) -> list[CameraDevice]:
    """Open indices 0..count-1 briefly with the OS's capture API (there is no device tree to read)."""
    from ..opencv import capture
    from .driver import platform_backend

    backend = platform_backend("auto")
    out = []
    for i in range(count):
        cap = capture.open_video_capture(i, capture.backend_id(backend))
        try:
            if cap.isOpened():
                out.append(CameraDevice(driver=DRIVER, id=str(i), select_field="device", model=f"camera {i}",
                                        note=f"found by probing with {backend}"))
        finally:
            cap.release()
    return out
