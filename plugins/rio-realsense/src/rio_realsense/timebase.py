"""Frame timestamps on the station clock.

A RealSense frame carries a timestamp from the camera (ms, in the SDK's "global time" domain: the
camera's hardware clock mapped to host time, or the hardware clock itself, or the host's arrival
time when metadata is off). None of these is `rio.clock` time, so it cannot be compared with an arm's
samples directly. We learn the offset between the two from the frames themselves: every frame that
arrives at host time `a` with camera time `h` bounds the offset from above (`a - h` includes the
transfer latency, which is never negative). The smallest `a - h` seen in a recent window is the
tightest such bound, so `t_frame = h + min(a - h)` is

- never later than the frame's arrival (the window holds the frame's own offset), and
- immune to jitter: a frame delayed by a busy USB bus or a descheduled thread only raises its own
  `a - h`, which the minimum ignores.

It is late by the smallest transfer latency in the window (a few ms over USB 3), the price of
needing no knowledge of the camera's time base. The window is finite so slow drift between the two
clocks is followed; a jump back in camera time or a change of time domain (a reconnected or reset
camera) starts over.
"""

from __future__ import annotations

from collections import deque


class FrameClock:
    """Maps camera timestamps (ms) to `rio.clock` seconds by tracking the minimum offset over
    `window_s` seconds of arrivals (a sliding-window minimum: O(1) per frame)."""

    def __init__(self, window_s: float = 5.0):
        if not window_s > 0:
            raise ValueError(f"window_s must be positive, got {window_s!r}")
        self.window_s = float(window_s)
        self.reset()

    def reset(self) -> None:
        #: (arrival, offset) with offsets strictly increasing from the front: the front is the minimum.
        self._window: deque[tuple[float, float]] = deque()
        self._domain: object = None
        self._last_camera_s: float | None = None
        self.resets = 0

    def map(self, camera_ms: float, arrival: float, domain: object = None) -> float:
        """The `rio.clock` time of a frame stamped `camera_ms` by the camera that arrived at `arrival`
        (a `rio.clock.now()` time). `domain` is the SDK's timestamp domain: a change resets the map."""
        camera_s = float(camera_ms) / 1000.0
        jumped_back = self._last_camera_s is not None and camera_s < self._last_camera_s - 1.0
        if domain != self._domain or jumped_back:
            self._window.clear()
            self._domain = domain
            self.resets += 1
        self._last_camera_s = camera_s
        offset = float(arrival) - camera_s
        w = self._window
        while w and w[-1][1] >= offset:
            w.pop()
        w.append((float(arrival), offset))
        while w[0][0] < arrival - self.window_s:
            w.popleft()
        return min(camera_s + w[0][1], float(arrival))  # min: rounding of large clock readings

    @property
    def offset(self) -> float | None:
        """The current estimate of (station clock - camera clock) in seconds, None before any frame."""
        return self._window[0][1] if self._window else None
