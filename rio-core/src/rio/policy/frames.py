"""Camera frames by reference: the policy node reads each frame of an observation straight from its
camera node's ring buffer instead of receiving it inside the request.

Under `shm` (and `thread`) the camera rings are readable in place from the policy node, so copying
~1 MB per camera into every request (and out again) is wasted work on the path from observation to
action. The request then carries each frame's timestamp; here the frame with exactly that timestamp is
found in the ring and handed to the policy in place: read-only views into the ring slot
(`RingBuffer.find_view`), checked when taken. Copying three 640x480 frames cost ~1 ms per request (even
read ahead, on a 2-core machine the copy competed with the control loop building the next observation);
the model's own preprocessing reads the pixels anyway, and reads them from there just as fast.

The views are that frame only while the camera has not come round to its slot again (a ring of N frames
keeps N-1: ~2 s of a 64-slot ring at 30 Hz), so after the forward pass the node asks each ring whether it
still holds them (`verify`); if not, the chunk is dropped as if the frame had been gone from the start. A
policy that keeps frames across calls (an observation history) must copy them (its preprocessing usually
does: tensors are copies).

A frame the camera has overwritten before it is taken (a policy node that falls that far behind) is never
replaced by another one: `take` raises `FrameGone`, and the node answers the request with an empty chunk,
which the client counts (`AsyncInference.stats()["frame_misses"]`) before asking again with a fresh
observation.
"""

from __future__ import annotations

from typing import Any

from rio.errors import ConfigError, FrameGone
from rio.runtime.ring_ref import SharedRing
from rio.schema import Camera

__all__ = ["CameraFrames", "FrameGone"]


class CameraFrames:
    """The camera rings of an observation layout, opened in the policy node; `close()` them."""

    def __init__(self, sources: dict[str, dict[str, Any]]):
        self.rings: dict[str, SharedRing] = {}
        self._taken: list[tuple[str, float, int]] = []
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
        """The frame `camera` published at `timestamp`, as the control loop's `Env` saw it (in place)."""
        ring = self.rings[camera].ring_buffer
        found = ring.find_view(timestamp)
        if found is None:
            raise FrameGone(camera, timestamp, ring.capacity)
        sample, seq = found
        self._taken.append((camera, timestamp, seq))
        return Camera.from_sample(sample)

    def forget(self) -> None:
        """Start a request afresh: the frames taken so far are no longer in use."""
        self._taken = []

    def verify(self) -> None:
        """After the frames taken since the last `verify` were used: raise `FrameGone` if any was overwritten
        meanwhile (what was computed from it may have seen another frame's pixels)."""
        taken, self._taken = self._taken, []
        for camera, timestamp, seq in taken:
            ring = self.rings[camera].ring_buffer
            if not ring.holds(seq):
                raise FrameGone(camera, timestamp, ring.capacity, "overwritten during the forward pass")

    def close(self) -> None:
        self._taken = []
        for ring in self.rings.values():
            ring.close()
        self.rings = {}
