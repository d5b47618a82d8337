"""rio.clock: one clock, deadline waits and fixed-rate loops (behaviour, not timing precision)."""

import time

import pytest
from rio import clock


def test_now_is_monotonic_seconds():
    a = clock.now()
    time.sleep(0.01)
    b = clock.now()
    assert 0.009 <= b - a < 1.0


def test_precise_wait_never_returns_early():
    for dt in (0.0005, 0.002, 0.01):
        t_end = clock.now() + dt
        clock.precise_wait(t_end)
        assert clock.now() >= t_end


def test_precise_wait_in_the_past_returns_immediately():
    t0 = clock.now()
    clock.precise_wait(t0 - 1.0)
    assert clock.now() - t0 < 0.05


def test_rate_keeps_absolute_schedule_and_counts_overruns():
    rate = clock.Rate(200)
    t0 = clock.now()
    for _ in range(20):
        rate.sleep()
    assert clock.now() - t0 >= 19 / 200  # never faster than the rate
    before = rate.overruns
    time.sleep(0.05)  # a tick far longer than the period
    rate.sleep()
    assert rate.overruns == before + 1
    t1 = clock.now()
    rate.sleep()  # re-anchored: no burst of catch-up ticks
    assert clock.now() - t1 >= 0.8 / 200


def test_rate_rejects_bad_frequency():
    with pytest.raises(ValueError):
        clock.Rate(0)
