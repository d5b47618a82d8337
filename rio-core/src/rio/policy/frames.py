"""Camera frames by reference: the policy node reads each frame of an observation straight from its
camera node's ring buffer instead of receiving it inside the request.

Under `shm` (and `thread`) the camera rings are readable in place from the policy node, so copying
~1 MB per camera into every request (and out again) is wasted work on the path from observation to
action. The request then carries each frame's timestamp; here the frame with exactly that timestamp is
found in the ring (`RingBuffer.find`) and copied once, under the ring's slot check.

Reading three 640x480 frames costs ~1 ms, so the node also reads ahead: right after publishing a chunk
it copies each camera's newest frame (`read_ahead`), while the control loop takes in that chunk and builds
its next observation, which most likely names those very frames; `take` then only compares timestamps.
A copy read ahead is handed out once, and only for its own timestamp; any other frame is found in the ring.

A frame the camera has overwritten by then (a ring of N frames keeps N-1; a policy node that falls that
far behind) is never replaced by another one: `take` raises `FrameGone`, and the node answers the request
with an empty chunk, which the client counts (`AsyncInference.stats()["frame_misses"]`) before asking
again with a fresh observation.
"""

from __future__ import annotations

from typing import Any

from ..errors import ConfigError
from ..ring_ref import SharedRing
from ..schema import Camera


class FrameGone(Exception):
    """The referenced frame is no longer in its camera's ring buffer."""

    def __init__(self, camera: str, timestamp: float, capacity: int):
        self.camera, self.timestamp = camera, timestamp
        super().__init__(f"camera '{camera}': frame {timestamp:.6f} is no longer in its ring buffer (the camera "
                         f"overwrote it; the ring keeps {capacity - 1} frames)")


class CameraFrames:
    """The camera rings of an observation layout, opened in the policy node; `close()` them."""

    def __init__(self, sources: dict[str, dict[str, Any]]):
        self.rings: dict[str, SharedRing] = {}
        self._ahead: dict[str, dict[str, Any]] = {}
        try:
            for name, ref in sources.items():
                self.rings[name] = SharedRing(ref)
        except ConfigError as e:
            self.close()
            raise ConfigError(f"{e}: start the policy node with frames='copy' to receive its frames in each "
                              "request") from e
        except BaseException:
            self.close()
            raise

    def take(self, camera: str, timestamp: float) -> Camera:
        """The frame `camera` published at `timestamp`, as the control loop's `Env` saw it."""
        ahead = self._ahead.pop(camera, None)
        if ahead is not None and float(ahead["timestamp"]) == timestamp:
            return Camera.from_sample(ahead)
        ring = self.rings[camera].ring_buffer
        sample = ring.find(timestamp)
        if sample is None:
            raise FrameGone(camera, timestamp, ring.capacity)
        return Camera.from_sample(sample)

    def read_ahead(self) -> None:
        """Copy each camera's newest frame now (checked, as any read), for the next `take` to find. Only
        an optimization: a camera that cannot be read now is left to `take`, which reports it."""
        for name, ring in self.rings.items():
            try:
                self._ahead[name] = ring.ring_buffer.get()
            except Exception:
                self._ahead.pop(name, None)

    def close(self) -> None:
        self._ahead = {}
        for ring in self.rings.values():
            ring.close()
        self.rings = {}
