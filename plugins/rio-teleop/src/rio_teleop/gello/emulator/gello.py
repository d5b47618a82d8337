"""An emulated GELLO: a `DynamixelBusEmulator` with a layout's servos, mounted with known offsets and
signs (`mounting`, the truth a calibration should recover), and a hand that poses it in follower
joint angles.

    with GelloEmulator("xarm7") as g:
        g.pose([0, 0.3, 0, 1.2, 0, 1.5, 0], gripper=0.5)   # the person holds it there
        g.move(lambda t: ...)                               # or moves it: t -> (q, gripper)

`port = "emulator"` in a station starts one inside the leader node (held in the known pose, or waving
around it with `emulator_motion = "wave"`), calibrated with `mounting`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from .. import control_table as T
from ..calibration import QUARTER, GelloCalibration
from ..layouts import Layout, get_layout
from .bus import DynamixelBusEmulator

MOTIONS = ("none", "wave")


def emulator_mounting(layout: Layout, name: str = "emulator") -> GelloCalibration:
    """How an emulated leader's horns are mounted: a different multiple of pi/2 per joint (some past a
    full turn, as a multi-turn reading after power-on gives), the layout's signs, the trigger released
    at half a turn."""
    offsets = [QUARTER * ((3 * k + 1) % 7 - 2) for k in range(layout.dof)]
    g_open = math.pi
    return GelloCalibration(layout.name, name, offsets, list(layout.signs), g_open, g_open + layout.gripper_travel,
                            [0.0] * layout.dof)


class GelloEmulator:
    def __init__(self, layout: Layout | str, *, mounting: GelloCalibration | None = None, baudrate: int = 57600,
                 start: bool = True):
        self.layout = get_layout(layout) if isinstance(layout, str) else layout
        self.mounting = mounting or emulator_mounting(self.layout)
        self.bus = DynamixelBusEmulator(self.layout.ids, start=False, baudrate=baudrate)
        self.port = self.bus.port
        self.pose(self.layout.known_pose)
        if start:
            self.bus.start()

    def start(self) -> GelloEmulator:
        self.bus.start()
        return self

    def close(self) -> None:
        self.bus.close()

    def __enter__(self) -> GelloEmulator:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- the hand ---------------------------------------------------------------------------------
    def _steps(self, q: Sequence[float], gripper: float) -> dict[int, float]:
        raw = self.mounting.raw(np.asarray(q, float))
        m = self.mounting
        out = {sid: float(r) / T.RAD_PER_STEP for sid, r in zip(self.layout.joint_ids, raw, strict=True)}
        if self.layout.gripper_id is not None:
            g = m.gripper_open + (1.0 - min(max(float(gripper), 0.0), 1.0)) * (m.gripper_closed - m.gripper_open)
            out[self.layout.gripper_id] = g / T.RAD_PER_STEP
        return out

    def pose(self, q: Sequence[float], gripper: float = 1.0) -> None:
        """Hold the leader where the follower's joints would read `q` (trigger `gripper`: 1 released)."""
        steps = self._steps(q, gripper)
        with self.bus.lock:
            for sid, s in steps.items():
                self.bus.servo(sid).hand = (lambda v: (lambda t: v))(s)

    def move(self, motion: Callable[[float], tuple[Sequence[float], float]]) -> None:
        """Move the leader along `motion(t) -> (q, gripper)` (t: the servo clock, `rio.clock.now()`)."""
        cache: dict[float, dict[int, float]] = {}

        def at(t: float) -> dict[int, float]:
            if t not in cache:
                cache.clear()
                cache[t] = self._steps(*motion(t))
            return cache[t]

        with self.bus.lock:
            for sid in self.layout.ids:
                self.bus.servo(sid).hand = (lambda i: (lambda t: at(t)[i]))(sid)

    def wave(self, amplitude: float = 0.25, period_s: float = 6.0) -> None:
        """Every joint swings around the known pose (phase-shifted), the trigger squeezes and releases."""
        q0 = np.asarray(self.layout.known_pose, float)
        phase = 0.9 * np.arange(self.layout.dof)
        t0 = self.bus.servo(self.layout.ids[0]).clock()

        def motion(t: float):
            w = 2 * math.pi * (t - t0) / period_s
            return q0 + amplitude * np.sin(w + phase), 0.5 + 0.5 * math.cos(w * 1.5)

        self.move(motion)

    def joints(self) -> np.ndarray:
        """The follower angles the leader is in now (from the servos, through the mounting)."""
        with self.bus.lock:
            raw = []
            for sid in self.layout.joint_ids:
                s = self.bus.servo(sid)
                s.update()
                raw.append(s.present() * T.RAD_PER_STEP)
        return self.mounting.joints(np.asarray(raw))


def attach_motion(gello: GelloEmulator, motion: str) -> None:
    if motion == "none":
        return
    if motion != "wave":
        raise ValueError(f"unknown emulator motion {motion!r}; choose from {MOTIONS}")
    gello.wave()
