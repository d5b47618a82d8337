"""The live status line of an interactive run: where the tool is, the gripper, the teleop mode, the loop's
rate and lateness, recording and elapsed time, redrawn in place a few times a second at the bottom of the
terminal (rich), with events (a mode change, a node's warning) printed above it as lines.

It is an `on_tick` callback of the control loop and costs the loop almost nothing: a tick only stores what
it saw; the text is made and drawn at most `refresh_hz` times a second. A workflow shows it only where a
person watches (`rio teleop` in a terminal, not with `--quiet`, not when its output goes to a file or a
pipe), so logs and `--json` stay clean.
"""

from __future__ import annotations

import dataclasses
import logging
from collections import deque
from typing import Any

import numpy as np

from rio import clock


class StatusLine:
    def __init__(self, console: Any, *, recording: str | None = None, refresh_hz: float = 4.0):
        from rich.live import Live

        self.console, self.recording = console, recording
        self._live = Live(console=console, refresh_per_second=refresh_hz, transient=True, redirect_stdout=True,
                          redirect_stderr=True, auto_refresh=False)
        self._every = 1.0 / refresh_hz
        self._next = 0.0
        self._times: deque[float] = deque(maxlen=256)
        self._late: deque[float] = deque(maxlen=256)
        self._mode: str | None = None
        self._handler: logging.Handler | None = None

    # -- lifetime -----------------------------------------------------------------------------------
    def __enter__(self) -> StatusLine:
        self._live.__enter__()
        # log records (a node's warning, a fault) go above the line instead of through it
        from rich.logging import RichHandler

        self._handler = RichHandler(console=self.console, show_time=False, show_path=False, markup=False)
        self._handler.setLevel(logging.WARNING)
        logging.getLogger().addHandler(self._handler)
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._handler is not None:
            logging.getLogger().removeHandler(self._handler)
        self._live.__exit__(*exc)

    # -- the loop's callback ------------------------------------------------------------------------
    def __call__(self, tick: Any) -> None:
        now = clock.now()
        if tick.periodic:
            self._times.append(tick.t)
            self._late.append(tick.lateness)
        mode = tick.info.get("mode")
        if mode is not None and str(mode) != self._mode:
            if self._mode is not None:
                self.event(f"mode: {_mode_name(mode)}")
            self._mode = str(mode)
        if now < self._next:
            return
        self._next = now + self._every
        self._live.update(self.text(tick), refresh=True)

    def event(self, text: str) -> None:
        """A line above the status line (it stays in the terminal's scrollback)."""
        self.console.print(text, markup=False, highlight=False)

    # -- what it shows ------------------------------------------------------------------------------
    def text(self, tick: Any) -> str:
        parts = [f"{tick.t - tick.t0:6.1f} s"]
        if len(self._times) > 1 and self._times[-1] > self._times[0]:
            rate = (len(self._times) - 1) / (self._times[-1] - self._times[0])
            parts.append(f"{rate:5.1f} Hz, late p99 {np.percentile(self._late, 99) * 1e3:.1f} ms")
        parts += _robot(tick.step.observation if tick.step is not None else None)
        if self._mode is not None:
            parts.append(f"mode {_mode_name(self._mode)}")
        if self.recording:
            parts.append(f"REC {self.recording}")
        return " | ".join(parts)


def _mode_name(mode: Any) -> str:
    return str(getattr(mode, "value", mode)).split(".")[-1].lower()


def _robot(obs: Any) -> list[str]:
    """Each tool's position and each gripper's opening, from an embodiment's observation."""
    if obs is None or not dataclasses.is_dataclass(obs):
        return []
    out = []
    for f in dataclasses.fields(obs):
        value = getattr(obs, f.name)
        if value is None:
            continue
        if f.name.endswith("proprio_eef"):
            x, y, z = np.asarray(value, dtype=float)[:3]
            out.append(f"{f.name.removesuffix('_proprio_eef').removesuffix('proprio_eef') or 'tool'} "
                       f"({x:+.3f} {y:+.3f} {z:+.3f}) m")
        elif f.name.startswith("gripper") and f.name.endswith("_width"):
            out.append(f"{f.name.removesuffix('_width')} {float(value) * 1e3:.0f} mm")
    return out
