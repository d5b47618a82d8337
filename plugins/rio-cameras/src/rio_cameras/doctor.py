"""The system check `rio doctor` runs for this plugin: video devices this user may not open."""

from __future__ import annotations

import glob
import os


def video_device_problem(dev_root: str = "/dev") -> str | None:
    """None when every /dev/video* can be opened for reading and writing by this user (or there are none:
    a camera may be unplugged); else the devices and the group to join (usually 'video')."""
    from .uvc.device import group_hint

    devices = sorted(glob.glob(os.path.join(dev_root, "video*")))
    denied = [d for d in devices if not os.access(d, os.R_OK | os.W_OK)]
    if not denied:
        return None
    return f"no permission on {', '.join(denied)}: {group_hint(denied[0])}"
