"""A RealSense as a `rio.interfaces.Grabber` source: each `grab()` waits briefly for a frameset, skips to
the newest complete one and processes it (alignment, intrinsics, timestamps), so the core grab thread
(newest frame, reopen after a loss, publish on arrival) is the one every camera plugin uses.

A RealSense decides itself when it is lost: no frame for `frame_timeout_s`, or for the longer open
timeout while a fresh connection has delivered nothing yet (a camera may take a while to start
streaming). Until then a wait without a frame is simply None, never counted against it.
"""

from __future__ import annotations

from typing import Any

from rio import clock
from rio.interfaces.grabber import SourceLost

from .frames import Frame, FrameProcessor
from .sources.base import FrameSource

#: How long one wait on the source may block: bounds how quickly the grab thread notices stop().
WAIT_S = 0.1


class RealSenseStream:
    #: the core grab thread never declares the camera lost by counting empty waits: this does
    max_failed_reads = 1 << 30

    def __init__(self, source: FrameSource, processor: FrameProcessor, *, frame_timeout_s: float,
                 open_timeout_s: float):
        self.source, self.processor = source, processor
        self.serial = source.serial
        self.frame_timeout_s, self.open_timeout_s = frame_timeout_s, open_timeout_s
        self._t_last = clock.now()
        self._fresh = True  # no frame yet on this connection
        self.incomplete = 0  # framesets lacking a stream (skipped)

    def grab(self) -> Frame | None:
        frames = self.source.wait(WAIT_S)
        now = clock.now()
        if frames is None:
            limit = self.open_timeout_s if self._fresh else self.frame_timeout_s
            if now - self._t_last > limit:
                raise SourceLost(f"RealSense {self.serial}: no frame for {now - self._t_last:.1f} s (unplugged, "
                                 "or the USB link dropped)")
            return None
        proc = self.processor
        while (more := self.source.poll()) is not None:  # skip to the newest complete frameset
            if proc.complete(more) or not proc.complete(frames):
                frames = more
        if not proc.complete(frames):
            self.incomplete += 1
            return None
        self._t_last, self._fresh = now, False
        return proc.process(frames, now)

    def close(self) -> None:
        self.source.close()

    @property
    def clock_offset(self) -> Any:
        return self.processor.clock.offset
