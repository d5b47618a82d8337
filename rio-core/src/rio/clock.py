"""One clock for the whole station.

Every published sample and every command target time comes from `now()`, so timestamps taken in
different processes on one machine are directly comparable (CLOCK_MONOTONIC is system-wide on Linux
and macOS). Sleeping is split in two: the OS sleep is coarse (timer slack, scheduler), so we sleep
until ~1 ms before the deadline and yield-spin the rest.
"""

from __future__ import annotations

import time as _time

from .host import yield_cpu as _yield

__all__ = ["now", "precise_wait", "Rate", "set_timer_slack"]

now = _time.monotonic

_SPIN_S = 0.001


def set_timer_slack(ns: int = 1) -> bool:
    """Make OS sleeps of this thread (and threads it starts later) wake on time.

    Linux delays timer wake-ups by up to 50 us of "slack" by default; measured here, a 1 ms sleep
    woke 89 us late at the median with the default and 27 us late with 1 ns. Node processes call
    this at start so their loops can sleep instead of spinning (a spinning loop steals the GIL from
    the thread answering API calls). Returns False where unsupported.
    """
    try:
        import ctypes

        return ctypes.CDLL("libc.so.6", use_errno=True).prctl(29, int(ns), 0, 0, 0) == 0  # PR_SET_TIMERSLACK
    except (OSError, AttributeError):
        return False


def precise_wait(t_end: float, spin_s: float = _SPIN_S) -> None:
    """Return at `t_end` (a `now()` time): OS sleep to `spin_s` before it, then yield-spin.

    `sched_yield()` is used for the spin because on a 2-core machine a pure busy loop starves the
    process we are waiting on, and `time.sleep(0)` costs ~30 us through timer slack.
    """
    t_sleep = t_end - now() - spin_s
    if t_sleep > 0:
        _time.sleep(t_sleep)
    while now() < t_end:
        _yield()


class Rate:
    """Fixed-rate loop timing on absolute deadlines, so one slow tick does not shift the schedule.

    A tick that finishes after its deadline counts as an overrun; the schedule then re-anchors on the
    current time instead of firing a burst of catch-up ticks (which would hammer hardware).
    """

    def __init__(self, hz: float, spin_s: float = _SPIN_S):
        if not hz > 0:
            raise ValueError(f"Rate needs a positive frequency, got {hz!r}")
        self.hz = float(hz)
        self.period = 1.0 / self.hz
        self.overruns = 0
        self.ticks = 0
        self.spin_s = spin_s
        self._t_next = now() + self.period

    def sleep(self) -> None:
        t = now()
        self.ticks += 1
        if t > self._t_next:
            self.overruns += 1
            self._t_next = t + self.period
            return
        precise_wait(self._t_next, self.spin_s)
        self._t_next += self.period

    # The paper's spelling.
    precise_sleep = sleep

    def reset(self) -> None:
        self._t_next = now() + self.period
