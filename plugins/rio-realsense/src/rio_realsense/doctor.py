"""`rio doctor` checks for RealSense cameras on Linux: the libusb library pyrealsense2's USB backend loads,
and Intel's udev rules, without which only root may open a camera (the SDK then finds no device, which
looks like a missing camera rather than a permission problem). Elsewhere both checks pass."""

from __future__ import annotations

import glob
import os
import sys

from rio.machine.system_needs import SystemNeed

RULES_DIRS = ("/etc/udev/rules.d", "/lib/udev/rules.d", "/usr/lib/udev/rules.d", "/run/udev/rules.d")
INTEL_VENDOR = "8086"


#: The library pyrealsense2's extension links (Linux): without it `import pyrealsense2` raises ImportError.
LIBUSB = SystemNeed("libusb-1.0-0", library="libusb-1.0.so.0", purpose="pyrealsense2, which links it")


def libusb_problem() -> str | None:
    """None when libusb-1.0 can be loaded (or this is not Linux), else what to install."""
    if LIBUSB.problem() is None:
        return None
    return f"libusb-1.0 is not installed (pyrealsense2 needs it): sudo apt install {LIBUSB.package}"


def realsense_rules(dirs: tuple[str, ...] = RULES_DIRS) -> list[str]:
    """The RealSense udev rule files installed (Intel's is 99-realsense-libusb.rules)."""
    return sorted(p for d in dirs for p in glob.glob(os.path.join(d, "*realsense*.rules")))


def connected_nodes(sys_usb: str = "/sys/bus/usb/devices") -> list[str]:
    """/dev/bus/usb nodes of the Intel USB devices connected (RealSense cameras among them)."""
    nodes = []
    for dev in glob.glob(os.path.join(sys_usb, "*")):
        try:
            with open(os.path.join(dev, "idVendor")) as f:
                if f.read().strip() != INTEL_VENDOR:
                    continue
            with open(os.path.join(dev, "busnum")) as f:
                bus = int(f.read())
            with open(os.path.join(dev, "devnum")) as f:
                num = int(f.read())
        except (OSError, ValueError):
            continue
        nodes.append(f"/dev/bus/usb/{bus:03d}/{num:03d}")
    return sorted(nodes)


def udev_problem(rules_dirs: tuple[str, ...] = RULES_DIRS, sys_usb: str = "/sys/bus/usb/devices",
                 euid: int | None = None) -> str | None:
    """None when the rules are installed (or this is not Linux, or the user is root), else the fix. A
    connected Intel device this user cannot open is named. (Arguments: for tests.)"""
    euid = os.geteuid() if euid is None and hasattr(os, "geteuid") else euid
    if not sys.platform.startswith("linux") or euid == 0:
        return None
    rules = realsense_rules(rules_dirs)
    denied = [n for n in connected_nodes(sys_usb) if os.path.exists(n) and not os.access(n, os.R_OK | os.W_OK)]
    if rules and not denied:
        return None
    problems = [] if rules else ["the RealSense udev rules (99-realsense-libusb.rules) are not installed"]
    if denied:
        problems.append(f"no permission on {', '.join(denied)}")
    return f"{'; '.join(problems)}: only root can open the cameras; install Intel's rules (the install line) and replug"
