"""One key, no Enter: the keep / discard / re-record prompt between recorded episodes.

`typer.prompt` needs Enter, and the keyboard teleop's keys (`k` is pitch) went nowhere for 23 s while it waited.
This reads single keys from the terminal in cbreak mode (its settings restored after), ignores every key it was
not asked for, and returns when one of `choices` comes, or None when a stop signal arrives (`stopped()` is
polled, since a caught SIGINT does not interrupt a read) or Ctrl+C raises.
"""

from __future__ import annotations

import contextlib
import os
import select
from collections.abc import Callable, Iterable


def read_key(choices: Iterable[str], *, tty: str | int = "/dev/tty", stopped: Callable[[], bool] | None = None,
             poll_s: float = 0.1, flush: bool = True) -> str | None:
    """The first key among `choices` (case-insensitive, returned lower-case) typed on `tty` (a path or an open
    descriptor) after the call (`flush`: keys typed before it, during the episode, are dropped); None when
    `stopped()` turns true or Ctrl+C raises KeyboardInterrupt meanwhile."""
    import termios
    import tty as ttymod

    wanted = {c.lower() for c in choices}
    own = isinstance(tty, str)
    fd: int = os.open(tty, os.O_RDONLY | os.O_NOCTTY) if isinstance(tty, str) else tty
    saved = None
    try:
        with contextlib.suppress(termios.error):
            saved = termios.tcgetattr(fd)
            ttymod.setcbreak(fd, termios.TCSANOW)  # one key at a time, no echo, Ctrl+C still signals; input kept
            if flush:
                termios.tcflush(fd, termios.TCIFLUSH)
        while True:
            if stopped is not None and stopped():
                return None
            ready, _, _ = select.select([fd], [], [], poll_s)
            if not ready:
                continue
            data = os.read(fd, 1)  # one key: what follows it is the next prompt's
            if not data:  # the terminal went away
                return None
            for ch in data.decode(errors="ignore").lower():
                if ch in wanted:
                    return ch
    except KeyboardInterrupt:
        return None
    finally:
        if saved is not None:
            with contextlib.suppress(termios.error):
                termios.tcsetattr(fd, termios.TCSADRAIN, saved)
        if own:
            os.close(fd)
