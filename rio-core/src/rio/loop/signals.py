"""SIGINT, SIGTERM and SIGHUP end a workflow through its normal end.

`timeout 60 rio teleop ...`, a closed terminal and Ctrl+C must all leave the same things behind: the
robot holding, the episode closed, the summary printed, shared memory released. A default SIGTERM
kills the process where it stands (no summary, segments left in /dev/shm), so while a control loop
runs these signals only raise a flag that the loop reads once per tick. A second signal while the
loop is finishing means "stop now": Ctrl+C raises KeyboardInterrupt, the others SystemExit, and the
runtime's own cleanup still runs.

Command-line workflows exit with 128 + the signal's number after printing their summary (130 for
SIGINT, 143 for SIGTERM, 129 for SIGHUP), as shells report a process ended by that signal.
"""

from __future__ import annotations

import signal
import threading
from typing import Any

from rio.machine import host


class StopSignals:
    """`with StopSignals() as stop:` ... `stop.received` is the first signal's name (or None). Only
    the main thread can take signals; elsewhere this does nothing and Ctrl+C stays KeyboardInterrupt."""

    def __init__(self, enabled: bool = True):
        self.enabled = enabled and threading.current_thread() is threading.main_thread()
        self.received: str | None = None
        self.number = 0
        self._old: dict[int, Any] = {}

    def _handle(self, signum: int, _frame: Any) -> None:
        if self.received is not None:  # the second one: stop now
            if signum == signal.SIGINT:
                raise KeyboardInterrupt
            raise SystemExit(128 + signum)
        self.received, self.number = signal.Signals(signum).name, signum

    def __enter__(self) -> StopSignals:
        if self.enabled:
            self._old = host.catch_stop_signals(self._handle)
        return self

    def __exit__(self, *exc: Any) -> None:
        host.restore_signals(self._old)
        self._old = {}

    @property
    def exit_code(self) -> int:
        """0, or 128 + the number of the signal that ended the run."""
        return 128 + self.number if self.received else 0
