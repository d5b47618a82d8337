"""`rio.interfaces.Grabber`, the grab thread every camera driver uses: newest frame only, each handed out
once, empty reads counted to a loss, a lost device closed and reopened while the node stays up, a
finished source not reopened, and a start without a first frame failing with the camera's name."""

from __future__ import annotations

import logging
import threading

import pytest

from rio.interfaces.grabber import CameraError, Grabber, SourceFinished, SourceLost
from rio.testing import wait_until


class Script:
    """A source whose reads follow a list: an int is a frame, None an empty read, an exception is raised;
    past the end it blocks briefly and returns None (a camera between frames)."""

    def __init__(self, steps):
        self.steps, self.closed = list(steps), False

    def grab(self):
        if not self.steps:
            threading.Event().wait(0.01)
            return None
        step = self.steps.pop(0)
        if isinstance(step, BaseException):
            raise step
        return step

    def close(self):
        self.closed = True


def grabber(*sources, **kw) -> Grabber:
    it = iter(sources)
    return Grabber("cam 'test'", lambda: next(it), reopen_s=0.01, **kw)


def test_frames_are_handed_out_once_and_each_arrival_is_announced():
    g = grabber(Script([1, 2, 3]))
    g.start(5.0)
    try:
        assert wait_until(lambda: g.status()["frames"] == 3, timeout=5)
        assert g.arrived.is_set()
        assert g.take() == (3, 3)  # the newest only
        assert g.take() is None  # not twice
    finally:
        g.stop()


def test_empty_reads_in_a_row_are_a_loss_and_the_device_is_reopened():
    first, second = Script([1, None, None, None]), Script([7])
    g = grabber(first, second, max_failed_reads=3)
    g.start(5.0)
    try:
        assert wait_until(lambda: g.status()["reopened"] == 1, timeout=5)
        assert first.closed and g.status()["lost"] == 1
        assert wait_until(lambda: (g.take() or (None,))[0] == 7, timeout=5)
    finally:
        g.stop()


def test_an_error_is_a_loss_a_failed_reopen_is_retried(caplog):
    caplog.set_level(logging.INFO, logger="rio.camera")
    calls = []

    def connect():
        calls.append(1)
        if len(calls) == 1:
            return Script([1, SourceLost("unplugged")])
        if len(calls) == 2:
            raise CameraError("still gone")
        return Script([5])

    g = Grabber("cam 'x'", connect, reopen_s=0.01)
    g.start(5.0)
    try:
        assert wait_until(lambda: (g.take() or (None,))[0] == 5, timeout=5)
        assert len(calls) >= 3 and g.status()["lost"] == 1 and g.status()["error"] is None
    finally:
        g.stop()
    said = [(r.levelno, r.getMessage()) for r in caplog.records]
    assert (logging.ERROR, "cam 'x': lost: SourceLost: unplugged; the node stays up and reopens it every 0.01 s") \
        in said
    assert any(level == logging.WARNING and m.startswith("cam 'x': reopened") for level, m in said)


def test_a_finished_source_is_not_reopened():
    g = grabber(Script([1, SourceFinished("end of the file")]), Script([9]))
    g.start(5.0)
    try:
        assert wait_until(lambda: g.status()["finished"], timeout=5)
        assert g.status()["reopened"] == 0
    finally:
        g.stop()


def test_no_first_frame_fails_the_start_naming_the_camera():
    g = grabber(Script([]))
    with pytest.raises(CameraError, match="cam 'test': opened, but no frame arrived"):
        g.start(0.3)
