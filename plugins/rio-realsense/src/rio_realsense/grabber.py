"""The grab thread: takes framesets from a source as they come, keeps only the newest processed frame,
and survives the camera going away.

Why a thread of our own: a RealSense delivers at its own pace (and stalls when the USB link does), and
the node's loop, which also answers API calls under the node's lock, must never wait on it. The
node's `read_state()` takes whatever is newest here, at once, and gets None when nothing new arrived,
so a frame is published at most once and a missing one is not published at all.

When frames stop (a pulled cable, a crashed USB link, a frameset the SDK could not deliver) for
`frame_timeout_s`, or the source raises, the loss is logged as a `RealSenseError` naming the serial and
the source is closed; the thread then tries to connect again every `reconnect_s` and says in the log
when it succeeded. The node stays up throughout, publishing nothing while the camera is gone.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

from rio import clock

from .errors import RealSenseError
from .frames import Frame, FrameProcessor
from .sources.base import FrameSource

#: How long one wait on the source may block: bounds how quickly stop() is noticed.
_WAIT_S = 0.1

Connect = Callable[[], tuple[FrameSource, FrameProcessor]]


class Grabber:
    def __init__(self, connect: Connect, serial: str, *, frame_timeout_s: float, reconnect_s: float,
                 log: logging.Logger):
        self._connect = connect
        self.serial = serial
        self.frame_timeout_s, self.reconnect_s = frame_timeout_s, reconnect_s
        self.log = log
        self._source: FrameSource | None = None
        self._processor: FrameProcessor | None = None
        self._lock = threading.Lock()
        self._latest: Frame | None = None
        self._seq = self._taken = 0
        self._stop = threading.Event()
        self._first = threading.Event()
        self._thread: threading.Thread | None = None
        self._t_last = 0.0
        self._t_lost: float | None = None
        self._open_timeout_s = frame_timeout_s
        #: no frame yet from this connection: a camera may take a while to start streaming
        self._fresh = True
        #: counters and the last problem, for camera_info()
        self.frames = self.incomplete = self.lost = self.reconnects = 0
        self.error: str | None = None

    # -- lifecycle (the node's thread) ------------------------------------------------------------------
    def start(self, open_timeout_s: float) -> None:
        """Connect (errors propagate: the node fails to start, naming the camera), start the thread and
        wait for the first frame."""
        self._source, self._processor = self._connect()
        self.serial = self._source.serial
        self._open_timeout_s = open_timeout_s
        self._t_last = clock.now()
        self._thread = threading.Thread(target=self._run, name=f"rio-realsense-{self.serial}", daemon=True)
        self._thread.start()
        if not self._first.wait(open_timeout_s):
            why = f" ({self.error})" if self.error else ""
            self.stop()
            raise RealSenseError(self.serial, f"started, but no frame arrived within {open_timeout_s:g} s{why}")

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
        self._close_source()

    def take(self) -> Frame | None:
        """The newest frame if it was not taken before, else None."""
        with self._lock:
            if self._latest is None or self._seq == self._taken:
                return None
            self._taken = self._seq
            return self._latest

    def status(self) -> dict[str, Any]:
        with self._lock:
            latest = self._latest
        return {"connected": self._source is not None, "frames": self.frames, "incomplete_framesets": self.incomplete,
                "lost": self.lost, "reconnects": self.reconnects, "error": self.error,
                "last_frame_age_s": None if latest is None else clock.now() - latest.t_frame,
                "clock_offset_s": None if self._processor is None else self._processor.clock.offset}

    # -- the thread -------------------------------------------------------------------------------------
    def _run(self) -> None:
        while not self._stop.is_set():
            if self._source is None:
                self._reconnect()
                continue
            try:
                self._grab_once()
            except Exception as e:  # noqa: BLE001 - whatever the SDK raised, the camera is lost; keep running
                err = e if isinstance(e, RealSenseError) else RealSenseError(self.serial, f"stopped delivering: {e}")
                self._lose(err)

    def _grab_once(self) -> None:
        src, proc = self._source, self._processor
        assert src is not None and proc is not None
        frames = src.wait(_WAIT_S)
        now = clock.now()
        if frames is None:
            limit = self._open_timeout_s if self._fresh else self.frame_timeout_s
            if now - self._t_last > limit:
                raise RealSenseError(self.serial, f"no frame for {now - self._t_last:.1f} s "
                                     "(unplugged, or the USB link dropped)")
            return
        while (more := src.poll()) is not None:  # skip to the newest complete frameset
            if proc.complete(more) or not proc.complete(frames):
                frames = more
        if not proc.complete(frames):
            self.incomplete += 1
            return
        frame = proc.process(frames, now)
        with self._lock:
            self._latest = frame
            self._seq += 1
        self.frames += 1
        self._t_last = now
        self._fresh = False
        self._first.set()

    def _lose(self, err: RealSenseError) -> None:
        self.lost += 1
        self.error = str(err)
        self._t_lost = clock.now()
        self.log.error("%s; the node keeps running and reconnects every %g s", err, self.reconnect_s)
        self._close_source()

    def _reconnect(self) -> None:
        if self._stop.wait(self.reconnect_s):
            return
        try:
            source, processor = self._connect()
        except Exception as e:  # noqa: BLE001 - still gone: try again later
            self.error = str(e)
            self.log.debug("RealSense %s: reconnect failed: %s", self.serial, e)
            return
        if self._stop.is_set():
            source.close()
            return
        self._source, self._processor = source, processor
        self._t_last = clock.now()
        self._fresh = True
        self.reconnects += 1
        self.error = None
        gone = "" if self._t_lost is None else f" after {clock.now() - self._t_lost:.1f} s"
        self.log.warning("RealSense %s: reconnected%s; frames resume", self.serial, gone)

    def _close_source(self) -> None:
        source, self._source, self._processor = self._source, None, None
        if source is not None:
            try:
                source.close()
            except Exception as e:  # noqa: BLE001 - closing a vanished camera may fail; it is gone either way
                self.log.debug("RealSense %s: close failed: %s", self.serial, e)
