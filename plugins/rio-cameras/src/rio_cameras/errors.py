"""The errors a camera driver raises. One base class so a caller (or a test) can catch every camera
failure without catching unrelated bugs."""

from __future__ import annotations


class CameraError(RuntimeError):
    """A camera could not be opened or configured; the message names the camera and what to try."""


class SourceLost(CameraError):
    """An open camera stopped delivering (unplugged, stream ended, SDK said so). The grab thread
    closes it and reopens it; the node stays up."""
