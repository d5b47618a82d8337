"""rio.time: one clock, deadline waits and fixed-rate loops (behaviour, not timing precision)."""

import time

import pytest
from rio import time as rtime


def test_now_is_monotonic_seconds():
    a = rtime.now()
    time.sleep(0.01)
    b = rtime.now()
    assert 0.009 <= b - a < 1.0


def test_precise_wait_never_returns_early():
    for dt in (0.0005, 0.002, 0.01):
        t_end = rtime.now() + dt
        rtime.precise_wait(t_end)
        assert rtime.now() >= t_end


def test_precise_wait_in_the_past_returns_immediately():
    t0 = rtime.now()
    rtime.precise_wait(t0 - 1.0)
    assert rtime.now() - t0 < 0.05


def test_rate_keeps_absolute_schedule_and_counts_overruns():
    rate = rtime.Rate(200)
    t0 = rtime.now()
    for _ in range(20):
        rate.sleep()
    assert rtime.now() - t0 >= 19 / 200  # never faster than the rate
    before = rate.overruns
    time.sleep(0.05)  # a tick far longer than the period
    rate.sleep()
    assert rate.overruns == before + 1
    t1 = rtime.now()
    rate.sleep()  # re-anchored: no burst of catch-up ticks
    assert rtime.now() - t1 >= 0.8 / 200


def test_rate_rejects_bad_frequency():
    with pytest.raises(ValueError):
        rtime.Rate(0)
