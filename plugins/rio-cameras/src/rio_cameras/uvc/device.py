"""Which device `device = ...` means, checked before OpenCV is asked (OpenCV's own failure is a bare
`isOpened() == False`, which cannot tell "unplugged" from "no permission").

An index (0, "2") is passed to OpenCV as an index. A path (`/dev/video2`, or better the stable
`/dev/v4l/by-id/usb-<vendor>_<model>_<serial>-video-index0`, which survives replugging and reboots where
the number may change) is resolved to its `/dev/videoN` each time the camera is (re)opened.
"""

from __future__ import annotations

import os

from ..errors import CameraError


def resolve_device(device: int | str) -> tuple[int | str, str]:
    """(what to hand OpenCV, how messages name it). Raises CameraError naming the fix for a path that does
    not exist or cannot be opened by this user."""
    if isinstance(device, int) or str(device).strip().isdigit():
        index = int(device)
        return index, f"index {index}"
    path = str(device)
    if not os.path.exists(path):
        raise CameraError(f"{path} does not exist: the camera is unplugged or the path is wrong "
                          "(`rio cameras list` shows the connected cameras and their /dev/v4l/by-id paths)")
    real = os.path.realpath(path)
    if not os.access(real, os.R_OK | os.W_OK):
        raise CameraError(f"no permission to open {real}: {group_hint(real)}")
    return real, path if real == path else f"{path} -> {real}"


def group_hint(path: str) -> str:
    """The usual fix for a video device this user may not open: join the group that owns it."""
    try:
        import grp

        group = grp.getgrgid(os.stat(path).st_gid).gr_name
    except (ImportError, KeyError, OSError):
        group = "video"
    return f"add yourself to the '{group}' group (sudo usermod -aG {group} $USER), then log in again"
