"""The one error this plugin raises. It names the camera by serial number because a station often has
two or three identical RealSense cameras, and "no frames" alone does not say which one to replug."""

from __future__ import annotations

from rio.errors import RioError


class RealSenseError(RioError):
    """A RealSense camera could not be found, opened or configured, or stopped delivering frames.

    `serial` is the camera's serial number ('' when none was configured and the camera could not be
    chosen); `what` says what happened, in words a user can act on."""

    def __init__(self, serial: str, what: str):
        self.serial, self.what = serial, what
        who = f"RealSense {serial}" if serial else "RealSense (no serial set)"
        super().__init__(f"{who}: {what}")
