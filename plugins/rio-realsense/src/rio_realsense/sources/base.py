"""The frame source seam: what the driver needs from wherever framesets come from.

The driver (alignment, intrinsics, depth scale, timestamps, reconnection) is written once against this
interface. A real camera is an `rs.pipeline` (`DeviceSource`); a software camera is an
`rs.software_device` whose frames an emulator injects through an `rs.syncer` (`SoftwareSource`):
`rs.pipeline` cannot be started on a software device, so the pipeline cannot be the seam itself.
Both hand over genuine pyrealsense2 framesets and an `rs.device`, so everything past this line runs
the SDK's own code on either.
"""

from __future__ import annotations

from typing import Any, Protocol


class FrameSource(Protocol):
    """One opened camera. `open()` raises `RealSenseError` naming the serial when it cannot start."""

    #: The camera's serial number (known once opened).
    serial: str

    def open(self) -> None:
        """Find the camera, configure its streams and start them."""

    def device(self) -> Any:
        """The `rs.device` being streamed (sensors, options, info, depth scale)."""

    def wait(self, timeout_s: float) -> Any:
        """The next frameset, or None when none arrived within `timeout_s`. May raise when the
        camera is gone."""

    def poll(self) -> Any:
        """A frameset already waiting, or None (never blocks): lets the driver skip to the newest."""

    def close(self) -> None:
        """Stop streaming and release the camera; safe to call twice or after a failed open()."""
