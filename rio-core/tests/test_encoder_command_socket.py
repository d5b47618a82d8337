"""The recorder's encoder process keeps its command socket whatever the process around the recorder did
to Python's socket defaults.

`socket.setdefaulttimeout()` is process-wide, and a library may call it: the xArm SDK sets 1 s whenever it
connects, from whichever thread opens the arm. Every socket object made afterwards is non-blocking
underneath, a socket pair made for a child included. The encoder inherited a non-blocking end, its first
read with nothing pending failed with EAGAIN, and it exited 0 as if the recorder had gone; the recorder's
next send got EPIPE and the episode lost its video. That is how recordings were lost in both pytest-xdist
workers, each of which had run an xArm test (rio-ufactory's, rio-teleop's GELLO driving an xArm) before
its recording tests; a single pytest process, in path order, records in-process only before those tests.
"""

from __future__ import annotations

import os
import socket

import numpy as np
import pytest

from rio.recording import Dataset
from rio.recording.encoder import EncoderProcess
from rio.recording.synthetic import record_synthetic

pytest.importorskip("av")


@pytest.fixture
def xarm_like_default_timeout():
    """A process-wide default socket timeout of 1 s, as the xArm SDK leaves it, for one test."""
    old = socket.getdefaulttimeout()
    socket.setdefaulttimeout(1.0)
    try:
        yield
    finally:
        socket.setdefaulttimeout(old)


def test_episodes_keep_every_frame_under_a_process_wide_socket_timeout(tmp_path, xarm_like_default_timeout):
    """Two episodes recorded in real time: the encoder waits for frames between steps and between episodes
    (where the old encoder read EAGAIN and exited), and every camera frame of both episodes is stored."""
    metas = record_synthetic(str(tmp_path / "ds"), episodes=2, steps=8, fps=30, size=(24, 32), realtime=True)
    assert [m["length"] for m in metas] == [8, 8]
    ds = Dataset(tmp_path / "ds")
    for k in range(2):
        ep = ds.episode(k)
        assert ep.verify() == []
        for cam in ("front", "wrist"):
            assert len(list(ep.step_frames(cam))) == 8, (k, cam)
        assert len(list(ep.step_frames("front", "depth"))) == 8, k


def test_the_command_socket_stays_blocking_when_a_timeout_is_set_after_the_encoder_started(tmp_path):
    """An arm connecting after the recorder opened (its node thread starting beside the loop): handing the
    encoder a frame ring must not turn the recorder's end of the socket non-blocking (multiprocessing's
    send_handle did, through a socket object made under the default timeout on the same open socket),
    which would make a send into a full socket buffer fail with EAGAIN and split a read message in two.
    The encoder still answers afterwards."""
    enc = EncoderProcess()
    old = socket.getdefaulttimeout()
    try:
        socket.setdefaulttimeout(1.0)
        enc.ensure_ring("front.rgb", (4, 4, 3), np.dtype(np.uint8), 2)
        enc.ensure_ring("front.rgb", (8, 8, 3), np.dtype(np.uint8), 2)  # a second hand-over, replacing the first
        assert os.get_blocking(enc.conn.fileno())
        assert enc.close_streams([], timeout=30.0) == {}
        assert enc.alive(), enc.exit_reason()
    finally:
        socket.setdefaulttimeout(old)
        enc.shutdown()
