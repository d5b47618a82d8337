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
    t1 = clock.now()
    assert rate.overruns == before + 1
    deadline = rate.schedule.deadline
    assert deadline > t1 - 1e-9  # re-anchored: no burst of catch-up ticks ...
    rate.sleep()
    assert clock.now() >= deadline  # ... the next tick waits for the grid's next deadline


def test_schedule_reanchors_on_its_grid_keeping_the_phase():
    grid = clock.Schedule(0.01, t0=100.0, phase=0.5)
    assert grid.deadline == pytest.approx(100.005)
    grid.advance()
    assert grid.deadline == pytest.approx(100.015)
    grid.reanchor(100.0731)  # fell behind: the first deadline after that time, still mid-period
    assert grid.k == 7 and grid.deadline == pytest.approx(100.075)
    grid.reanchor(100.02)  # never back in time
    assert grid.k == 7
    with pytest.raises(ValueError, match="positive period"):
        clock.Schedule(0.0, t0=0.0)


def test_count_rate_measures_a_counter_between_readings(monkeypatch):
    t = iter([10.0, 12.0, 13.0])
    monkeypatch.setattr(clock, "now", lambda: next(t))
    n = iter([5, 25, 35])
    meter = clock.CountRate(lambda: next(n))
    assert meter.rate() == pytest.approx(10.0)  # 20 counts in 2 s
    assert meter.rate() == pytest.approx(10.0)  # 10 more in 1 s
    assert clock.CountRate(lambda: None).rate() is None  # a node without state has no rate


def test_rate_rejects_bad_frequency():
    with pytest.raises(ValueError):
        clock.Rate(0)
