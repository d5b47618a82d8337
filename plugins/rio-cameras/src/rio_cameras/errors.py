"""The errors a camera driver raises: core's camera errors (`rio.interfaces.grabber`), so a caller (or a
test) catches every camera failure, from this plugin or another, without catching unrelated bugs."""

from __future__ import annotations

from rio.interfaces.grabber import CameraError, SourceFinished, SourceLost

__all__ = ["CameraError", "SourceLost", "SourceFinished"]
