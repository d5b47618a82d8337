"""Scripted hands for emulated arms: what a person moving a (torque-off) leader arm would do, so a
emulated leader-follower station shows motion with nobody at the desk."""

from __future__ import annotations

import math

from ..calibration import MID
from .bus import FeetechBusEmulator

MOTIONS = ("none", "wave")


def wave(center: float, amplitude: float, period_s: float, phase: float, t0: float):
    def hand(t: float) -> float:
        return center + amplitude * math.sin(2 * math.pi * (t - t0) / period_s + phase)
    return hand


def attach_motion(bus: FeetechBusEmulator, motion: str) -> None:
    """'wave': every joint swings slowly around mid-turn (about +-20 degrees, the jaw opens and
    closes); 'none': joints stay where they are."""
    if motion == "none":
        return
    if motion != "wave":
        raise ValueError(f"unknown emulator motion {motion!r}; choose from {MOTIONS}")
    with bus.lock:
        for k, (sid, servo) in enumerate(sorted(bus.servos.items())):
            if sid == 6:
                servo.hand = wave(MID + 500, 450, 4.0, 0.0, servo.clock())
            else:
                servo.hand = wave(MID, 230, 6.0, 0.9 * k, servo.clock())


class CalibrationHand:
    """The person calibrating an emulated arm: holds it in a middle pose (anywhere on the encoders, as a
    freshly assembled arm is), then swings every joint through +-`amplitude` steps once."""

    def __init__(self, bus: FeetechBusEmulator, middles: dict[int, float] | None = None, amplitude: float = 900.0):
        self.bus, self.amplitude = bus, float(amplitude)
        self.middles = middles or {sid: MID + 397.0 * ((sid * 7) % 5 - 2) for sid in bus.servos}

    def hold_middle(self) -> None:
        with self.bus.lock:
            for sid, servo in self.bus.servos.items():
                servo.hand = (lambda m: (lambda t: m))(self.middles[sid])

    def sweep(self, period_s: float = 1.0) -> None:
        """Start one full swing (down, up, back to the middle) lasting `period_s`."""
        with self.bus.lock:
            for sid, servo in self.bus.servos.items():
                t0, mid = servo.clock(), self.middles[sid]

                def hand(t, t0=t0, mid=mid):
                    x = min(max((t - t0) / period_s, 0.0), 1.0)
                    return mid - self.amplitude * math.sin(2 * math.pi * x)

                servo.hand = hand
