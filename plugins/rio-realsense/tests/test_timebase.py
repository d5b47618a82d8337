"""The camera-clock to station-clock map (`FrameClock`) on synthetic timestamps: arrivals jittered
the way a busy USB bus and a descheduled thread jitter them."""

from __future__ import annotations

import numpy as np
import pytest
from rio_realsense.timebase import FrameClock

BASE_MS = 5_000_000.0  # the camera's clock reading when the station clock reads 0
MIN_LATENCY = 0.004


def frames(n: int, fps: float = 30.0, seed: int = 0):
    """(camera ms, true exposure time, arrival) for `n` frames: a fixed 4 ms transfer plus exponential
    jitter (mean 5 ms) and, every 50th frame, a 150 ms stall."""
    rng = np.random.default_rng(seed)
    for i in range(n):
        t_true = 100.0 + i / fps
        delay = MIN_LATENCY + rng.exponential(0.005) + (0.15 if i % 50 == 25 else 0.0)
        yield BASE_MS + t_true * 1000.0, t_true, t_true + delay


def test_never_after_arrival_and_jitter_free():
    clock = FrameClock(window_s=2.0)
    errors = []
    for i, (cam_ms, t_true, arrival) in enumerate(frames(600)):
        t = clock.map(cam_ms, arrival, "global")
        assert t <= arrival
        if i >= 60:  # once the window holds a second of frames
            errors.append(t - t_true)
    errors = np.array(errors)
    # late by about the smallest transfer latency, never by a stall or the jitter
    assert np.all(errors >= MIN_LATENCY - 1e-9)
    assert np.all(errors < MIN_LATENCY + 0.003)
    assert np.all(np.diff([clock.map(m, a, "global") for m, _, a in frames(100, seed=1)]) > 0)


def test_a_new_time_domain_or_a_clock_that_jumps_back_starts_over():
    clock = FrameClock(window_s=2.0)
    for cam_ms, _, arrival in frames(30):
        clock.map(cam_ms, arrival, "global")
    assert clock.resets == 1
    offset = clock.offset
    assert offset == pytest.approx(-BASE_MS / 1000.0, abs=0.01)
    # the camera restarted: its clock reads 0 again
    t = clock.map(10.0, 200.0, "global")
    assert clock.resets == 2 and t == pytest.approx(200.0)
    clock.map(50.0, 200.04, "hardware_clock")
    assert clock.resets == 3


def test_follows_drift_beyond_the_window():
    """Clocks that drift 1 ms/s apart: the window's minimum follows, so the error stays bounded."""
    clock = FrameClock(window_s=1.0)
    worst = 0.0
    for i in range(900):
        t_true = i / 30.0
        cam_ms = t_true * 1000.0 * (1 + 1e-3)
        arrival = t_true + 0.004
        t = clock.map(cam_ms, arrival, None)
        assert t <= arrival
        if i > 60:
            worst = max(worst, abs(t - t_true))
    assert worst < 0.004 + 0.0015
