"""The grab thread a camera driver runs its device in (`rio.interfaces.Grabber`).

A camera read blocks (a V4L2 `select()`, an RTSP socket, an SDK queue), sometimes for seconds when
something goes wrong; the node loop must never wait on it. So each camera grabs in its own thread and
keeps only the newest frame; the node's `read_state()` takes it without blocking, and publishes nothing
when no new frame came since the last one (the camera contract: a frame not grabbed is not published).

When the device stops delivering (unplugged, a stream drops, the SDK raises), the thread logs one error
naming the camera, closes the device and tries to reopen it every `reopen_s` seconds; the node stays up
and clients simply see no new frames (their timestamps age) until it is back.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any, Protocol

from rio import clock
from rio.errors import RioError

Frame = Any  # whatever the driver's source returns; a frame with a `t` attribute (its capture time) shows an age


class CameraError(RioError):
    """A camera could not be opened or stopped delivering; the message names the camera and what to try."""


class SourceLost(CameraError):
    """An open camera stopped delivering (unplugged, stream ended, SDK said so). The grab thread closes it
    and reopens it; the node stays up."""


class Source(Protocol):
    """What a driver opens: `grab()` blocks until the next frame and returns it, or None for one failed
    read (counted: several in a row mean the device is lost); it raises `SourceLost` (or any error) when
    the device is gone, `SourceFinished` when a finite source has ended. `close()` releases it. A source
    may set `max_failed_reads` (e.g. 1 where a read already waited out a long timeout)."""

    def grab(self) -> Frame | None: ...

    def close(self) -> None: ...


class SourceFinished(CameraError):
    """A finite source (a video file with loop = false) has no more frames: stop, do not reopen."""


class Grabber:
    def __init__(self, label: str, connect: Callable[[], Source], *,
                 process: Callable[[Frame], Frame] = lambda frame: frame,
                 reopen_s: float = 1.0, max_failed_reads: int = 3, log: logging.Logger | None = None):
        self.label, self._connect, self._process = label, connect, process
        self.reopen_s, self.max_failed_reads = float(reopen_s), int(max_failed_reads)
        self.log = log or logging.getLogger("rio.camera")
        self._source: Source | None = None
        self._source_lock = threading.Lock()
        self._frame_lock = threading.Lock()
        self._latest: Frame | None = None
        self._index = 0  # frames grabbed since start
        self._taken = 0  # index of the last frame handed out
        self._first = threading.Event()
        #: set on every new frame: the node's `arrival_event()` (published as it lands)
        self.arrived = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        #: why the device was lost, and why the last reopen failed (None while it delivers)
        self.lost_reason: str | None = None
        self.reopen_error: str | None = None
        self.lost = 0
        self.reopened = 0
        self.finished = False

    # -- the node's side ------------------------------------------------------------------------------
    def start(self, first_frame_timeout: float) -> None:
        """Open the device (errors propagate: a camera that cannot open fails the node's start), start the
        thread and wait for the first frame, so the node is ready with a picture."""
        self._source = self._connect()
        self._thread = threading.Thread(target=self._run, name=f"rio-camera-{self.label}", daemon=True)
        self._thread.start()
        if not self._first.wait(first_frame_timeout):
            why = f" ({self.error})" if self.error else ""  # e.g. reads that failed
            self.stop()
            raise CameraError(f"{self.label}: opened, but no frame arrived within {first_frame_timeout:g} s{why}; "
                              "raise open_timeout_s for slow streams")

    def take(self) -> tuple[Frame, int] | None:
        """The newest frame and its index, if it is newer than the last one taken; else None. Never blocks
        on the device."""
        with self._frame_lock:
            if self._latest is None or self._index == self._taken:
                return None
            self._taken = self._index
            return self._latest, self._index

    def stop(self, join_s: float = 3.0) -> None:
        self._stop.set()
        t = self._thread
        if t is not None and t is not threading.current_thread():
            t.join(join_s)
            if t.is_alive():  # blocked inside the SDK: closing the device is what unblocks most of them
                self.log.warning("%s: the grab thread did not stop within %g s; closing the device under it",
                                 self.label, join_s)
                self._close_source()
                t.join(join_s)
        self._close_source()

    @property
    def error(self) -> str | None:
        """One line on what is wrong now, naming the cause (None while frames arrive)."""
        parts = [p for p in (self.lost_reason, self.reopen_error) if p]
        return "; ".join(parts) or None

    def status(self) -> dict[str, Any]:
        with self._frame_lock:
            latest, index = self._latest, self._index
        return {"connected": self._source is not None, "error": self.error, "frames": index,
                "last_frame_age_s": None if (t := getattr(latest, "t", None)) is None else clock.now() - t,
                "lost": self.lost, "reopened": self.reopened, "finished": self.finished}

    # -- the thread ------------------------------------------------------------------------------------
    def _run(self) -> None:
        failures = 0
        try:
            while not self._stop.is_set():
                source = self._source
                if source is None:
                    self._reopen()
                    continue
                try:
                    frame = source.grab()
                    if frame is None:
                        failures += 1
                        if failures >= getattr(source, "max_failed_reads", self.max_failed_reads):
                            raise SourceLost(f"{failures} reads in a row returned no frame")
                        continue
                    failures = 0
                    frame = self._process(frame)
                except SourceFinished as e:
                    self.finished = True
                    self.log.info("%s: %s; no more frames", self.label, e)
                    return
                except Exception as e:  # noqa: BLE001 - any failure of the device: report it, reopen, stay up
                    if self._stop.is_set():
                        return
                    failures = 0
                    self._lose(e)
                    continue
                with self._frame_lock:
                    self._latest = frame
                    self._index += 1
                self._first.set()
                self.arrived.set()
        finally:
            self._close_source()

    def _lose(self, e: BaseException) -> None:
        self.lost += 1
        self.lost_reason, self.reopen_error = f"lost: {type(e).__name__}: {e}", None
        self.log.error("%s: %s; the node stays up and reopens it every %g s", self.label, self.error, self.reopen_s)
        self._close_source()

    def _reopen(self) -> None:
        if self._stop.wait(self.reopen_s):
            return
        try:
            source = self._connect()
        except Exception as e:  # noqa: BLE001 - still gone: say so once per distinct reason
            why = f"reopen failed: {type(e).__name__}: {e}"
            if why != self.reopen_error:
                self.log.warning("%s: %s (retrying every %g s)", self.label, why, self.reopen_s)
            self.reopen_error = why
            return
        with self._source_lock:
            if self._stop.is_set():
                source.close()
                return
            self._source = source
        self.reopened += 1
        self.log.warning("%s: reopened (it was %s)", self.label, self.lost_reason or "lost")
        self.lost_reason = self.reopen_error = None

    def _close_source(self) -> None:
        with self._source_lock:
            source, self._source = self._source, None
        if source is not None:
            try:
                source.close()
            except Exception as e:  # noqa: BLE001 - a device that fails to close is already gone
                self.log.debug("%s: closing raised %s: %s", self.label, type(e).__name__, e)
