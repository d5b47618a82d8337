"""`teleop.keyboard`: end-effector teleop from terminal keys. Needs no display and no input
device permissions, so it works over SSH; it reads the controlling terminal (`/dev/tty`), so it
works in a node process too.

Terminals report key presses, not releases (and repeat a held key after a short delay), so each
press moves the target for `hold_s` seconds; holding a key keeps it moving.

    w/s  +x/-x (forward/back)    a/d  +y/-y (left/right)    r/f  +z/-z (up/down)
    i/k  pitch                   j/l  yaw                   u/o  roll
    space  toggle gripper        m    next teleop mode      q or Enter  finish
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from pydantic import Field

from rio import clock
from rio.control.teleop import BUTTON_DONE, BUTTON_MODE
from rio.interfaces import TeleopNode
from rio.interfaces.teleop import TeleopConfig
from rio.runtime.node import remote

HELP = ("keys: w/s a/d r/f move x/y/z, i/k j/l u/o rotate, space gripper, m mode, q or Enter finish")

_LINEAR = {"w": (0, 1), "s": (0, -1), "a": (1, 1), "d": (1, -1), "r": (2, 1), "f": (2, -1)}
_ANGULAR = {"u": (3, 1), "o": (3, -1), "i": (4, 1), "k": (4, -1), "j": (5, 1), "l": (5, -1)}


class KeyTwist:
    """Key presses -> twist, gripper and buttons (the part that needs no terminal; tested alone)."""

    def __init__(self, speed: float, rot_speed: float, hold_s: float, buttons: int = 2):
        self.speed, self.rot_speed, self.hold_s = speed, rot_speed, hold_s
        self.buttons = int(buttons)  # how many are published (the configured number)
        self.until = np.zeros(6)      # per twist axis: active until this time
        self.sign = np.zeros(6)
        self.gripper = 1.0
        self.mode_until = -1.0
        self.done = False

    def press(self, key: str, t: float) -> None:
        key = key.lower()
        if key in _LINEAR or key in _ANGULAR:
            axis, sign = _LINEAR.get(key) or _ANGULAR[key]
            self.until[axis], self.sign[axis] = t + self.hold_s, sign
        elif key == " ":
            self.gripper = 0.0 if self.gripper > 0.5 else 1.0
        elif key == "m":
            self.mode_until = t + self.hold_s
        elif key in ("q", "\n", "\r"):
            self.done = True

    def state(self, t: float) -> dict[str, Any]:
        active = self.until > t
        scale = np.array([self.speed] * 3 + [self.rot_speed] * 3)
        buttons = np.zeros(self.buttons, bool)
        buttons[BUTTON_MODE:BUTTON_MODE + 1] = t < self.mode_until  # where the configured buttons include it
        buttons[BUTTON_DONE:BUTTON_DONE + 1] = self.done
        return {"twist": np.where(active, self.sign * scale, 0.0), "gripper": self.gripper, "buttons": buttons}


class KeyboardTeleop(TeleopNode):
    class Config(TeleopConfig):
        speed: float = Field(0.05, gt=0, description="tool speed while a move key is down (m/s)")
        rot_speed: float = Field(0.5, gt=0, description="rotation speed while a rotate key is down (rad/s)")
        hold_s: float = Field(0.15, gt=0, description="how long one key press keeps moving (s)")
        tty: str = Field("/dev/tty", description="terminal to read")
        rate_hz: float = Field(100.0, gt=0)

    def setup(self) -> None:
        super().setup()
        c = self.config
        self.tty, self.keys = c.tty, KeyTwist(c.speed, c.rot_speed, c.hold_s, c.buttons)
        self._fd: int | None = None
        self._saved: list[Any] | None = None  # the terminal's settings, restored on close
        self._paused = False  # between episodes of a recording session the terminal is the prompt's

    def open(self) -> None:
        import termios
        import tty

        try:
            self._fd = os.open(self.tty, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY)
        except OSError as e:
            raise RuntimeError(f"teleop.keyboard needs a terminal ({self.tty}: {e.strerror}); run it from a "
                               "terminal (ssh is fine), or use --teleop scripted") from None
        try:
            self._saved = termios.tcgetattr(self._fd)
            tty.setcbreak(self._fd)  # keys arrive one by one, no echo; Ctrl+C still interrupts
        except termios.error as e:
            os.close(self._fd)
            self._fd = None
            raise RuntimeError(f"teleop.keyboard: {self.tty} is not a terminal ({e}); run it from a terminal, "
                               "or use --teleop scripted") from None

    def close(self) -> None:
        if self._fd is not None:
            import termios

            if self._saved is not None:
                termios.tcsetattr(self._fd, termios.TCSADRAIN, self._saved)
            os.close(self._fd)
            self._fd = None

    def read_state(self) -> dict[str, Any]:
        t = clock.now()
        assert self._fd is not None  # opened in open()
        try:
            data = b"" if self._paused else os.read(self._fd, 64)
        except BlockingIOError:
            data = b""
        for ch in data.decode(errors="ignore"):
            self.keys.press(ch, t)
        return self.keys.state(t)

    @remote
    def reset(self) -> float:
        self.keys.done = False
        self._paused = False
        return 0.0

    @remote
    def pause(self) -> None:
        """Stop reading the terminal until the next `reset()`: between the episodes of a recording session
        the keep / discard / re-record prompt reads it, and a key read here would be lost to it."""
        self._paused = True

    @remote
    def help(self) -> str:
        return HELP


KeyboardTeleopConfig = KeyboardTeleop.Config
