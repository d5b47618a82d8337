"""One clock for the whole station.

Every published sample and every command target time comes from `now()`, so timestamps taken in
different processes on one machine are directly comparable (CLOCK_MONOTONIC is system-wide on Linux
and macOS). Sleeping is split in two: the OS sleep is coarse (timer slack, scheduler), so we sleep
until ~1 ms before the deadline and yield-spin the rest.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable

from rio.machine.host import yield_cpu as _yield

__all__ = ["now", "precise_wait", "Schedule", "Rate", "CountRate", "set_timer_slack"]

now = _time.monotonic

#: The control rates RIO accepts (Hz), from a station file (`rate_hz`) or `--rate`. Below 1 Hz a loop's first
#: tick comes long after any `--duration` (it ran 10^9 s past `--duration 1` at `--rate 1e-9`); above 10 kHz
#: no general-purpose OS keeps the deadlines.
RATE_RANGE_HZ = (1.0, 10_000.0)

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


class Schedule:
    """A grid of absolute deadlines `t0 + (k + phase) * period`: the one fixed-rate schedule of RIO (node
    loops through `Rate`, the control loop directly).

    Deadlines are absolute so one slow tick does not shift the ones after it. A tick that ends past
    its deadline is late; after one that ends a whole period or more behind, `reanchor(t)` moves on to
    the first deadline after `t` (the grid's phase kept) instead of firing a burst of catch-up ticks,
    which would hammer hardware.
    """

    def __init__(self, period: float, t0: float, phase: float = 0.0):
        if not period > 0:
            raise ValueError(f"a schedule needs a positive period, got {period!r}")
        self.period, self.t0, self.phase = float(period), float(t0), float(phase)
        self.k = 0

    @property
    def deadline(self) -> float:
        return self.t0 + (self.k + self.phase) * self.period

    def advance(self) -> None:
        self.k += 1

    def reanchor(self, t: float) -> None:
        """Skip the deadlines already past at `t`."""
        self.k = max(self.k, math.floor((t - self.t0) / self.period - self.phase) + 1)


class Rate:
    """Paces a loop on a `Schedule`: `sleep()` at the end of each tick waits for the next deadline.

    A tick that ends after its deadline counts as an overrun: `sleep()` returns at once and the
    schedule re-anchors on the grid, so the next tick waits for the first deadline after now.
    """

    def __init__(self, hz: float, spin_s: float = _SPIN_S):
        if not hz > 0:
            raise ValueError(f"Rate needs a positive frequency, got {hz!r}")
        self.hz = float(hz)
        self.period = 1.0 / self.hz
        self.overruns = 0
        self.ticks = 0
        self.spin_s = spin_s
        self.schedule = Schedule(self.period, now(), phase=1.0)

    def sleep(self) -> None:
        t, sched = now(), self.schedule
        self.ticks += 1
        if t > sched.deadline:
            self.overruns += 1
            sched.reanchor(t)
            return
        precise_wait(sched.deadline, self.spin_s)
        sched.advance()

    # The paper's spelling.
    precise_sleep = sleep

    def reset(self) -> None:
        self.schedule = Schedule(self.period, now(), phase=1.0)


class CountRate:
    """The rate of a growing counter between readings (a node's published-sample count): what `rio top`
    shows live and what a run's summary reports per node. `read` returns the counter, or None when
    there is none (a node without state)."""

    def __init__(self, read: Callable[[], int | None]):
        self.read = read
        self.last = self._reading()

    def _reading(self) -> tuple[float, int] | None:
        n = self.read()
        return None if n is None else (now(), int(n))

    def rate(self) -> float | None:
        """Counts per second since the previous reading (or since construction); None without a counter."""
        cur, last = self._reading(), self.last
        self.last = cur
        if cur is None or last is None or cur[0] <= last[0]:
            return None
        return (cur[1] - last[1]) / (cur[0] - last[0])
